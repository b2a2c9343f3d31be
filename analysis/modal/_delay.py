"""Delay of the response channels behind the force, read off a modal fit's poles.

A DAQ whose anti-alias filters differ between the force and the response channels (a group
delay of a sample or so) multiplies every measured FRF by ``exp(-i w tau)``. The poles
survive it (the stabilisation diagram finds them), but no sum of modes holds the phase ramp:
on the artifact twin of `tests/daq_twin.py` (one-sample delay at fs 512 Hz, modes at 15 and
36 Hz) the written model missed the FRFs by 49 % / 35 % with the right modes. With the poles
fixed, a real-mode FRF is linear in its (imaginary) residues and real residual terms, so the
delay is the one that leaves the least-squares residual of ``H exp(i w tau)`` smallest (a
grid over +-`MAX_DELAY` samples, each point one linear solve).
"""

from __future__ import annotations

import numpy as np
import scipy.stats

#: largest delay searched, samples (anti-alias group delays differ by a few samples at most)
MAX_DELAY = 3.0
#: grid step of the search, samples
STEP = 0.01
#: significance of the F test that keeps a delay (one parameter more than none)
ALPHA = 1e-3


def response_delay(freqs: np.ndarray, H: np.ndarray, std: np.ndarray | None,
                   poles: np.ndarray, fs: float) -> float:
    """Delay of the responses behind the force, samples (0 unless significant).

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Lines of the fit band, Hz.
    H : ndarray, complex, shape (n_f, n_out)
        Measured receptance column.
    std : ndarray, shape (n_f, n_out), optional
        Its noise standard deviation (weights); unit weights when None.
    poles : ndarray, complex, shape (n_modes,)
        Poles of a modal fit of ``H`` (rad/s).
    fs : float
        Sample rate, Hz.

    Returns
    -------
    float
        The ``tau`` minimising the weighted residual of ``H exp(i 2 pi f tau / fs)`` fitted
        by real modes (imaginary residues) plus real ``L / s^2 + U0 + U2 s^2``; 0 when its F test
        against ``tau = 0`` (one parameter, `ALPHA`) fails.
    """
    s = 2j * np.pi * np.asarray(freqs, dtype=float)
    g = 1 / (s[:, None] - poles[None, :])
    gc = 1 / (s[:, None] - np.conj(poles)[None, :])
    # real modes (what the written model holds): imaginary residues on conjugate poles, real
    # residual terms; free complex residues would rotate each mode's phase and absorb most of
    # the ramp (1 % noise then moved a one-sample delay by 0.2-0.3 samples)
    basis = np.column_stack([1j * (g - gc), 1 / s ** 2, np.ones_like(s), s ** 2])
    w = np.ones(H.shape) if std is None else 1 / np.maximum(std, 1e-300 + 1e-12 * np.abs(H))
    taus = np.arange(-MAX_DELAY, MAX_DELAY + STEP / 2, STEP)
    rss = np.array([_rss(basis, H * np.exp(s * tau / fs)[:, None], w) for tau in taus])
    best = int(np.argmin(rss))
    zero = int(np.argmin(np.abs(taus)))
    dof = 2 * H.size - basis.shape[1] * H.shape[1] - 1
    if dof <= 0 or rss[best] <= 0:
        return 0.0
    f_stat = (rss[zero] - rss[best]) / (rss[best] / dof)
    if f_stat <= scipy.stats.f.ppf(1 - ALPHA, 1, dof):
        return 0.0
    if 0 < best < taus.size - 1:        # the parabola through the grid's three best points
        a, b, c = rss[best - 1:best + 2]
        return float(taus[best] + 0.5 * STEP * (a - c) / max(a - 2 * b + c, 1e-300))
    return float(taus[best])


def _rss(basis: np.ndarray, H: np.ndarray, w: np.ndarray) -> float:
    """Weighted residual sum of squares of the fit of each column of ``H`` by real
    combinations of the (complex) ``basis`` columns."""
    total = 0.0
    for j in range(H.shape[1]):
        a = basis * w[:, j, None]
        b = H[:, j] * w[:, j]
        a2, b2 = np.concatenate([a.real, a.imag]), np.concatenate([b.real, b.imag])
        coef = np.linalg.lstsq(a2, b2, rcond=None)[0]
        total += float(np.sum((a2 @ coef - b2) ** 2))
    return total
