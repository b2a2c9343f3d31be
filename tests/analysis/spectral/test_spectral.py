"""Spectral core: conjugation convention, H1, coherences, conditioned inputs."""

import numpy as np
import pytest
import scipy.signal

from analysis.errors import InputError
from analysis.spectral import (conditioned_inputs, h1, multiple_coherence, ordinary_coherence,
                               spectral_matrix)


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    n = 2**16
    a, b = rng.standard_normal(n), rng.standard_normal(n)
    r2 = 0.6 * a + b                                  # partially correlated inputs
    y = 2.0 * np.roll(a, 3) - 0.5 * r2 + 0.05 * rng.standard_normal(n)
    return np.column_stack([y, a, r2])


def test_matches_scipy_csd_and_pins_conjugation(data):
    sp = spectral_matrix(data, 1000.0, nperseg=1024)
    _, c = scipy.signal.csd(data[:, 1], data[:, 0], 1000.0, nperseg=1024)
    # S[y, x] = E[Y X*] = scipy csd(x, y)
    np.testing.assert_allclose(sp.S[:, 0, 1], c, rtol=1e-10, atol=1e-12 * np.abs(c).max())


def test_delay_gives_negative_phase():
    rng = np.random.default_rng(1)
    x = rng.standard_normal(2**16)
    tau = 2
    y = np.concatenate([np.zeros(tau), x[:-tau]])
    sp = spectral_matrix(np.column_stack([y, x]), 1000.0, nperseg=4096)
    h = h1(sp.S[:, :1, 1:], sp.S[:, 1:, 1:])[:, 0, 0]
    k = 100
    assert np.angle(h[k]) == pytest.approx(-2 * np.pi * sp.freqs[k] * tau / 1000.0, abs=1e-2)


def test_h1_and_conditioned_coherences(data):
    sp = spectral_matrix(data, 1000.0, nperseg=1024, band=(10, 400))
    s_xx = sp.S[:, :1, :1].diagonal(axis1=1, axis2=2).real
    s_xr, s_rr = sp.S[:, :1, 1:], sp.S[:, 1:, 1:]
    h = h1(s_xr, s_rr)
    assert np.median(np.abs(h[:, 0, 1] + 0.5)) < 0.01
    gm = multiple_coherence(s_xx, s_xr, s_rr)
    cond = conditioned_inputs(s_xx, s_xr, s_rr)
    np.testing.assert_allclose(cond.coherence.sum(axis=2), gm, atol=1e-12)
    uu = cond.phi @ s_rr @ cond.phi.conj().transpose(0, 2, 1)
    assert np.abs(uu[:, 0, 1]).max() < 1e-10 * np.abs(uu).max()
    np.testing.assert_allclose(cond.transfer(), h, rtol=1e-9)
    assert ordinary_coherence(sp.S, 1, 2).mean() > 0.2        # inputs really correlated


def test_all_pairs_match_scipy_with_offsets_band_and_channel_list(data):
    """Every pair, several chunks of segments, mean removal of large offsets, a band, a
    window whose spectrum reaches beyond the DC bins, and channels given as a list."""
    rng = np.random.default_rng(2)
    d = data + np.array([5.0, -3.0, 40.0]) + 0.01 * rng.standard_normal(data.shape)
    kw = dict(nperseg=1000, window=("tukey", 0.25), noverlap=500)
    sp = spectral_matrix(d, 1000.0, nperseg=1000, window=("tukey", 0.25), band=(0, 300))
    assert sp.n_avg == 1 + (d.shape[0] - 1000) // 500
    for a in range(3):
        for b in range(3):
            f, c = scipy.signal.csd(d[:, b], d[:, a], 1000.0, **kw)
            keep = f <= 300
            np.testing.assert_allclose(sp.S[:, a, b], c[keep], rtol=1e-9,
                                       atol=1e-11 * np.abs(c).max())
    same = spectral_matrix([d[:, 0], d[:, 1], d[:, 2]], 1000.0, nperseg=1000,
                           window=("tukey", 0.25), band=(0, 300))
    np.testing.assert_array_equal(same.S, sp.S)


def test_bad_channels():
    with pytest.raises(InputError, match="common length"):
        spectral_matrix([np.zeros(100), np.zeros(99)], 1.0, nperseg=32)
    with pytest.raises(InputError, match="shape"):
        spectral_matrix(np.zeros(100), 1.0, nperseg=32)
    for bad in (0, -4, 3, 16.0, True):
        with pytest.raises(InputError, match="nperseg"):
            spectral_matrix(np.zeros((100, 2)), 1.0, nperseg=bad)
