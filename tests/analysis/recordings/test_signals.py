"""Frequency-domain integration/differentiation and band selection."""

import numpy as np
import pytest

from analysis.recordings import change_kind, excitation_band, to_kinematics


@pytest.fixture(scope="module")
def sines():
    fs, n = 1000.0, 2**15
    t = np.arange(n) / fs
    rng = np.random.default_rng(1)
    fr, ph = rng.uniform(5, 200, 20), rng.uniform(0, 6.3, 20)
    x = sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(fr, ph))
    v = sum(2 * np.pi * f * np.cos(2 * np.pi * f * t + p) for f, p in zip(fr, ph))
    a = -sum((2 * np.pi * f) ** 2 * np.sin(2 * np.pi * f * t + p) for f, p in zip(fr, ph))
    return fs, x, v, a


def test_differentiation_beats_finite_differences(sines):
    fs, x, v, _ = sines
    e = 500
    spectral = np.abs(change_kind(x, fs, 1) - v)[e:-e].max() / np.abs(v).max()
    fd = np.abs(np.gradient(x, 1 / fs) - v)[e:-e].max() / np.abs(v).max()
    assert spectral < 1e-5 < 1e-2 < fd


def test_double_integration(sines):
    fs, x, v, a = sines
    xi, vi = to_kinematics(a[:, None], fs, "acceleration", highpass=2.0)
    e = 2000
    xd = x - np.polyval(np.polyfit(np.arange(x.size), x, 1), np.arange(x.size))
    # the integration constants are not in the data: compare with x less its linear trend;
    # what remains is the 2 Hz high-pass acting on that trend-free reference
    assert np.abs(xi[e:-e, 0] - xd[e:-e]).max() < 1e-3 * np.abs(x).max()
    vd = v - np.polyval(np.polyfit(np.arange(v.size), v, 1), np.arange(v.size))
    assert np.abs(vi[e:-e, 0] - vd[e:-e]).max() < 1e-3 * np.abs(v).max()


def test_excitation_band():
    f = np.linspace(0, 500, 501)
    p = np.where((f >= 20) & (f <= 300), 1.0, 1e-6)
    assert excitation_band(f, p) == (20.0, 300.0)


def test_periodic_helpers():
    from analysis.recordings import period_spectra, periodic_kinematics, steady_periods
    fs, n = 1000.0, 1000
    t = np.arange(3 * 2 * n) / fs
    x = np.sin(2 * np.pi * 7 * t) + 0.5 * np.cos(2 * np.pi * 40 * t)
    per = steady_periods(np.c_[x, 2 * x], n, transient_periods=1, realizations=2)
    assert per.shape == (2, 2, n, 2)
    xd, v = periodic_kinematics(per, fs, "displacement")
    tt = t[:n]
    vt = 2 * np.pi * 7 * np.cos(2 * np.pi * 7 * tt) - 40 * np.pi * np.sin(2 * np.pi * 40 * tt)
    assert np.abs(v[0, 0, :, 0] - vt).max() < 1e-9 * np.abs(vt).max()   # exact, no edges
    xi, _ = periodic_kinematics(v, fs, "velocity")
    np.testing.assert_allclose(xi, xd, atol=1e-9)
    rng = np.random.default_rng(0)
    noisy = np.tile(per[:, :1], (1, 16, 1, 1)) + 0.1 * rng.standard_normal((2, 16, n, 2))
    sig, noise = period_spectra(noisy)
    # white noise of variance 0.01: |DFT|^2 = n 0.01 per line, / 16 for the average
    assert np.median(noise) == pytest.approx(n * 0.01 / 16, rel=0.05)
    with pytest.raises(Exception, match="whole"):
        steady_periods(x[:-1], n)
