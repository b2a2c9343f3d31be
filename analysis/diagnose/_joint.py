"""Joint refit of several accepted candidates (one effect is found per search pass).

Effects found one after the other are estimated with the earlier ones fixed: the first
estimate absorbs part of the effects not yet in the model (a linear stiffness error fitted
before a missing cubic spring comes out too large). Once every pass is done, the coefficients
of all accepted candidates are refitted together by weighted least squares on the level FRFs
of the fitting recordings, with the model FRF at each level (paper eq 12)::

    H = H_L(M + dM, C + dC, K + dK) (B - sum_m w_m p_m T_m)

``T_m`` are the force-to-basis transfers of the starting model's elements and of every
candidate basis, held by the first search's levels (they depend on the measured motion
only). Memory kinds are not linear in a coefficient and stay at their own estimate there.

A kind with a second parameter besides its coefficient (a gap's width, a slider's slip
displacement ``fd / kd``: `analysis.models._kinds.Grid`) is then refitted in that parameter
too, on all fitting levels with the other nonlinear coefficients re-solved with its own at
every value of that parameter and the linear errors at their joint estimates (`grid_refit`,
random and multisine data; a slider found first, with a cubic spring still missing, kept its
slip and the cubic its sequential estimate: ``chain-cubic2+jenkins01-disp-random-z7``
without noise p -8.1 %, interval not covering; re-solved, p -3.3 %, kd -1.0 %, fd +0.4 %, all
three intervals covering), and both its parameters get their 95 % interval
from the profile of the misfit, the coefficient re-solved at every value of the second
parameter: the two are strongly correlated (a wider gap with a stiffer contact, a later slip
with a softer slider explain nearly the same FRFs), and the coefficient's interval at a
fixed second parameter, the screening's, was several times too narrow (measured on
``chain-gap01-disp-random``: contact stiffness +-1.3 %, 6.4 % off the truth; +-7.6 % from
the profile).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import brentq, least_squares, minimize_scalar
from scipy.stats import chi2 as chi2_dist

from ..errors import ModelError
from ..models import KINDS, LINEAR_PARAM, Model
from ._compare import chi2, model_frf, stuck_linear
from ._linear_update import Z95, correction_q
from ._select import Fit, Search, coef_name, corrected_model, scaled_params

BLOCKS = 8
"""Contiguous frequency blocks per fitting level: the clusters of `misfit_intervals`'
cluster-robust covariance and jackknife (a model-form misfit is smooth in frequency:
neighbouring lines are not independent)."""

PROFILE_SPAN = np.log(2.0)
"""How far (log) the second parameter is refitted and profiled either side of its estimate:
an interval reaching it is reported as reaching it (wider than the data can say)."""


def _name(fit: Fit) -> str:
    return LINEAR_PARAM[fit.cand.kind] if fit.cand.linear else coef_name(fit.cand.kind)


def _key(fit: Fit) -> tuple:
    return (fit.cand, fit.extra)


def _linear_model(start: Model, fits: list[Fit], theta: np.ndarray) -> Model:
    mats = {"mass": start.mass.copy(), "damping": start.damping.copy(),
            "stiffness": start.stiffness.copy()}
    for f, t in zip(fits, theta):
        if f.cand.linear:
            wq = correction_q(start, f.cand.w)
            mats[f.cand.kind.split("_")[0]] += t * np.outer(wq, wq)
    return start.with_linear(mats["mass"], mats["damping"], mats["stiffness"], [])


def _valid(search: Search, fit: Fit, value: float) -> bool:
    if fit.cand.linear:
        return search.linear_ok(fit.cand, value)
    lo, hi = search.bounds(fit.cand, fit.extra)
    return (value >= 0 or not KINDS[fit.cand.kind].dissipative) and lo <= value <= hi


def joint_refit(start: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    """Refit the coefficients of ``fits`` together on ``search``'s levels (start model),
    then the second parameter of each kind that has one (`grid_refit`).

    Returns the fits with the joint estimates, their 95 % intervals and the joint ``chi2``
    (the coefficients unchanged when a memory kind is among them, the refit does not lower
    the misfit or its estimates leave the model's valid range).
    """
    fits = _coefficients(start, search, fits)
    for i, f in enumerate(fits):
        if search.continuous_grid and _gridded(f):
            key = (i, tuple((g.cand, g.extra, tuple(sorted(g.params.items()))) for g in fits))
            if key not in search.grid_refits:     # the same fits once per search
                search.grid_refits[key] = grid_refit(start, search, fits, i)
            refit = search.grid_refits[key]
            try:   # the refitted element must leave the model valid (a stuck stiffness)
                model = start
                for g in refit:
                    model = corrected_model(model, g)
            except ModelError:
                continue
            fits = refit
    return fits



def _coefficients_of(search: Search, fits: list[Fit]) -> tuple[list[str], np.ndarray]:
    """Each nonlinear fit's basis made available in the search; the fits' coefficient names
    and values."""
    for f in fits:
        if not f.cand.linear:
            search.ensure_basis(f.cand, f.extra)
    names = [_name(f) for f in fits]
    return names, np.array([f.params[n] for f, n in zip(fits, names)])

def _coefficients(start: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    if len(fits) < 2 or any(f.cand.memory for f in fits):
        return fits
    names, theta0 = _coefficients_of(search, fits)
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
    try:   # a step through an invalid model (a negative stiffness): the range is left
        sol = least_squares(resid, np.sign(theta0) + (theta0 == 0), method="lm")
    except ModelError:
        return fits
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


def _gridded(fit: Fit) -> bool:
    if fit.cand.linear or fit.extra is None or not fit.extra > 0:
        return False
    grid = KINDS[fit.cand.kind].search.grid
    return grid is not None and len(grid.fractions) > 1


def _free(fits: list[Fit], i: int) -> list[int]:
    """Indices re-solved with ``fits[i]``'s coefficient at each value of its second
    parameter: ``i`` and every other nonlinear fit (their coefficients enter the model FRF
    linearly at a fixed linear part)."""
    return [i] + [j for j, f in enumerate(fits) if j != i and not f.cand.linear]


def _others(start: Model, search: Search, fits: list[Fit], free: list[int]
            ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per fitting level, the receptance and model FRF with every fit but ``fits[free]``."""
    rest = [f for j, f in enumerate(fits) if j not in free]
    theta = np.array([f.params[_name(f)] for f in rest])
    lin = _linear_model(start, rest, theta) if rest else start
    terms = list(search.terms)
    for f in rest:
        if not f.cand.linear:
            search.ensure_basis(f.cand, f.extra)
            terms.append((f.cand.w, f.params[_name(f)], _key(f)))
    h_lins = [lin.linear_frf(lf.freqs) for lf in search.levels] if rest else search.H_lins
    return h_lins, [model_frf(hl, lf, terms) for hl, lf in zip(h_lins, search.levels)]


def _profile(search: Search, fits: list[Fit], free: list[int], h_lins: list[np.ndarray],
             h0s: list[np.ndarray], extra: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Coefficients of ``fits[free]`` with ``fits[free[0]]`` at second parameter ``extra``
    (closed-form weighted least squares, the other fits fixed), their standard errors and
    the misfit ``chi2``.

    All free coefficients are re-solved together: a second effect held at its estimate made
    with the first one's second parameter off lets the two biases lock in (measured on
    ``chain-cubic2+jenkins01-disp-random-z7``, docs/diagnose.md)."""
    keys = [(fits[j].cand, extra if k == 0 else fits[j].extra) for k, j in enumerate(free)]
    a = np.zeros((len(keys), len(keys)))
    rhs = np.zeros(len(keys))
    ds = []
    for lf, hl, h0 in zip(search.levels, h_lins, h0s):
        for c, e in keys:
            search.ensure_basis(c, e)
        d = np.stack([(hl @ c.w)[:, :, None] * lf.T[(c, e)][:, None, :] for c, e in keys])
        ds.append(d)
        flat = d.reshape(len(keys), -1)
        weighted = np.conj(flat) * np.broadcast_to(1.0 / lf.var, lf.H.shape).ravel()
        a += (weighted @ flat.T).real
        rhs += (weighted @ (lf.H - h0).ravel()).real
    inv = np.linalg.pinv(a)
    p = -inv @ rhs
    p[0] = max(p[0], 0.0)                           # grid kinds' coefficients are positive
    bf = np.mean([lf.bin_factor for lf in search.levels])
    se = np.sqrt(np.clip(np.diag(inv), 0.0, None) * bf / 2)
    x2 = sum(chi2(lf, h0 - np.tensordot(p, d, axes=1))
             for lf, h0, d in zip(search.levels, h0s, ds))
    return p, se, float(x2)


def grid_refit(start: Model, search: Search, fits: list[Fit], i: int) -> list[Fit]:
    """``fits`` with ``fits[i]`` refitted in its coefficient and second parameter on all
    fitting levels, the other nonlinear coefficients re-solved with it (`_profile`), the
    linear errors at their estimates; ``fits[i]`` with both parameters' 95 % profile
    intervals.

    The second parameter minimises the misfit with the coefficients re-solved (bounded, a
    factor 2 either side); the profile interval holds the values whose misfit exceeds the
    minimum by at most ``Z95^2`` times the reduced misfit when above 1 (the model does not
    fit the data to their noise: scipy's ``curve_fit`` default); over it the coefficient
    spans its estimates widened by its standard error at each end.
    """
    fit, free = fits[i], _free(fits, i)
    h_lins, h0s = _others(start, search, fits, free)
    z0 = float(np.log(fit.extra))

    def solve(z: float) -> tuple[np.ndarray, np.ndarray, float]:
        return _profile(search, fits, free, h_lins, h0s, float(np.exp(z)))
    sol = minimize_scalar(lambda z: solve(z)[2], bounds=(z0 - PROFILE_SPAN, z0 + PROFILE_SPAN),
                          method="bounded", options={"xatol": 0.005})
    z = float(sol.x) if sol.fun < solve(z0)[2] else z0
    ps_all, ses, x2 = solve(z)
    p, se = ps_all[0], ses[0]
    reduced = max(1.0, x2 / max(search.n_values - len(fits) - 1, 1.0))
    limit = x2 + Z95 ** 2 * reduced
    ends = [_edge(lambda e: solve(e)[2], z, z + s * PROFILE_SPAN, limit) for s in (-1.0, 1.0)]
    ps = [(q[0], s[0]) for q, s, _ in (solve(e) for e in ends)]
    kind, name = fit.cand.kind, coef_name(fit.cand.kind)
    grid = KINDS[kind].search.grid
    params = scaled_params(kind, p, float(np.exp(z)))
    # the coefficient's ends at each profile point; a slider's fd = kd * slip takes its
    # ends from them too (the ends' kd alone trade off against the slip: fd collapsed)
    ends_q = [(q + d * Z95 * s * np.sqrt(reduced), e)
              for (q, s), e in [((p, se), z), *zip(ps, ends)] for d in (-1.0, 1.0)]
    lo_p, hi_p = min(q for q, _ in ends_q), max(q for q, _ in ends_q)
    second = [scaled_params(kind, max(q, 0.0), float(np.exp(e)))[grid.param]
              for q, e in ends_q]
    ci = dict(fit.ci95, **{name: [float(lo_p), float(hi_p)],
                           grid.param: [float(min(second)), float(max(second))]})
    ev = dict(fit.evidence, grid_profile=(
        f"{grid.param} refitted on all fitting levels with the other nonlinear coefficients "
        f"re-solved (from {fit.params[grid.param]:.4g}); intervals from the misfit profile"
        + (f", widened by the reduced misfit {reduced:.3g}" if reduced > 1 else "")))
    out = list(fits)
    out[i] = Fit(fit.cand, params, ci, float(x2), fit.delta_bic, ev, extra=float(np.exp(z)))
    for j, q, s in zip(free[1:], ps_all[1:], ses[1:]):
        out[j] = _resolved(fits[j], float(q), float(s * np.sqrt(reduced)), float(x2))
    return out


def _resolved(fit: Fit, coef: float, se: float, x2: float) -> Fit:
    """``fit`` at coefficient ``coef`` re-solved with another fit's second parameter, its
    interval moved there and widened to ``coef +- Z95 se`` where narrower."""
    n = coef_name(fit.cand.kind)
    params = (dict(fit.params, **{n: coef}) if fit.extra is None
              else scaled_params(fit.cand.kind, coef, fit.extra))
    lo, hi = (v - fit.params[n] + coef for v in fit.ci95[n])
    ev = dict(fit.evidence, profile_estimate=fit.params[n])
    return Fit(fit.cand, params, dict(fit.ci95, **{n: _wider([lo, hi], coef, se)}), x2,
               fit.delta_bic, ev, extra=fit.extra)


def _edge(cost: Callable[[float], float], z0: float, z1: float, limit: float) -> float:
    """Where ``cost`` crosses ``limit`` between ``z0`` (below it) and ``z1``; ``z1`` when it
    does not."""
    if cost(z1) <= limit:
        return z1
    return float(brentq(lambda z: cost(z) - limit, z0, z1, xtol=0.005))


def misfit_intervals(start: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    """``fits`` with each parameter's 95 % interval widened, where wider, to the
    cluster-robust (sandwich, Huber-White) interval of all parameters on ``search``'s
    fitting levels (start model ``start``).

    The coefficient intervals of the screening, the reverse path and the joint refit hold
    the random error only: where the model misfits beyond its noise (a start model's own
    error, an approximate law) the misfit left is not noise, and the estimate moves with it.
    The sandwich ``A^-1 B A^-1`` keeps the noise-only ``A = J^H J`` (variance-weighted) and
    replaces the noise in ``B`` by the misfit actually left, its scores ``J^H r`` summed over
    `BLOCKS` contiguous frequency blocks per level (clusters: the misfit of neighbouring
    lines is correlated), with the small-sample factor ``G / (G - 1)``. A kind with a second
    parameter takes, where wider, the cluster jackknife too (`_cluster_jackknife`: the fit
    repeated, linearised, without each block in turn): that parameter is pinned by the few
    blocks where the motion crosses it, whose scores the fit zeroed. The parameters are
    every coefficient and, for a kind with a second parameter (`_gridded`: a gap's width, a
    slider's slip displacement), the log of that grid value: the second parameter's
    interval (a gap's ``g``, a slider's ``fd = kd * slip``) comes from their joint
    covariance (delta method), so a slider's ``fd`` carries ``kd``'s error as well as the
    slip's (the profile alone, `grid_refit`, lets them trade off). Each interval is the
    widest of the cluster-robust (and jackknife) and noise-only ones, with the second
    parameters free and fixed (`_sandwich`). On a model that fits to its noise it estimates the noise
    interval; estimates are unchanged. Stepped-sine fits (harmonic balance) keep theirs.
    """
    if not fits or not search.continuous_grid or any(f.cand.memory and f.extra is None
                                                     for f in fits):
        return fits
    names, theta = _coefficients_of(search, fits)
    try:   # a step off an estimate at the edge of the valid range (an indefinite stiffness)
        covs, jack = _sandwich(start, search, fits, theta)
    except ModelError:
        return fits
    grids = [i for i, f in enumerate(fits) if _gridded(f)]

    def se(g: np.ndarray, i: int) -> float:   # of a linear function g of the parameters
        return float(np.sqrt(max(max(g @ c @ g for c in covs + (jack if i in grids else [])),
                                 0.0)))
    size = len(covs[0])
    out = []
    for i, (f, n, t) in enumerate(zip(fits, names, theta)):
        ci = {n: _wider(f.ci95[n], t, se(np.eye(size)[i], i))}
        if i in grids:
            grid = KINDS[f.cand.kind].search.grid
            value = scaled_params(f.cand.kind, t, f.extra)[grid.param]
            g = np.zeros(size)   # d value / d (coefficient, log extra)
            g[i], g[len(fits) + grids.index(i)] = (f.extra if grid.per else 0.0), value
            ci[grid.param] = _wider(f.ci95.get(grid.param, [value] * 2), value, se(g, i))
        wider = {k: v for k, v in ci.items() if v != list(f.ci95.get(k, []))}
        if not wider:
            out.append(f)
            continue
        ev = dict(f.evidence, interval=(
            f"{', '.join(wider)} widened to the joint interval of the misfit left "
            f"(leave-one-block-out over {BLOCKS} frequency blocks per level, at least the "
            "noise's"
            + (", the second parameter free)" if i in grids else ")")))
        out.append(Fit(f.cand, f.params, dict(f.ci95, **wider), f.chi2, f.delta_bic, ev,
                       extra=f.extra))
    return out


def jointly_distinct(start: Model, search: Search, fits: list[Fit], subset: list[int]
                     ) -> bool:
    """Whether the coefficients of ``fits[subset]`` are together distinguishable from zero
    on the covariances `misfit_intervals` reports from (`_sandwich`: cluster-robust and
    noise-only, the second parameters free and fixed): the smallest of their Wald
    statistics beyond the 95 % quantile of chi-square with ``len(subset)`` degrees of
    freedom. Effects acting on nearly the same motion each hold zero alone while their
    sum is pinned. False where those covariances are not computed (stepped sine, a memory
    law fitted in all its parameters): each effect is judged alone."""
    if not search.continuous_grid or any(f.cand.memory and f.extra is None for f in fits):
        return False
    theta = _coefficients_of(search, fits)[1]
    try:
        covs, _ = _sandwich(start, search, fits, theta)
    except ModelError:
        return False
    t, cell = theta[subset], np.ix_(subset, subset)
    wald = min(float(t @ np.linalg.pinv(c[cell]) @ t) for c in covs)
    return wald > chi2_dist.ppf(0.95, len(subset))


LOG_STEP = 2e-3
"""Step in the log of a second parameter for the sandwich's Jacobian (a slider's force is
only piecewise smooth in its slip displacement: not the coefficients' 1e-4)."""


def _sandwich(start: Model, search: Search, fits: list[Fit], theta: np.ndarray
              ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Cluster-robust and noise-only covariance of the coefficients ``theta`` of ``fits``
    and of the log grid values of the `_gridded` ones (in that order), `misfit_intervals`,
    then both with the grid values fixed (their rows and columns zero); and the cluster
    jackknife, free and fixed.

    Neither pair bounds the other: with the second parameters free, the misfit a
    coefficient's score shares with theirs moves to them (measured: `gvt-jenkins-joint` kd
    +-0.16 % free, +-0.24 % fixed); `misfit_intervals` takes the widest.

    The cluster-robust one runs low where a parameter is pinned by a few blocks (their
    scores are the ones the fit zeroed): ``test_diagnose_slider_intervals`` with the noise
    3x the stated one, ``kd`` covered 82 % of 60 realizations (the jackknife 92 %); zoo
    `twin-jenkins_joint-acc-multisine` over ten multisine realizations, ``fd`` 4 of 10 (the
    jackknife 8). The jackknife overshoots where the misfit is a steady bias: on
    `sdof-cubic-acc-random` (six realizations: p -2.2 % +- 0.4 %) +-6 %, the cluster-robust
    +-3 %; `misfit_intervals` takes it for second parameters only. The noise-only covariance
    (``A^-1`` times the bins' correlation over 2) is the floor."""
    step = 1e-4 * np.array([max(abs(t), abs(f.ci95[n][1] - f.ci95[n][0]), 1e-300)
                            for f, n, t in zip(fits, _coefficients_of(search, fits)[0], theta)])
    h = _predicted(start, search, fits, theta)
    dh = [[(d - h0) / s for d, h0 in zip(_predicted(start, search, fits, theta + s * e), h)]
          for s, e in zip(step, np.eye(len(fits)))]
    for i, f in enumerate(fits):
        if _gridded(f):
            moved = [g if j != i else Fit(g.cand, g.params, g.ci95, g.chi2, g.delta_bic,
                                          g.evidence, extra=g.extra * np.exp(LOG_STEP))
                     for j, g in enumerate(fits)]
            for g in moved:
                if not g.cand.linear:
                    search.ensure_basis(g.cand, g.extra)
            dh.append([(d - h0) / LOG_STEP
                       for d, h0 in zip(_predicted(start, search, moved, theta), h)])
    blocks, scores = [], []
    for i, lf in enumerate(search.levels):
        sd = np.sqrt(lf.var)
        r = (lf.H - h[i]) / sd
        jac = [-d[i] / sd for d in dh]
        for blk in np.array_split(np.arange(lf.freqs.size), BLOCKS):
            blocks.append([[np.sum((np.conj(a[blk]) * b[blk]).real) for b in jac]
                           for a in jac])
            scores.append([np.sum((np.conj(a[blk]) * r[blk]).real) for a in jac])
    a_g, g, k = np.array(blocks), np.array(scores), len(fits)
    bread = a_g.sum(axis=0)
    bf = np.mean([lf.bin_factor for lf in search.levels])
    out, jack = [], []
    for keep in (slice(None), slice(0, k)):   # the second parameters free, then fixed
        inv = np.zeros_like(bread)
        inv[keep, keep] = np.linalg.pinv(bread[keep, keep])
        out += [inv @ (g.T @ g) @ inv * len(g) / max(len(g) - 1, 1), inv * bf / 2]
        jack.append(_cluster_jackknife(bread, a_g, g, keep))
    return out, jack


def _cluster_jackknife(bread: np.ndarray, a_g: np.ndarray, g: np.ndarray, keep: slice
                       ) -> np.ndarray:
    """Leave-one-block-out (cluster jackknife, CR3) covariance of the parameters ``keep``:
    each block's linearised refit without it, ``-(A - A_g)^-1 s_g``, and their spread times
    ``(G - 1) / G``; the other rows and columns zero. Unlike ``A^-1 (sum s_g s_g^T) A^-1``
    it is not fooled where a block pins a parameter (its score is the one the fit zeroed):
    the refit without that block moves by what the block alone decided."""
    n = len(g)
    steps = np.zeros((n, bread.shape[0]))
    for j in range(n):
        steps[j, keep] = -np.linalg.pinv((bread - a_g[j])[keep, keep]) @ g[j, keep]
    dev = steps - steps.mean(axis=0)
    return dev.T @ dev * (n - 1) / max(n, 1)


def _wider(ci: list[float], value: float, se: float) -> list[float]:
    """``ci`` widened, where narrower, to ``value +- Z95 se``."""
    lo, hi = ci
    return [float(min(lo, value - Z95 * se)), float(max(hi, value + Z95 * se))]


def _predicted(start: Model, search: Search, fits: list[Fit], theta: np.ndarray
               ) -> list[np.ndarray]:
    """Model FRF of every fitting level with ``fits`` at coefficients ``theta`` (the linear
    part holds the start model's stuck stiffness, as the search's receptances do)."""
    lin = _linear_model(stuck_linear(start), fits, theta)
    terms = search.terms + [(f.cand.w, t, _key(f)) for f, t in zip(fits, theta)
                            if not f.cand.linear]
    return [model_frf(lin.linear_frf(lf.freqs), lf, terms) for lf in search.levels]
