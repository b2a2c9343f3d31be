"""Fits of linear model errors (mass, stiffness, damping at a DOF or between DOFs).

A linear error ``delta`` at position ``w`` (over points) adds ``delta u u^T`` to the mass,
damping or stiffness matrix over the internal coordinates, ``u`` = `correction_q`: ``w`` in
internal coordinates, ``T' w``, where a ``[modal]`` model's residual pseudo-modes are left
out. A pseudo-mode stands for modes outside the band (an in-band compliance or mass line, a
low pseudo-mode of an accelerometer fit carries a large static flexibility that is no
structure's): a linear error corrects the structure the modes in the band carry, and through
a pseudo-mode it would change the model where the data say nothing (a negative stiffness
correction larger than the pseudo-mode's fictitious static stiffness turned such a model
indefinite, `circuit-cubic-acc-multisine`). The split needs the pseudo-modes uncoupled from
the modes (mass, damping, stiffness with the sliders' stuck stiffness); a model whose
pseudo-modes are coupled to its modes is corrected along the whole ``T' w``.

With ``H`` the receptance at the points, ``H_m`` that of the modes alone (``H`` when the
model has no pseudo-modes to split off) and ``s(omega) = 1`` (stiffness), ``i omega``
(damping) or ``-omega^2`` (mass), the Sherman-Morrison formula gives the changed receptance
and level FRF in closed form::

    H'  = H  - delta s (H_m w)(w^T H_m) / (1 + delta s w^T H_m w)
    H0' = H0 - delta s (H_m w)(w^T H0_m) / (1 + delta s w^T H_m w)

(``H0_m`` the level FRF through the modes alone), so a one-parameter least-squares fit over
all levels needs no matrix inversions per trial. Where the level is compared through the
Welch leakage (``H0`` holds the term ``L``, `._leakage`), ``H0_m`` is the model's own response
without it: the correction changes the response, ``H0' = (H0 - L) - ... + L``; applied to
``L`` as well, it moved the leakage with the correction and biased the estimate by the
leakage's size (`sdof-stiffness-disp-random` noise-free, the fitted model's ``L``, segments of
1024 samples: +1.2 % with, -0.36 % without; docs/diagnose.md, "Merged, session 33: bias").
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ..models import Candidate, Model
from ._compare import stuck_linear

Z95 = 1.959963984540054


def _split(model: Model) -> int | None:
    """Number of modes before ``model``'s pseudo-modes when they can be split off
    (`correction_q`), else None."""
    n_m = model.n_q - model.n_residual
    if not model.is_modal or not model.n_residual or n_m < 1:
        return None
    return n_m if all(not np.any(a[:n_m, n_m:]) and not np.any(a[n_m:, :n_m])
                      for a in (model.mass, model.damping, model.stiffness)) else None


def correction_q(model: Model, w: np.ndarray) -> np.ndarray:
    """``w`` in ``model``'s internal coordinates as a linear error acts on it: ``T' w`` with
    the pseudo-modes' entries zero when they split off (module docstring; judged with the
    sliders' stuck stiffness in the linear part, `._compare.stuck_linear`)."""
    u = model.to_q(w)
    n_m = _split(stuck_linear(model))
    if n_m is not None:
        u[n_m:] = 0.0
    return u


def modes_model(model: Model) -> Model | None:
    """The linear part of ``model`` with its sliders' stuck stiffness
    (`._compare.stuck_linear`, as the search's receptances hold it) without its pseudo-modes,
    when they split off; None otherwise (the whole model is corrected)."""
    stuck = stuck_linear(model)
    n_m = _split(stuck)
    if n_m is None:
        return None
    keep = slice(0, n_m)
    return Model(stuck.mass[keep, keep], stuck.damping[keep, keep], stuck.stiffness[keep, keep],
                 [], stuck.name, list(stuck.points), stuck.shapes[:, keep])


def _scale(kind: str, freqs: np.ndarray) -> np.ndarray:
    om = 2 * np.pi * freqs
    return {"stiffness_error": np.ones_like(om, dtype=complex),
            "damping_error": 1j * om,
            "mass_error": -(om**2) + 0j}[kind]


def updated_frf(cand: Candidate, delta: float, freqs: np.ndarray, H_m: np.ndarray,
                H0_m: np.ndarray, H0: np.ndarray) -> np.ndarray:
    """Level FRF after adding the linear error ``delta`` to the model with FRF ``H0``
    (``H_m``, ``H0_m``: receptance and level FRF through its modes alone, the latter
    without the level's leakage term, module docstring)."""
    w = cand.w
    a = H_m @ w                                     # (n_f, n_dof)
    b = np.einsum("d,fdi->fi", w, H0_m)             # (n_f, n_in)
    c = a @ w                                       # (n_f,)
    ds = delta * _scale(cand.kind, freqs)
    return H0 - (ds / (1 + ds * c))[:, None, None] * a[:, :, None] * b[:, None, :]


def updated_receptance(H_lin: np.ndarray, H_m: np.ndarray, kind: str, w: np.ndarray,
                       delta: float, freqs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Receptance and modes' receptance after adding the linear error ``delta`` of ``kind``
    at ``w`` (Sherman-Morrison; both symmetric), shapes like ``H_lin``."""
    a = H_m @ w
    ds = delta * _scale(kind, freqs)
    change = (ds / (1 + ds * (a @ w)))[:, None, None] * a[:, :, None] * a[:, None, :]
    new = H_lin - change
    return new, (new if H_m is H_lin else H_m - change)


def fit_linear_error(cand: Candidate, levels: list, H_ms: list[np.ndarray],
                     H0_ms: list[np.ndarray], H0s: list[np.ndarray]) -> tuple[float, float]:
    """Least-squares ``delta`` (and its standard error) over all given levels.

    Parameters
    ----------
    cand : Candidate
        A linear-error candidate.
    levels : list of LevelFRF
    H_ms, H0_ms, H0s : list of ndarray
        Per level, the receptance and model level FRF through the modes alone
        (`updated_frf`) and the current model level FRF.
    """
    def resid(theta: np.ndarray) -> np.ndarray:
        out = []
        for lf, hm, h0m, h0 in zip(levels, H_ms, H0_ms, H0s):
            r = (lf.H - updated_frf(cand, theta[0], lf.freqs, hm, h0m, h0)) / np.sqrt(lf.var)
            out += [r.real.ravel(), r.imag.ravel()]
        return np.concatenate(out)

    # Linearised start: H' ~ H0 - delta s a b^T.
    num = den = 0.0
    for lf, hm, h0m, h0 in zip(levels, H_ms, H0_ms, H0s):
        a = hm @ cand.w
        b = np.einsum("d,fdi->fi", cand.w, h0m)
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
