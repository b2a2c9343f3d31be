"""The modal fit on the lines it is given: multisines with lines left out (every second line,
30 % at random), where pyEMA's FFT-based LSCF needs every line of a grid through 0 Hz. The
diagram then runs the same estimator on the measured lines (`analysis.modal._lscf`)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import f16_twin as T
from analysis.modal import fit_linear
from analysis.modal._ema import stabilisation
from analysis.modal._lscf import lscf_poles

FN = np.array([8.0, 17.0, 31.0])
ZETA = np.array([0.02, 0.01, 0.015])


def _column(f: np.ndarray) -> np.ndarray:
    w = 2 * np.pi * f
    return sum(np.outer(1 / ((2 * np.pi * fn) ** 2 - w ** 2 + 2j * z * 2 * np.pi * fn * w),
                        [1.0, 0.5 * (-1) ** i])
               for i, (fn, z) in enumerate(zip(FN, ZETA)))


def _in_band(pf, pz, lo=2.0, hi=45.0):
    pf, pz = np.asarray(pf), np.asarray(pz)
    ok = (pf > lo) & (pf < hi) & (pz > 0) & (pz < 0.5)
    order = np.argsort(pf[ok])
    return pf[ok][order], pz[ok][order]


def test_lscf_on_the_lines_is_pyemas_lscf_and_needs_no_missing_line():
    """Noise-free three modes: both give the same poles (at orders 6 and 12, within 1e-3: the
    estimators' rounding at order 6, where the z-domain model is not yet exact); at order 12
    the true poles within 1e-5 (a z-domain model of a continuous-time FRF: measured 1.0e-6),
    also with 40 % of the lines missing."""
    from pyEMA import Model as LSCF
    f = np.arange(0.0, 45.01, 0.1)
    h = _column(f)
    lscf = LSCF(frf=h.T, freq=f, lower=2.0, upper=f[-1], pol_order_high=10,
                frf_form="receptance")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        lscf.get_poles(method="lscf", show_progress=False)
    sel = f >= 2.0
    mine_f, mine_z = lscf_poles(f[sel], h[sel], 20)
    for k in (2, 5):               # orders 6 and 12
        a, b = _in_band(lscf.pole_freq[k], lscf.pole_xi[k]), _in_band(mine_f[k], mine_z[k])
        np.testing.assert_allclose(b[0], a[0], rtol=1e-3)
    np.testing.assert_allclose(_in_band(mine_f[5], mine_z[5])[0], FN, rtol=1e-5)
    rng = np.random.default_rng(0)
    kept = np.sort(rng.choice(np.flatnonzero(sel), int(0.6 * sel.sum()), replace=False))
    gap_f, gap_z = lscf_poles(f[kept], h[kept], 12)
    pf, pz = _in_band(gap_f[5], gap_z[5])
    np.testing.assert_allclose(pf, FN, rtol=1e-5)
    np.testing.assert_allclose(pz, ZETA, rtol=1e-3)
    # the stabilisation diagram takes such lines instead of stopping
    stab = stabilisation(f[kept], h[kept], (2.0, 45.0), max_order=12)
    np.testing.assert_allclose(np.sort(stab.freqs_hz[-1]), FN, rtol=1e-5)


@pytest.mark.parametrize("lines", ["all", "every-2nd", "random"])
def test_fit_linear_on_a_gappy_twin_recovers_its_modes(lines):
    """The linear F-16-like twin (2 % accelerometer noise, 1 % force noise, 4096-sample
    periods, 4 steady periods), its multisine thinned. Measured: every line 8 of 8 modes,
    frequencies within 0.04 %, damping within 6 % (the 2.7 and 3.3 Hz modes' half-power
    bandwidths, 0.08 and 0.10 Hz, are at or below the 0.098 Hz line spacing); every second
    line: 8 of 8, 0.13 %, 7.5 %; 30 % at random: 8 of 8, 0.06 %, 8.7 %. Tolerances: 0.2 % and
    10 %, the clean fit held to the same."""
    lin = T.linear_structure()
    fn = np.sort(lin.natural_frequencies())
    fn = fn[(fn > T.BAND[0]) & (fn < T.BAND[1])]
    rec = T.recordings(T.twin(False, 4096, 4, (1,), lines=lines))[0]
    fit = fit_linear(rec, T.BAND)
    assert fit.modes.freqs_hz.size == fn.size == 8
    np.testing.assert_allclose(fit.modes.freqs_hz, fn, rtol=0.002)
    np.testing.assert_allclose(fit.modes.damping, T.ZETA, rtol=0.10)
    assert fit.frf_error.max() < 0.05
