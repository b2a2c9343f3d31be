"""Frequency-domain integration/differentiation and band selection."""

import numpy as np
import pytest

from analysis.signals import change_kind, excitation_band, to_kinematics


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
