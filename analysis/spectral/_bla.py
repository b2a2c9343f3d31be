"""Best linear approximation and nonlinearity detection from periodic-random data.

The robust method of Pintelon & Schoukens (System Identification, 2nd ed., 2012, section 4.3)
on ``M`` realizations of a random-phase multisine, each with ``P`` steady periods:

* per realization, the period average ``U_m, Y_m`` at the excited lines and its noise
  (co)variances from the spread over periods; ``G_m = Y_m / U_m`` with its noise variance
  ``(s_Y^2 + |G|^2 s_U^2 - 2 Re(G^* s_YU)) / |U|^2`` (first order);
* the BLA ``G = mean_m G_m``, its noise variance ``sum_m var_n(G_m) / M^2`` and its total
  variance ``sum_m |G_m - G|^2 / (M (M - 1))``.

A linear system leaves only noise, so both variances agree; stochastic nonlinear distortions
(the part of the response a linear model cannot explain, which changes with the random
phases) make the total exceed the noise. Per line, ``total / noise`` is F-distributed with
``(2 (M - 1), 2 M (P - 1))`` degrees of freedom for a linear system (Gaussian noise): lines
above its 99 % quantile flag distortion, and far more than 1 % of such lines detect a
nonlinearity (`analysis.detection.bla_summary`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.fft
import scipy.stats

from ..errors import InputError
from ..recordings import steady_periods
from ._lines import Interference, MainsCaveat, excited_lines
from ._sine_fit import hold_gain
from ._unlocked import remove_unlocked

DETECT_QUANTILE = 0.99
"""Per-line quantile of the linear-system F distribution of total / noise variance."""


@dataclass
class BLA:
    """Best linear approximation of one level.

    Attributes
    ----------
    freqs : ndarray, shape (n_f,)
        Excited lines, Hz.
    G : ndarray, shape (n_f, n_out), complex
        BLA from the force to each response.
    var_noise, var_total : ndarray, shape (n_f, n_out)
        Noise and total variance of ``G`` (total: NaN with one realization, where the
        stochastic distortions cannot be told from the linear part; noise: NaN with one
        period per realization, where it cannot be told from the distortions).
    coherence : ndarray, shape (n_f, n_out)
        Coherence of the period averages across realizations (noise and distortion lower
        it; with few realizations it is biased high by about ``1 / M``); with one
        realization, that of a single period against the noise from the period spread.
    realizations, periods : int
    interference : tuple of Interference
        Steady force lines outside the designed band(s), left out (`analysis.spectral._lines`).
    """

    freqs: np.ndarray
    G: np.ndarray
    var_noise: np.ndarray
    var_total: np.ndarray
    coherence: np.ndarray
    realizations: int
    periods: int
    interference: tuple[Interference, ...] = ()
    caveat: MainsCaveat | None = None
    """One realization with mains multiples on the drive lines (`analysis.spectral.
    MainsCaveat`), else None."""

    @property
    def var_weight(self) -> np.ndarray:
        """Variance to weight a fit of ``G`` with: the noise's, or the total with one period
        per realization (noise and distortions then together, the robust method's)."""
        return self.var_noise if self.periods >= 2 else self.var_total

    @property
    def var_distortion(self) -> np.ndarray:
        """Variance of ``G`` due to stochastic nonlinear distortions (>= 0)."""
        return np.maximum(self.var_total - self.var_noise, 0.0)

    def threshold(self) -> float:
        """99 % quantile of ``var_total / var_noise`` for a linear system."""
        m, p = self.realizations, self.periods
        return float(scipy.stats.f.ppf(DETECT_QUANTILE, 2 * (m - 1), 2 * m * (p - 1)))

def _period_spectra(per: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Period-averaged force ``U`` (M, n_lines) and responses ``Y`` (M, n_lines, n_out) of
    steady periods (M, P, N, 1 + n_out), and each period's deviation from the average."""
    spec = scipy.fft.rfft(per, axis=2)
    mean = spec.mean(axis=1)
    return mean[..., 0], mean[..., 1:], spec - mean[:, None]


def _without_unlocked(per: np.ndarray, fs: float, drifting: tuple[float, ...],
                      interference: tuple[Interference, ...]
                      ) -> tuple[np.ndarray, tuple[Interference, ...]]:
    """The periods without the unlocked sources on the ``drifting`` lines
    (`analysis.spectral._unlocked`), and the interference naming their fitted frequencies."""
    for hz in drifting:
        per, fitted = remove_unlocked(per, fs, hz)
        interference = tuple(replace(i, unlocked_hz=fitted) if i.freq_hz == hz else i
                             for i in interference)
    return per, interference


def best_linear_approximation(force: np.ndarray, response: np.ndarray, fs: float,
                              period: int, *, transient_periods: int = 1,
                              realizations: int = 1, force_hold: str | None = None,
                              band: tuple[float, float] | None = None) -> BLA:
    """BLA, noise and total variance of a periodic-random record (module docstring).

    Parameters
    ----------
    force : ndarray, shape (n,) or (n, 1)
        The one applied force.
    response : ndarray, shape (n, n_out)
    fs : float
        Sample rate, Hz.
    period, transient_periods, realizations
        Record layout (`analysis.recordings.steady_periods`).
    force_hold : {"none", "linear"}, optional
        How the force acted between its samples (`analysis.spectral.hold_gain`).
    band : (lo, hi), optional
        Lines considered, Hz (applied before the excited lines are picked,
        `analysis.spectral.excited_lines`).

    Returns
    -------
    BLA
    """
    f = np.asarray(force, dtype=float)
    f = f[:, None] if f.ndim == 1 else f
    if f.shape[1] != 1:
        raise InputError(f"the BLA takes one force channel, got {f.shape[1]}; analyse each "
                         "shaker's run separately")
    x = np.asarray(response, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    per = steady_periods(np.concatenate([f, x], axis=1), period,
                         transient_periods=transient_periods, realizations=realizations)
    n_p = per.shape[1]
    if n_p < 2 and per.shape[0] < 2:
        raise InputError("the BLA needs 2 or more steady periods or realizations; the record "
                         "holds one period of one realization")
    U, Y, dev = _period_spectra(per)
    scale = 1.0 / (max(n_p - 1, 1) * n_p)                   # variance of a period mean
    all_freqs = np.arange(U.shape[1]) * fs / period
    picked = excited_lines(all_freqs, np.abs(U).mean(axis=0) ** 2,
                           (np.abs(dev[..., 0]) ** 2).sum(axis=1).mean(axis=0) * scale,
                           band=band, amplitudes=np.abs(U))
    interference = picked.interference
    if picked.drifting and n_p >= 2:     # an unlocked source: fitted and taken out of the periods
        per, interference = _without_unlocked(per, fs, picked.drifting, interference)
        U, Y, dev = _period_spectra(per)
    lines = picked.lines
    if lines.size == 0:
        raise InputError("the force excites no DFT line of the period"
                         + ("" if band is None else f" in {band[0]:g}-{band[1]:g} Hz; check "
                            "the band"))
    U, Y, dev = U[:, lines], Y[:, lines], dev[:, :, lines]
    s_uu = (np.abs(dev[..., 0]) ** 2).sum(axis=1) * scale                  # (M, n_f)
    s_yy = (np.abs(dev[..., 1:]) ** 2).sum(axis=1) * scale                 # (M, n_f, n_out)
    s_yu = (dev[..., 1:] * dev[..., :1].conj()).sum(axis=1) * scale
    Gm = Y / U[..., None]
    var_m = (s_yy + np.abs(Gm) ** 2 * s_uu[..., None]
             - 2 * (Gm.conj() * s_yu).real) / (np.abs(U) ** 2)[..., None]
    m = Gm.shape[0]
    G = Gm.mean(axis=0)
    var_noise = np.maximum(var_m, 0.0).sum(axis=0) / m**2
    if n_p < 2:     # one period per realization: no spread over periods, the noise unknown
        var_noise = np.full_like(var_noise, np.nan)
    if m >= 2:
        var_total = (np.abs(Gm - G) ** 2).sum(axis=0) / (m * (m - 1))
        cross = np.abs((Y * U.conj()[..., None]).sum(axis=0)) ** 2
        coherence = cross / ((np.abs(U) ** 2).sum(axis=0)[:, None]
                             * (np.abs(Y) ** 2).sum(axis=0))
    else:   # one realization: no total variance; coherence of one period against the noise
        var_total = np.full_like(var_noise, np.nan)
        signal = np.abs(G) ** 2
        coherence = signal / np.maximum(signal + n_p * var_noise, 1e-300)
    freqs = lines * fs / period
    gain = hold_gain(freqs, fs, force_hold)[:, None]
    return BLA(freqs, G / gain, var_noise / gain**2, var_total / gain**2, coherence, m, n_p,
               interference, picked.caveat())
