"""Excitation generators: level, band content, determinism, plan ordering."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.plant import (burst_random, multisine, periodic, random_gaussian, sine_block,
                            stepped_sine_plan, swept_sine)

FS = 4096.0


def _power_outside(x, fs, band):
    spec = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(x.size, 1 / fs)
    out = (f < band[0]) | (f > band[1])
    return spec[out].sum() / spec.sum()


def test_random_gaussian_level_band_determinism():
    x = random_gaussian(16384, FS, (20, 500), 3.0, seed=5)
    assert np.sqrt(np.mean(x ** 2)) == pytest.approx(3.0, rel=1e-12)
    assert _power_outside(x, FS, (20, 500)) < 1e-25
    np.testing.assert_array_equal(x, random_gaussian(16384, FS, (20, 500), 3.0, seed=5))
    assert not np.array_equal(x, random_gaussian(16384, FS, (20, 500), 3.0, seed=6))
    # Gaussian amplitude distribution: kurtosis 3 within sampling error
    assert np.mean(x ** 4) / np.mean(x ** 2) ** 2 == pytest.approx(3.0, abs=0.2)


@pytest.mark.parametrize("phases", ["random", "schroeder"])
def test_multisine_flat_lines_in_band(phases):
    n = 4096
    x = multisine(n, FS, (10, 300), 2.0, seed=1, phases=phases)
    assert np.sqrt(np.mean(x ** 2)) == pytest.approx(2.0, rel=1e-12)
    amp = np.abs(np.fft.rfft(x))
    f = np.fft.rfftfreq(n, 1 / FS)
    inside = (f >= 10) & (f <= 300)
    np.testing.assert_allclose(amp[inside], amp[inside][0], rtol=1e-9)
    assert amp[~inside].max() < 1e-9 * amp[inside][0]
    rep = periodic(x, 3)
    np.testing.assert_array_equal(rep[n:2 * n], x)
    if phases == "schroeder":   # low crest factor
        assert np.abs(x).max() / 2.0 < 2.0


def test_burst_random():
    x = burst_random(8192, FS, (20, 400), 1.5, 0.5, seed=2)
    assert np.all(x[4096:] == 0.0)
    assert np.sqrt(np.mean(x[:4096] ** 2)) == pytest.approx(1.5, rel=1e-12)
    assert _power_outside(x, FS, (20, 400)) < 0.01     # tapered switching: little leakage
    np.testing.assert_array_equal(x, burst_random(8192, FS, (20, 400), 1.5, 0.5, seed=2))


def test_stepped_sine_plan_ordering_and_lengths():
    up = stepped_sine_plan((10.0, 100.0, 5, "log"), "up", 10, 20, FS)
    assert [s.freq for s in up] == pytest.approx(np.geomspace(10, 100, 5))
    down = stepped_sine_plan([30.0, 10.0, 20.0], "down", 10, 20, FS)
    assert [s.freq for s in down] == [30.0, 20.0, 10.0]
    step = down[0]
    assert step.n_settle >= 10 * FS / 30 and step.n_settle < 10 * FS / 30 + 1
    assert step.n_measure >= 20 * FS / 30 and step.n_measure < 20 * FS / 30 + 1
    lin = stepped_sine_plan((10.0, 50.0, 5, "linear"), fs=FS)
    assert [s.freq for s in lin] == pytest.approx([10, 20, 30, 40, 50])


def test_sine_block_and_sweep():
    s = sine_block(100.0, 2.0, 4096, FS, phase=np.pi / 2)
    assert s[0] == pytest.approx(2.0)
    assert np.sqrt(np.mean(s ** 2)) == pytest.approx(2.0 / np.sqrt(2), rel=1e-3)
    # block continuation: the next block starts at phase + 2 pi f n / fs
    nxt = sine_block(100.0, 2.0, 10, FS, phase=np.pi / 2 + 2 * np.pi * 100 * 4096 / FS)
    np.testing.assert_allclose(nxt, sine_block(100.0, 2.0, 4106, FS, np.pi / 2)[4096:],
                               atol=1e-9)
    sweep = swept_sine(10.0, 400.0, 4.0, FS, 1.5)
    assert sweep.size == 4 * FS and sweep[0] == pytest.approx(0.0, abs=1e-12)
    assert np.abs(sweep).max() == pytest.approx(1.5, rel=1e-3)
    assert _power_outside(sweep, FS, (5, 600)) < 0.01


@pytest.mark.parametrize("call", [
    lambda: random_gaussian(1000, FS, (500, 100), 1.0),
    lambda: random_gaussian(1000, FS, (10, 3000), 1.0),
    lambda: random_gaussian(1000, FS, (10, 20), -1.0),
    lambda: multisine(64, FS, (1, 2), 1.0),
    lambda: multisine(1024, FS, (10, 100), 1.0, phases="clipped"),
    lambda: burst_random(1000, FS, (10, 100), 1.0, 1.5),
    lambda: stepped_sine_plan([10.0, 3000.0], fs=FS),
    lambda: stepped_sine_plan([10.0], direction="sideways", fs=FS),
    lambda: stepped_sine_plan([10.0]),
    lambda: swept_sine(10, 400, 1.0, FS, 1.0, method="zigzag"),
])
def test_bad_settings_raise_input_error(call):
    with pytest.raises(InputError):
        call()
