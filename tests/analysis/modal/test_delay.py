"""The responses' delay behind the force, read off a modal fit's poles
(`analysis.modal._delay`): a 2-DOF receptance column delayed by a known number of samples,
noise-free and with 1 % noise on the lines; its 95 % interval covering the truth; stated to
the interval's resolution; read through `fit_linear` on the noisy multisine twin of
`tests/daq_twin.py`, whole and fractional, and never on that twin without a delay."""

import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

from analysis.models import Model
from analysis.modal import DelayReading, fit_linear
from analysis.modal._delay import LEVEL, STEP, response_delay
from analysis.plant import multisine, periodic, simulate
from analysis.recordings import DaqArtifacts, PeriodicLayout, Recording, apply_daq_artifacts

sys.path.append(str(Path(__file__).resolve().parents[2]))
import daq_twin as T  # noqa: E402

FS = 512.0


def _column(delay: float, noise: float, seed: int = 0):
    k = np.array([[3.0e4, -1.5e4], [-1.5e4, 1.5e4]])
    m = np.diag([1.0, 0.5])
    model = Model(m, 4e-4 * k + m, k, [], "2-DOF")
    f = np.arange(5.0, 100.0, 0.5)
    H = model.linear_frf(f, [0])[:, :, 0] * np.exp(-2j * np.pi * f * delay / FS)[:, None]
    std = noise * np.abs(H)
    rng = np.random.default_rng(seed)
    H = H + std * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    w, v = np.linalg.eig(np.linalg.solve(m, k))
    # the model's poles (proportional damping c = 4e-4 k + m)
    wn = np.sqrt(w)
    zeta = 0.5 * (4e-4 * wn + 1.0 / wn)
    poles = -zeta * wn + 1j * wn * np.sqrt(1 - zeta ** 2)
    return f, H, std, poles


@pytest.mark.parametrize("delay", [1.0, -0.5, 2.3])
def test_delay_found(delay):
    f, H, std, poles = _column(delay, 0.0)
    assert response_delay(f, H, None, poles, FS).samples == pytest.approx(delay, abs=STEP)


def test_delay_found_through_noise():
    f, H, std, poles = _column(1.0, 0.01)
    assert response_delay(f, H, std, poles, FS).samples == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_delay_reads_none(seed):
    """With no delay, noise alone does not pass the F test (alpha 1e-3)."""
    f, H, std, poles = _column(0.0, 0.01, seed)
    assert response_delay(f, H, std, poles, FS) == DelayReading()


def test_interval_covers_the_delay():
    """1 % noise, 12 draws of a 0.3-sample delay: the 95 % profile interval holds the truth
    in at least 9 (fewer happens with probability 0.2 % if its coverage is 95 %), and it
    is narrow (the delay is resolved to a few thousandths of a sample there)."""
    draws = [response_delay(*_column(0.3, 0.01, seed)[:3], _column(0.3, 0.0)[3], FS)
             for seed in range(12)]
    held = sum(d.low <= 0.3 <= d.high for d in draws)
    assert scipy.stats.binom.cdf(8, 12, LEVEL) < 0.003 and held >= 9
    assert all(0 < d.high - d.low < 0.02 for d in draws)
    assert all(d.stated == 0.3 for d in draws if d.low <= 0.3 <= d.high)


@pytest.mark.parametrize("reading, stated", [
    (DelayReading(1.0321, 0.97, 1.06), 1),               # a whole sample within the interval
    (DelayReading(0.444, 0.38, 0.47), 0.4),
    (DelayReading(0.444, 0.428, 0.461), 0.44),
    (DelayReading(0.4449, 0.4437, 0.4460), 0.445),
    (DelayReading(-0.52, -0.61, -0.43), -0.5)])
def test_stated_to_the_interval(reading, stated):
    """The fewest decimals inside the interval, nearest the reading."""
    assert reading.stated == stated


def _twin(delay: float, seed: int, noise: float = T.NOISE) -> Recording:
    """`daq_twin`'s 2 N level (one realization, 1 + 3 periods), its sensor and force noise
    (``noise`` x rms) drawn with ``seed``, the responses ``delay`` samples late (a
    band-limited phase ramp, `DaqArtifacts.delay`)."""
    force = periodic(multisine(T.PERIOD, T.FS, T.BAND, T.LEVELS[0], seed=3), 4)
    acc = simulate(T.truth(), force[:, None], T.FS, [0], response_kind="acceleration")
    rng = np.random.default_rng(seed)
    acc = acc + noise * acc.std(axis=0) * rng.standard_normal(acc.shape)
    force = force + noise * force.std() * rng.standard_normal(force.shape)
    rec = Recording(T.FS, "random", np.array([0]), force[:, None], acc, "acceleration",
                    layout=PeriodicLayout(T.PERIOD, 1, 3, 1))
    return apply_daq_artifacts(rec, DaqArtifacts(delay=delay), rng) if delay else rec


@pytest.mark.parametrize("delay", [0.5, 1.0])
def test_fit_linear_reads_the_twin_delay_within_its_interval(delay):
    """Through `fit_linear` on the noisy twin (0.5 % noise, 3 periods): the noise-free
    twin's reading (the simulated data's own offset: +0.003-0.004 sample, a discretisation
    of the plant) within 0.01 sample of the delay, and held by the noisy twin's 95 %
    interval in at least 4 of 6 noise draws (fewer: probability 0.2 % at 95 % coverage);
    stated as the shortest decimal inside the interval: the delay itself when it is inside."""
    clean = fit_linear(_twin(delay, 0, noise=1e-7)).delay.samples
    assert clean == pytest.approx(delay, abs=0.01)
    draws = [fit_linear(_twin(delay, seed)).delay for seed in range(1, 7)]
    assert sum(d.low <= clean <= d.high for d in draws) >= 4
    assert all(0 < d.high - d.low < 0.05 and d.low <= d.stated <= d.high
               and d.stated == round(d.stated, 3) for d in draws)    # to the resolution
    assert all(d.stated == delay for d in draws if d.low <= delay <= d.high)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_fit_linear_reads_no_delay_on_the_twin_without_one(seed):
    assert fit_linear(_twin(0.0, seed)).delay == DelayReading()
