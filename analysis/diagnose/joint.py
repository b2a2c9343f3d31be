"""Joint refit of several accepted candidates (one effect is found per search pass).

Effects found one after the other are estimated with the earlier ones fixed: the first
estimate absorbs part of the effects not yet in the model (a linear stiffness error fitted
before a missing cubic spring comes out too large). Once every pass is done, the coefficients
of all accepted candidates are refitted together by weighted least squares on the level FRFs
of the fitting recordings, with the model FRF at each level (paper eq 12)::

    H = H_L(M + dM, C + dC, K + dK) (B - sum_m w_m p_m T_m)

``T_m`` are the force-to-basis transfers of the starting model's elements and of every
candidate basis, held by the first search's levels (they depend on the measured motion
only). Memory kinds are not linear in a coefficient and stay at their own estimate.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ..errors import ModelError
from ..models import KINDS, LINEAR_PARAM, Model
from .compare import chi2, model_frf
from .linear_update import Z95
from .select import Fit, Search, coef_name, corrected_model


def _name(fit: Fit) -> str:
    return LINEAR_PARAM[fit.cand.kind] if fit.cand.linear else coef_name(fit.cand.kind)


def _key(fit: Fit) -> tuple:
    return (fit.cand, fit.extra)


def _linear_model(start: Model, fits: list[Fit], theta: np.ndarray) -> Model:
    mats = {"mass": start.mass.copy(), "damping": start.damping.copy(),
            "stiffness": start.stiffness.copy()}
    for f, t in zip(fits, theta):
        if f.cand.linear:
            wq = start.to_q(f.cand.w)
            mats[f.cand.kind.split("_")[0]] += t * np.outer(wq, wq)
    return start.with_linear(mats["mass"], mats["damping"], mats["stiffness"], [])


def _valid(search: Search, fit: Fit, value: float) -> bool:
    if fit.cand.linear:
        return search.linear_ok(fit.cand, value)
    lo, hi = search.bounds(fit.cand, fit.extra)
    return (value >= 0 or not KINDS[fit.cand.kind].dissipative) and lo <= value <= hi


def joint_refit(start: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    """Refit the coefficients of ``fits`` together on ``search``'s levels (start model).

    Returns the fits with the joint estimates, their 95 % intervals and the joint ``chi2``
    (unchanged when a memory kind is among them, the refit does not lower the misfit or
    its estimates leave the model's valid range).
    """
    if len(fits) < 2 or any(f.cand.memory for f in fits):
        return fits
    for f in fits:
        if not f.cand.linear:
            search.ensure_basis(f.cand, f.extra)
    names = [_name(f) for f in fits]
    theta0 = np.array([f.params[n] for f, n in zip(fits, names)])
    scale = np.where(theta0 != 0, np.abs(theta0), 1.0)

    def predicted(theta: np.ndarray) -> list[np.ndarray]:
        lin = _linear_model(start, fits, theta)
        terms = search.terms + [(f.cand.w, t, _key(f)) for f, t in zip(fits, theta)
                                if not f.cand.linear]
        return [model_frf(lin.linear_frf(lf.freqs), lf, terms) for lf in search.levels]

    def resid(z: np.ndarray) -> np.ndarray:
        out = []
        for lf, h in zip(search.levels, predicted(z * scale)):
            r = (lf.H - h) / np.sqrt(lf.var)
            out += [r.real.ravel(), r.imag.ravel()]
        return np.concatenate(out)

    x2_seq = sum(chi2(lf, h) for lf, h in zip(search.levels, predicted(theta0)))
    sol = least_squares(resid, np.sign(theta0) + (theta0 == 0), method="lm")
    theta = sol.x * scale
    x2 = sum(chi2(lf, h) for lf, h in zip(search.levels, predicted(theta)))
    if not x2 < x2_seq or not all(_valid(search, f, t) for f, t in zip(fits, theta)):
        return fits
    bf = np.mean([lf.bin_factor for lf in search.levels])
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * bf / 2     # Re and Im carry var/2 each
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None)) * scale
    out = []
    for f, n, t, s in zip(fits, names, theta, se):
        params = dict(f.params, **{n: float(t)})
        ci = dict(f.ci95, **{n: [float(t - Z95 * s), float(t + Z95 * s)]})
        ev = dict(f.evidence, estimator="joint FRF fit", sequential_estimate=f.params[n])
        out.append(Fit(f.cand, params, ci, float(x2), f.delta_bic, ev, extra=f.extra))
    try:   # the joint estimates must leave the model valid (stuck stiffness, linear errors)
        model = start
        for f in out:
            model = corrected_model(model, f)
    except ModelError:
        return fits
    return out
