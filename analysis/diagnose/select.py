"""Candidate search on random data: fit every candidate, rank by information criterion.

Every candidate of the library is fitted to the level FRFs of the fitting recordings:

* nonlinear kinds linear in one coefficient: closed-form weighted least squares on
  ``H_meas - H0 = -p H_L w T_g`` (screening), then the shortlisted ones are re-estimated
  from the data alone by the reverse path (`analysis.reverse_path`), which also gives the
  coefficient's frequency dependence and the multiple-coherence gain;
* kinds with a second parameter (gap width, friction regularisation): the same for each
  value of a small grid (the kind's `analysis.kinds.Search.grid`), the best one kept;
* linear errors: `linear_update.fit_linear_error`.

Selection: Bayesian information criterion on the variance-weighted misfit ``chi2``:
``dBIC = chi2_0 - chi2_c - k ln N`` (``N`` effective values). Memory kinds are not linear
in their parameters and are searched on stepped-sine data.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Hashable

import numpy as np

from ..elements import restoring_force
from ..errors import EstimationError, InputError, ModelError
from ..kinds import KINDS
from ..model import Element, Model
from ..recording import Recording
from ..reverse_path import reverse_path
from .candidates import LINEAR_PARAM, Candidate, library
from .compare import LevelFRF, chi2, level_frf, model_frf, unit_force
from .leakage import leakage_bias
from .linear_update import Z95, fit_linear_error, updated_frf
from .prepare import Prepared

SHORTLIST = 4
REACH = 1.5
"""Deformation range (times the largest measured one) over which a stiffness candidate's
tangent stiffness must stay positive (a replay may overshoot the measured motion)."""
MARGIN = 0.9
"""Share of the structure's own stiffness at a location that a softening candidate may
remove at the edge of `REACH` (softening beyond it makes the replay diverge)."""


@dataclass
class Fit:
    """One fitted candidate and its evidence."""

    cand: Candidate
    params: dict[str, float]
    ci95: dict[str, list[float]]
    chi2: float
    delta_bic: float
    evidence: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.cand.kind, "w": self.cand.w.tolist(), "dofs": list(self.cand.dofs),
                "params": self.params, "ci95": self.ci95, "chi2": self.chi2,
                "delta_bic": self.delta_bic, "evidence": self.evidence}


def unit_params(kind: str, extra: float | None) -> dict[str, float]:
    """Parameters of the unit-coefficient basis of a linear-in-parameter kind."""
    spec = KINDS[kind]
    params = {spec.coef: 1.0}
    if spec.search.grid is not None:
        params[spec.search.grid.param] = float(extra)
    return params


def coef_name(kind: str) -> str:
    return KINDS[kind].coef


def grid_value(kind: str, params: dict[str, float]) -> float | None:
    """The value of ``kind``'s grid parameter in ``params`` (None for kinds without one)."""
    grid = KINDS[kind].search.grid
    return None if grid is None else params.get(grid.param)


def candidate_extras(model: Model, low_x: np.ndarray, low_v: np.ndarray
                     ) -> dict[tuple, list[float | None]]:
    """Grid of the non-coefficient parameter of each memoryless nonlinear candidate.

    A kind's `analysis.kinds.Search.grid` gives the fractions of the rms deformation or rate
    at the lowest fitting level (``coulomb_friction``: ``v_reg`` = 1 % of the rms rate;
    ``gap``: widths of 0.25 to 1.5 rms deformations).
    """
    extra: dict[tuple, list[float | None]] = {}
    for c in library(model.n_dof):
        if c.linear or c.memory:
            continue
        grid = KINDS[c.kind].search.grid
        if grid is None:
            extra[(c.kind, c.dofs)] = [None]
        else:
            s = float(np.std((low_x if grid.variable == "x" else low_v) @ c.w))
            extra[(c.kind, c.dofs)] = [f * s for f in grid.fractions]
    return extra


class Search:
    """Candidate fits on level FRFs (random or stepped sine) of the fitting recordings.

    ``levels[i].T`` must hold, for every ``(kind, dofs, extra)`` of ``extra`` and every
    ``("model", m)``, the force-to-restoring-force transfer of that unit basis.
    """

    def __init__(self, model: Model, levels: list[LevelFRF],
                 extra: dict[tuple, list[float | None]]) -> None:
        self.model, self.levels, self.extra = model, levels, extra
        self.reach: dict[tuple, float] = {}   # location -> largest deformation to bound
        self.cands = [c for c in library(model.n_dof) if not c.memory]
        self.H_lins = [model.linear_frf(lf.freqs) for lf in self.levels]
        self.terms = [(el.w, 1.0, ("model", i)) for i, el in enumerate(model.elements)]
        self.H0s = [model_frf(hl, lf, self.terms) for hl, lf in zip(self.H_lins, self.levels)]
        self.chi2_0 = sum(chi2(lf, h) for lf, h in zip(self.levels, self.H0s))
        self.n_values = sum(lf.n_values for lf in self.levels)

    def bic_gain(self, chi2_c: float, k: int) -> float:
        return self.chi2_0 - chi2_c - k * np.log(self.n_values)

    def bounds(self, c: Candidate, extra: float | None) -> tuple[float, float]:
        """Coefficient range keeping the tangent stiffness along ``c.w`` positive.

        A restoring (non-dissipative, memoryless) candidate with tangent ``p k_t(u)`` at unit
        coefficient ``p`` may not remove more than `MARGIN` of the stiffness the structure
        offers at its location, ``1 / (w^T K^-1 w)``, for deformations up to ``self.reach``
        (a softening cubic spring otherwise turns the tangent negative and the replay
        diverges). Unbounded without a known reach or a positive definite K.
        """
        spec = KINDS[c.kind]
        reach = self.reach.get(c.dofs)
        if c.linear or spec.dissipative or spec.memory or not reach:
            return -np.inf, np.inf
        try:   # static flexibility at the location, w^T H_L(0) w = w^T K^-1 w
            flex = float((c.w @ self.model.linear_frf(np.zeros(1))[0] @ c.w).real)
        except np.linalg.LinAlgError:
            return -np.inf, np.inf
        if not flex > 0:
            return -np.inf, np.inf
        u, du = np.linspace(-reach, reach, 401), 1e-4 * reach
        both = np.concatenate([u + du, u - du])
        g = restoring_force(c.kind, unit_params(c.kind, extra), both, np.zeros_like(both))[0]
        kt = (g[:u.size] - g[u.size:]) / (2 * du)     # tangent at unit coefficient
        lo = -MARGIN / flex / kt.max() if kt.max() > 0 else -np.inf
        hi = MARGIN / flex / -kt.min() if kt.min() < 0 else np.inf
        return float(lo), float(hi)

    # --- screening ---------------------------------------------------------------------
    def _fit_coefficient(self, c: Candidate, extra: float | None) -> tuple[float, float, float]:
        """Weighted LS coefficient, its standard error and the resulting chi2."""
        num = den = 0.0
        ds = []
        for lf, hl, h0 in zip(self.levels, self.H_lins, self.H0s):
            d = (hl @ c.w)[:, :, None] * lf.T[(c.kind, c.dofs, extra)][:, None, :]
            ds.append(d)
            num += np.sum((np.conj(d) * (lf.H - h0) / lf.var).real)
            den += np.sum(np.abs(d) ** 2 / lf.var)
        p = -num / den if den > 0 else 0.0
        if KINDS[c.kind].dissipative:
            p = max(p, 0.0)   # negative dissipation is not physical
        p = float(np.clip(p, *self.bounds(c, extra)))
        bf = np.mean([lf.bin_factor for lf in self.levels])
        se = float(np.sqrt(bf / (2 * den))) if den > 0 else float("inf")
        x2 = sum(chi2(lf, h0 - p * d) for lf, h0, d in zip(self.levels, self.H0s, ds))
        return float(p), se, x2

    def screen(self) -> list[Fit]:
        """Fit every candidate of the library; best first."""
        fits = []
        for c in self.cands:
            if c.linear:
                delta, se = fit_linear_error(c, self.levels, self.H_lins, self.H0s)
                if not self.linear_ok(c, delta):
                    continue
                x2 = sum(chi2(lf, updated_frf(c, delta, lf.freqs, hl, h0))
                         for lf, hl, h0 in zip(self.levels, self.H_lins, self.H0s))
                name = LINEAR_PARAM[c.kind]
                fits.append(Fit(c, {name: delta}, {name: [delta - Z95 * se, delta + Z95 * se]},
                                x2, self.bic_gain(x2, c.n_params), {"estimator": "frf-fit"}))
                continue
            best = None
            for e in self.extra[(c.kind, c.dofs)]:
                p, se, x2 = self._fit_coefficient(c, e)
                if best is None or x2 < best[2]:
                    best = (p, se, x2, e)
            p, se, x2, e = best
            params = unit_params(c.kind, e)
            name = coef_name(c.kind)
            params[name] = p
            fits.append(Fit(c, params, {name: [p - Z95 * se, p + Z95 * se]}, x2,
                            self.bic_gain(x2, c.n_params), {"estimator": "frf-screen"}))
        return sorted(fits, key=lambda f: -f.delta_bic)

    def linear_ok(self, c: Candidate, delta: float) -> bool:
        """A linear update must leave the mass positive definite and C, K semi-definite."""
        wq = self.model.to_q(c.w)
        ww = np.outer(wq, wq)
        mat = {"mass_error": self.model.mass, "damping_error": self.model.damping,
               "stiffness_error": self.model.stiffness}[c.kind] + delta * ww
        ev = np.linalg.eigvalsh(mat).min()
        return bool(ev > 0 if c.kind == "mass_error" else ev >= -1e-9 * np.abs(mat).max())

class RandomSearch(Search):
    """`Search` on random recordings, with reverse-path refinement."""

    def __init__(self, model: Model, preps: list[Prepared], band: tuple[float, float],
                 nperseg: int, floor: float) -> None:
        self.preps, self.band, self.nperseg = preps, band, nperseg
        low = min(preps, key=lambda p: p.level)
        extra = candidate_extras(model, low.x, low.v)
        levels = [self._level(model, extra, p, floor) for p in preps]
        reach = {c.dofs: REACH * max(float(np.abs(p.x @ c.w).max()) for p in preps)
                 for c in library(model.n_dof)}
        terms = [(el.w, 1.0, ("model", i)) for i, el in enumerate(model.elements)]
        for lf in levels:   # the starting model as the Welch estimate sees it
            lf.leakage = leakage_bias(model, lf, terms)
        super().__init__(model, levels, extra)
        self.reach = reach

    def _level(self, model: Model, extra: dict, p: Prepared, floor: float) -> LevelFRF:
        bases: dict[Hashable, np.ndarray] = {}
        for i, el in enumerate(model.elements):
            bases[("model", i)] = unit_force(el.kind, el.params, el.w, p)
        for (kind, dofs), extras in extra.items():
            w = Candidate(kind, dofs, model.n_dof).w
            for e in extras:
                bases[(kind, dofs, e)] = unit_force(kind, unit_params(kind, e), w, p)
        return level_frf(p, self.band, self.nperseg, bases, floor=floor)

    def refine(self, fit: Fit, noise: str = "none") -> Fit:
        """Re-estimate a nonlinear candidate's coefficient from the data by reverse path.

        ``noise`` is passed to `analysis.reverse_path.reverse_path`: "none" (H1) ranks the
        shortlist quickly; "auto" (noise-debiased when the records are noisy) gives the
        final estimate of the chosen candidate.
        """
        c = fit.cand
        name = coef_name(c.kind)
        known = {k: v for k, v in fit.params.items() if k != name}
        trial = self.model.with_elements(self.model.elements + [Element(c.kind, c.w, known)])
        recs = [Recording(p.fs, "random", p.force_dofs, p.force, p.x) for p in self.preps]
        opts: dict[str, Any] = {"band": self.band, "nperseg": self.nperseg, "noise": noise}
        if self.preps[0].period is not None:
            opts.update(nperseg=self.preps[0].period, window="boxcar", overlap=0.0)
        try:
            rp = reverse_path(recs, trial, **opts)
        except (InputError, EstimationError) as exc:
            fit.evidence["reverse_path"] = f"not estimable: {exc}"
            return fit
        coef = rp.coefficients[-1]
        p = float(coef.value)
        if KINDS[c.kind].dissipative and p <= 0:
            fit.evidence["reverse_path"] = "negative dissipative coefficient"
            return fit
        lo, hi = self.bounds(c, grid_value(c.kind, fit.params))
        bounded = not lo <= p <= hi
        if bounded:
            p = float(np.clip(p, lo, hi))
        wts = 1.0 / np.maximum(coef.variance, 1e-300)
        vals = coef.values
        scale = max(abs(p), 1e-300)
        evidence = {
            "estimator": "reverse-path" + ("" if noise == "none" else f" (noise {noise})"),
            "coef_imag_ratio": float(np.sum(wts * np.abs(vals.imag)) / np.sum(wts) / scale),
            "coef_spread": float(np.sqrt(np.sum(wts * (vals.real - p) ** 2) / np.sum(wts))
                                 / scale),
            "coherence_gain": float(np.mean(rp.coherence_nonlinear - rp.coherence_linear)),
        }
        if bounded:
            evidence["bounded"] = (f"estimate {float(coef.value):.4g} clipped to {p:.4g}: the "
                                   "tangent stiffness must stay positive over the measured "
                                   "deformation range")
        params = dict(fit.params)
        params[name] = p
        extra = grid_value(c.kind, params)
        x2 = 0.0
        for lf, hl in zip(self.levels, self.H_lins):
            terms = self.terms + [(c.w, p, (c.kind, c.dofs, extra))]
            x2 += chi2(lf, model_frf(hl, lf, terms))
        return Fit(c, params, {name: [float(coef.ci95[0]), float(coef.ci95[1])]}, x2,
                   self.bic_gain(x2, c.n_params), evidence)


def corrected_model(model: Model, fit: Fit) -> Model:
    """The model with the chosen candidate added."""
    try:
        return _corrected_model(model, fit)
    except ModelError as exc:
        raise ModelError(f"the fitted {fit.cand.kind} leaves the model's valid range ({exc}): "
                         "the starting model is far from the data; check its units and "
                         "values") from None


def _corrected_model(model: Model, fit: Fit) -> Model:
    c = fit.cand
    if not c.linear:
        params = {k: v for k, v in fit.params.items() if k in KINDS[c.kind].all_params}
        return model.with_elements(model.elements + [Element(c.kind, c.w, params)],
                                   name=f"{model.name} + {c.kind}")
    delta = next(iter(fit.params.values()))
    wq = model.to_q(c.w)
    mats = {"mass": model.mass.copy(), "damping": model.damping.copy(),
            "stiffness": model.stiffness.copy()}
    mats[c.kind.split("_")[0]] += delta * np.outer(wq, wq)
    return model.with_linear(mats["mass"], mats["damping"], mats["stiffness"],
                             [Element(e.kind, e.w.copy(), dict(e.params))
                              for e in model.elements], f"{model.name} + {c.kind}")
