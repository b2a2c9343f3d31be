"""Linear errors re-estimated with the Welch leakage of the model they make.

A random level is compared through the Welch leakage ``L`` of the model (`._leakage`). A
search computes ``L`` once, for the model it starts from, and holds it while it fits the
candidates; but a linear error moves the resonances, and the leakage with them: the start
model's ``L`` stays at the old resonance, where the corrected model no longer peaks, and the
estimate absorbs the difference. Measured on `sdof-stiffness-disp-random` without sensor
noise (docs/diagnose.md, "Merged, session 33: bias"): the stiffness error -0.56 % with the
start model's leakage (Welch segments of 2048 samples, 95 % interval +-0.28 %), -0.26 % with
the fitted model's; with segments of 1024 / 4096 samples -1.10 / -0.27 % against -0.36 /
-0.19 %; a second iteration moves it by less than 0.03 %.

The chosen effects are therefore refitted once with the leakage of the model they make
(`leakage_refit`), and their reported intervals are taken on the same comparison
(`reported_intervals`). Only the linear errors are re-estimated: a nonlinear coefficient
keeps the reverse path's (noise-debiased) or the joint refit's estimate, and so does its
interval the search's comparison where no linear error is among the effects (measured: the
fitted model's leakage, with a slider's equivalent stiffness in it, widened
`sdof-jenkins-disp-random`'s kd interval from -4.0..+1.4 % to +-22 %).
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

import numpy as np
from scipy.optimize import least_squares

from ..errors import ModelError
from ..models import Model
from ._compare import stuck_linear
from ._joint import (_coefficients_of, _key, _linear_model, _predicted, _valid,
                     misfit_intervals)
from ._leakage import leakage_bias
from ._linear_update import Z95
from ._select import Fit, Search


@contextmanager
def fitted_leakage(start: Model, search: Search, fits: list[Fit]) -> Iterator[bool]:
    """Compare ``search``'s levels through the Welch leakage of ``start`` with ``fits``
    added (the start model's restored on exit); yields whether it did (not for levels
    without a Welch kernel, nor with a memory law fitted in all its parameters, which has
    no basis transfer)."""
    levels = search.levels
    if not fits or any(lf.leakage is None for lf in levels) or any(
            f.cand.memory and f.extra is None for f in fits):
        yield False
        return
    _, theta = _coefficients_of(search, fits)
    lin = _linear_model(stuck_linear(start), fits, theta)
    terms = search.terms + [(f.cand.w, t, _key(f)) for f, t in zip(fits, theta)
                            if not f.cand.linear]
    saved = [lf.leakage for lf in levels]
    fitted = [leakage_bias(lin, lf, terms) for lf in levels]
    try:
        for lf, b in zip(levels, fitted):
            lf.leakage = b
        yield True
    finally:
        for lf, b in zip(levels, saved):
            lf.leakage = b


def leakage_refit(start: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    """``fits`` with their linear errors refitted (weighted least squares, the other
    parameters held) with the Welch leakage of the model they make (module docstring).

    Each refitted interval is the fit's own moved to the new estimate, widened to the
    refit's noise interval where wider. ``fits`` unchanged without linear errors or
    leakage, or where the refit leaves the model's valid range.
    """
    idx = [i for i, f in enumerate(fits) if f.cand.linear]
    if not idx:
        return fits
    with fitted_leakage(start, search, fits) as applied:
        if not applied:
            return fits
        names, theta0 = _coefficients_of(search, fits)
        scale = np.array([max(abs(theta0[i]), 1e-300) for i in idx])

        def resid(z: np.ndarray) -> np.ndarray:
            theta = theta0.copy()
            theta[idx] += z * scale
            out = []
            for lf, h in zip(search.levels, _predicted(start, search, fits, theta)):
                r = (lf.H - h) / np.sqrt(lf.var)
                out += [r.real.ravel(), r.imag.ravel()]
            return np.concatenate(out)

        try:   # a step through an invalid model (an indefinite stiffness)
            sol = least_squares(resid, np.zeros(len(idx)), method="lm")
        except ModelError:
            return fits
    bf = np.mean([lf.bin_factor for lf in search.levels])
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * bf / 2     # Re and Im carry var/2 each
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None)) * scale
    out = list(fits)
    for j, i in enumerate(idx):
        f, n = fits[i], names[i]
        t = float(theta0[i] + sol.x[j] * scale[j])
        if not _valid(search, f, t):
            return fits
        lo, hi = (v - theta0[i] + t for v in f.ci95[n])
        ci = [float(min(lo, t - Z95 * se[j])), float(max(hi, t + Z95 * se[j]))]
        ev = dict(f.evidence, start_leakage_estimate=float(theta0[i]))
        out[i] = Fit(f.cand, dict(f.params, **{n: t}), dict(f.ci95, **{n: ci}), f.chi2,
                     f.delta_bic, ev, extra=f.extra)
    return out


def reported_intervals(start: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    """`._joint.misfit_intervals` on the comparison the estimates were formed on: the
    fitted model's leakage where linear errors are among ``fits`` (`leakage_refit`), the
    search's otherwise."""
    if not any(f.cand.linear for f in fits):
        return misfit_intervals(start, search, fits)
    with fitted_leakage(start, search, fits):
        return misfit_intervals(start, search, fits)
