"""Least-squares complex-frequency (LSCF) poles of an FRF given on any set of lines.

pyEMA's LSCF (`analysis.modal._ema.stabilisation`) builds its normal equations with FFTs, so
it needs the FRF on every line of a uniform grid starting at 0 Hz. A multisine's FRF can miss
lines (a design with every other or random lines left out, lines dropped where the force
dips or where interference sat, an odd multisine's grid that does not pass through 0 Hz).
Written by hand because no maintained library takes such lines: the same estimator (Verboven
2002, eq 5.26; common-denominator z-domain model with real coefficients, ``a_n = 1``), its
normal equations formed directly from the measured lines, each weighted one, so that a
missing line is simply weighted out (not filled in).
"""

from __future__ import annotations

import numpy as np


def lscf_poles(freqs: np.ndarray, frf: np.ndarray, max_order: int
               ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Poles of the LSCF models of orders 2, 4, ..., ``max_order`` fitted to ``frf``.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Frequencies of the measured lines, Hz (any spacing, > 0).
    frf : ndarray, shape (n_f, n_out)
        FRF column (any form: the poles are the same).
    max_order : int
        Highest denominator order (even).

    Returns
    -------
    freqs_hz, damping : list of ndarray
        Per order, the natural frequency and damping ratio of every pole with positive
        imaginary part (pyEMA's ``pole_freq`` and ``pole_xi``).
    """
    f = np.asarray(freqs, dtype=float)
    h = np.asarray(frf, dtype=complex).reshape(f.size, -1)
    dt = 1.0 / (2.0 * f.max())                      # z-domain over [0, pi], as pyEMA maps it
    z = np.exp(2j * np.pi * f * dt)
    basis = z[:, None] ** np.arange(max_order + 1)[None, :]          # (n_f, n + 1)
    r = (basis.conj().T @ basis).real
    m = np.zeros_like(r)
    for o in range(h.shape[1]):
        y = -h[:, o:o + 1] * basis
        s = (basis.conj().T @ y).real
        t = (y.conj().T @ y).real
        m += t - s.T @ np.linalg.solve(r, s)
    out_f, out_z = [], []
    for n in range(2, max_order + 1, 2):
        a = np.linalg.solve(m[:n, :n], -m[:n, n])   # a_n = 1
        roots = np.roots(np.r_[a, 1.0][::-1])
        s_pole = np.log(roots.astype(complex)) / dt
        s_pole = s_pole[s_pole.imag > 0]
        wn = np.abs(s_pole)
        out_f.append(wn / (2 * np.pi))
        out_z.append(-s_pole.real / wn)
    return out_f, out_z
