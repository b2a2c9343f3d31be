"""Fits of linear model errors (mass, stiffness, damping at a DOF or between DOFs).

A linear error ``delta`` at position ``w`` changes the dynamic stiffness by
``delta s(omega) w w^T`` with ``s = 1`` (stiffness), ``i omega`` (damping) or ``-omega^2``
(mass). The Sherman-Morrison formula gives the changed level FRF in closed form::

    H' = H0 - delta s (H_L w)(w^T H0) / (1 + delta s w^T H_L w)

so a one-parameter least-squares fit over all levels needs no matrix inversions per trial.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ..models import Candidate

Z95 = 1.959963984540054


def _scale(kind: str, freqs: np.ndarray) -> np.ndarray:
    om = 2 * np.pi * freqs
    return {"stiffness_error": np.ones_like(om, dtype=complex),
            "damping_error": 1j * om,
            "mass_error": -(om**2) + 0j}[kind]


def updated_frf(cand: Candidate, delta: float, freqs: np.ndarray, H_lin: np.ndarray,
                H0: np.ndarray) -> np.ndarray:
    """Level FRF after adding the linear error ``delta`` to the model with FRF ``H0``."""
    w = cand.w
    a = H_lin @ w                                   # (n_f, n_dof)
    b = np.einsum("d,fdi->fi", w, H0)               # (n_f, n_in)
    c = a @ w                                       # (n_f,)
    ds = delta * _scale(cand.kind, freqs)
    return H0 - (ds / (1 + ds * c))[:, None, None] * a[:, :, None] * b[:, None, :]


def updated_receptance(H_lin: np.ndarray, kind: str, w: np.ndarray, delta: float,
                       freqs: np.ndarray) -> np.ndarray:
    """Receptance after adding the linear error ``delta`` of ``kind`` at ``w w^T``
    (Sherman-Morrison; ``H_lin`` symmetric), shape like ``H_lin``."""
    a = H_lin @ w
    ds = delta * _scale(kind, freqs)
    return H_lin - (ds / (1 + ds * (a @ w)))[:, None, None] * a[:, :, None] * a[:, None, :]


def fit_linear_error(cand: Candidate, levels: list, H_lins: list[np.ndarray],
                     H0s: list[np.ndarray]) -> tuple[float, float]:
    """Least-squares ``delta`` (and its standard error) over all given levels.

    Parameters
    ----------
    cand : Candidate
        A linear-error candidate.
    levels : list of LevelFRF
    H_lins, H0s : list of ndarray
        Underlying linear receptance and current model level FRF of each level.
    """
    def resid(theta: np.ndarray) -> np.ndarray:
        out = []
        for lf, hl, h0 in zip(levels, H_lins, H0s):
            r = (lf.H - updated_frf(cand, theta[0], lf.freqs, hl, h0)) / np.sqrt(lf.var)
            out += [r.real.ravel(), r.imag.ravel()]
        return np.concatenate(out)

    # Linearised start: H' ~ H0 - delta s a b^T.
    num = den = 0.0
    for lf, hl, h0 in zip(levels, H_lins, H0s):
        a = hl @ cand.w
        b = np.einsum("d,fdi->fi", cand.w, h0)
        d = _scale(cand.kind, lf.freqs)[:, None, None] * a[:, :, None] * b[:, None, :]
        num += np.sum((np.conj(d) * (lf.H - h0) / lf.var).real)
        den += np.sum(np.abs(d) ** 2 / lf.var)
    d0 = -num / den if den > 0 else 0.0
    scale = abs(d0) if d0 != 0 else 1.0
    sol = least_squares(resid, [d0], x_scale=[scale], method="lm")
    jtj = float(sol.jac[:, 0] @ sol.jac[:, 0])
    bf = np.mean([lf.bin_factor for lf in levels])
    se = float(np.sqrt(bf / (2 * jtj))) if jtj > 0 else float("inf")  # Re, Im var/2 each
    return float(sol.x[0]), se
