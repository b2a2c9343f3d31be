"""Spectral core: conjugation convention, H1, coherences, conditioned inputs."""

import numpy as np
import pytest
import scipy.signal

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
