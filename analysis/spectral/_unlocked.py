"""A sinusoid not locked to the period (mains at 50.02 Hz), fitted and taken out of the periods.

A source off the period's DFT grid leaks into the lines around its own, far beyond the
adjacent ones in the response (where the structure's response to the drive may be small),
so leaving lines out does not rid a period-averaged FRF of it. Its phase drifts from period
to period, which is how `excited_lines` (rule 7) tells it; the same drift identifies it: the
record minus its period average holds only noise and the sinusoid's drifting part. For each
candidate frequency near the drifting line, the sinusoid's own drifting part (its cos and sin
minus their period averages) is regressed on that residual, channel by channel; the
frequency explaining most of it is kept and the whole sinusoid (and its harmonics, at
multiples of that frequency, amplitudes fitted alike) is subtracted from the periods. The
periodic drive is untouched (its residual is zero), so the fit is not biased by the drive
line it sits on. Written by hand: a least-squares fit of a few sinusoids of one unknown
frequency against a periodic nuisance has no library routine.
"""

from __future__ import annotations

import numpy as np

#: candidate frequencies per search stage, over +-half a line, then +-1/40 line
SEARCH_POINTS = 41
#: harmonics of the fitted frequency also taken out (up to fs/2)
HARMONICS = 3
#: a candidate whose sinusoids drift by less than this share of their size over the periods
#: is too close to the grid to be told from the drive (its fit would blow noise up)
MIN_DRIFT = 0.1


def _drifting(basis: np.ndarray, periods: int) -> np.ndarray:
    """``basis`` (P*N, k) minus its period average, tiled."""
    b = basis.reshape(periods, -1, basis.shape[1])
    return (b - b.mean(axis=0)).reshape(basis.shape)


def _basis(freqs: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Cosines then sines of ``freqs`` at times ``t``, shape (len(t), 2 len(freqs))."""
    ph = 2 * np.pi * np.outer(t, freqs)
    return np.concatenate([np.cos(ph), np.sin(ph)], axis=1)


def _explained(f: float, t: np.ndarray, resid: np.ndarray, periods: int,
               fs: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Residual energy explained by the drifting part of ``f`` and its harmonics; the
    coefficients and the full basis."""
    freqs = f * np.arange(1, HARMONICS + 1)
    freqs = freqs[freqs < fs / 2]
    full = _basis(freqs, t)
    drift = _drifting(full, periods)
    if np.min(np.linalg.norm(drift, axis=0) / np.linalg.norm(full, axis=0)) < MIN_DRIFT:
        return 0.0, np.zeros((full.shape[1], resid.shape[1])), full
    coef, *_ = np.linalg.lstsq(drift, resid, rcond=None)
    return float(np.sum((drift @ coef) ** 2)), coef, full


def remove_unlocked(per: np.ndarray, fs: float, line_hz: float) -> tuple[np.ndarray, float]:
    """Periods with the unlocked sinusoid near ``line_hz`` (and its harmonics) taken out.

    Parameters
    ----------
    per : ndarray, shape (M, P, N, n_ch)
        Steady periods of each realization (`analysis.recordings.steady_periods`), ``P >= 2``.
    fs : float
        Sample rate, Hz.
    line_hz : float
        The DFT line whose period-to-period drift named the source.

    Returns
    -------
    per : ndarray
        A copy without the sinusoid (fitted per realization, its frequency common).
    freq_hz : float
        The fitted frequency.
    """
    m, p, n, _ = per.shape
    df = fs / n
    t = np.arange(p * n) / fs
    resid = [(per[r] - per[r].mean(axis=0)).reshape(p * n, -1) for r in range(m)]
    best, width = line_hz, 0.5 * df
    for _ in range(2):
        cands = best + np.linspace(-width, width, SEARCH_POINTS)
        cands = cands[np.abs(cands - line_hz) > 1e-9 * df]      # on the grid: no drift
        score = [sum(_explained(f, t, r, p, fs)[0] for r in resid) for f in cands]
        best, width = float(cands[int(np.argmax(score))]), width / 20
    out = per.copy()
    for r in range(m):
        _, coef, full = _explained(best, t, resid[r], p, fs)
        out[r] -= (full @ coef).reshape(p, n, -1)
    return out, best
