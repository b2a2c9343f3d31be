"""Candidate search on random data: fit every candidate, rank by information criterion.

Every candidate of the library is fitted to the level FRFs of the fitting recordings:

* nonlinear kinds linear in one coefficient: closed-form weighted least squares on
  ``H_meas - H0 = -p H_L w T_g`` (screening), then the shortlisted ones are re-estimated
  from the data alone by the reverse path (`analysis.reverse_path`), which also gives the
  coefficient's frequency dependence and the multiple-coherence gain;
* kinds with a second parameter (gap width, friction regularisation) and memory kinds at a
  fixed slip displacement ``fd / kd`` (their force is then linear in ``kd``): the same for
  each value of a small grid (the kind's `analysis.models._kinds.Search.grid`), the best one kept
  and, once shortlisted, its grid value refined continuously (`RandomSearch.refine`);
* linear errors: `linear_update.fit_linear_error`.

Selection: Bayesian information criterion on the variance-weighted misfit ``chi2``:
``dBIC = chi2_0 - chi2_c - k ln N`` (``N`` effective values). Memory kinds are not linear
in their parameters but linear in ``kd`` at a fixed slip displacement: they are screened on
that grid here and fitted by harmonic balance on stepped-sine data (`.stepped`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Hashable, Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from ..models import KINDS, LINEAR_PARAM, Candidate, Element, Model, library, restoring_force
from ..errors import EstimationError, InputError, ModelError
from ..recordings import Recording
from ..reverse_path import ReversePathOptions, reverse_path
from ._compare import (LevelFRF, add_basis, chi2, deformation, element_force, law_force,
                      level_frf, model_frf, stuck_linear)
from ._leakage import leakage_bias
from ._linear_update import (Z95, correction_q, fit_linear_error, modes_model, updated_frf,
                             updated_receptance)
from ._outofsample import Predictor
from ._prepare import Prepared
from ._result import CandidateFit
from ._sensor_noise import noise_bias

SHORTLIST = 4
REACH = 1.5
"""Deformation range (times the largest measured one) over which a stiffness candidate's
tangent stiffness must stay positive (a replay may overshoot the measured motion)."""
MARGIN = 0.9
"""Share of the structure's own stiffness at a location that a softening candidate may
remove at the edge of `REACH` (softening beyond it makes the replay diverge)."""
JOINT_KINDS = ("stiffness_error",)
"""The linear corrections at a nonlinear candidate's location fitted jointly with it
(`Search.predictor`): a start model fitted on data holds the equivalent (secant) stiffness
of whatever acts there at that level. A damping correction beside it was tried (session 31):
it named spurious damping errors beside true effects on start models without one."""


@dataclass
class Fit:
    """One fitted candidate and its evidence."""

    cand: Candidate
    params: dict[str, float]
    ci95: dict[str, list[float]]
    chi2: float
    delta_bic: float
    evidence: dict[str, Any] = field(default_factory=dict)
    extra: float | None = None
    """Grid value of the basis the fit used (its key in ``LevelFRF.T`` is ``(cand, extra)``)."""

    def result(self) -> CandidateFit:
        """The fit as a result row (`result.CandidateFit`)."""
        c = self.cand
        return CandidateFit(c.kind, tuple(c.w.tolist()), c.dofs, tuple(c.points), dict(self.params),
                            {k: (v[0], v[1]) for k, v in self.ci95.items()}, self.chi2,
                            self.delta_bic, dict(self.evidence), c.compensated)


def unit_params(kind: str, extra: float | None) -> dict[str, float]:
    """Parameters of the unit-coefficient basis of a kind screened as linear in one
    parameter (``extra``: its grid value)."""
    return scaled_params(kind, 1.0, extra)


def scaled_params(kind: str, coef: float, extra: float | None) -> dict[str, float]:
    """Parameters at coefficient ``coef`` and grid value ``extra`` (a ``Grid.per`` ratio
    scales with the coefficient)."""
    grid = KINDS[kind].search.grid
    params = {coef_name(kind): float(coef)}
    if grid is not None:
        params[grid.param] = float(extra) * (float(coef) if grid.per else 1.0)
        params.update(grid.fixed)
    return params


def coef_name(kind: str) -> str:
    """The parameter a candidate's force is linear in while screening."""
    grid = KINDS[kind].search.grid
    return grid.per if grid is not None and grid.per else KINDS[kind].coef


def candidate_force(c: Candidate, extra: float | None, p: Prepared) -> np.ndarray:
    """Unit-coefficient force of candidate ``c`` along the measured motion of ``p`` (a
    compensated candidate less its stuck stiffness, which the linear part holds)."""
    params = unit_params(c.kind, extra)
    u, v = deformation(p, c.w)
    g = law_force(c.kind, params, u, v, p.period) - noise_bias(c.kind, params, c.w, u, v,
                                                                 p.noise)
    if c.compensated:
        g = g - params[KINDS[c.kind].initial_stiffness] * u
    return g


def screened(c: Candidate) -> bool:
    """Whether the random-data screening fits ``c`` (memory kinds only with a grid)."""
    return not c.memory or KINDS[c.kind].search.grid is not None


def candidate_extras(model: Model, low: tuple[np.ndarray, np.ndarray],
                     high: tuple[np.ndarray, np.ndarray], *, memory: bool = False
                     ) -> dict[Candidate, list[float | None]]:
    """Grid of the non-coefficient parameter of each nonlinear candidate screened.

    A kind's `analysis.models._kinds.Search.grid` gives the fractions of the rms deformation or rate
    (``x``, ``v`` of ``low`` or ``high``: the lowest or highest fitting level) that are
    tried: ``coulomb_friction``: ``v_reg`` = 1 % of the rms rate at the lowest level;
    ``gap``: widths of 0.25 to 3 rms deformations at the highest level (contact at its
    peaks is the common case); sliders: slip displacements of 0.5 to 8 rms deformations at
    the lowest level. Memory kinds only with ``memory`` (random data; stepped sine fits
    them by harmonic balance).
    """
    extra: dict[Candidate, list[float | None]] = {}
    for c in library(model.n_dof, model.points, model.support):
        if c.linear or (c.memory and not (memory and screened(c))):
            continue
        grid = KINDS[c.kind].search.grid
        if grid is None:
            extra[c] = [None]
        else:
            x, v = low if grid.level == "low" else high
            s = float(np.std((x if grid.variable == "x" else v) @ c.w))
            extra[c] = [f * s for f in grid.fractions]
    return extra


class Search:
    """Candidate fits on level FRFs (random or stepped sine) of the fitting recordings.

    ``levels[i].T`` must hold, for every candidate ``c`` and grid value ``e`` of ``extra``
    (key ``(c, e)``) and every ``("model", m)``, the force-to-restoring-force transfer of
    that unit basis.
    """

    continuous_grid = False
    """Whether `ensure_basis` adds the basis of any grid value (else only the grid's)."""

    def __init__(self, model: Model, levels: list[LevelFRF],
                 extra: dict[Candidate, list[float | None]]) -> None:
        self.model, self.levels, self.extra = model, levels, extra
        self.grid_refits: dict[tuple, Fit] = {}   # `joint.grid_refit` results, by the fits
        self.reach: dict[tuple, float] = {}   # location -> largest deformation to bound
        self.cands = [c for c in library(model.n_dof, model.points, model.support)
                      if c.linear or c in extra]
        self.H_lins = [stuck_linear(model).linear_frf(lf.freqs) for lf in self.levels]
        self.terms = [(el.w, 1.0, ("model", i)) for i, el in enumerate(model.elements)]
        self.H0s = [model_frf(hl, lf, self.terms) for hl, lf in zip(self.H_lins, self.levels)]
        modes = modes_model(model)   # what a linear error corrects (`.linear_update`)
        self.H_modes = self.H_lins if modes is None else [modes.linear_frf(lf.freqs)
                                                          for lf in self.levels]
        # The correction acts on the model's response, not on the leakage term it is
        # compared with (held: `.linear_update.updated_frf`).
        self.H0_modes = [model_frf(hm, lf, self.terms, leakage=False)
                         for hm, lf in zip(self.H_modes, self.levels)]
        self.chi2_0 = sum(chi2(lf, h) for lf, h in zip(self.levels, self.H0s))
        self.n_values = sum(lf.n_values for lf in self.levels)
        self._refined: dict[Candidate, float] = {}   # `refine_grid`'s values, by candidate

    def ensure_basis(self, c: Candidate, extra: float | None) -> None:
        """Make ``(c, extra)`` available in every level's transfers (a grid value refined
        in another search pass); stepped-sine searches hold every grid value already."""

    def refine_grid(self, fit: Fit, within: bool = False) -> Fit:
        """The grid value (gap width, slip displacement) of a shortlisted candidate refined
        continuously: bounded 1-D minimisation of the misfit over a factor of 2 either side
        of the best grid point (the coefficient re-solved in closed form at each value), not
        beyond the grid's own span when ``within``."""
        c, e0 = fit.cand, fit.extra
        grid = KINDS[c.kind].search.grid
        if grid is None or len(grid.fractions) < 2 or not e0:
            return fit
        if c not in self._refined:
            def cost(z: float) -> float:
                e = float(np.exp(z))
                self.ensure_basis(c, e)
                return self._fit_coefficient(c, e)[2]
            z0 = float(np.log(e0))
            lo, hi = z0 - np.log(2), z0 + np.log(2)
            if within:
                span = np.log([e for e in self.extra[c] if e])
                lo, hi = max(lo, float(span.min())), min(hi, float(span.max()))
            sol = minimize_scalar(cost, bounds=(lo, hi), method="bounded",
                                  options={"xatol": 0.01})
            self._refined[c] = float(np.exp(sol.x)) if sol.fun < fit.chi2 else e0
        e = self._refined[c]
        if e == e0:
            return fit
        p, se, x2 = self._fit_coefficient(c, e)
        name = coef_name(c.kind)
        ev = dict(fit.evidence, grid_refined=f"{grid.param} refined from {fit.params[grid.param]:.4g}")
        return Fit(c, scaled_params(c.kind, p, e), {name: [p - Z95 * se, p + Z95 * se]}, x2,
                   self.bic_gain(x2, c.n_params), ev, extra=e)

    def companions(self, fit: Fit) -> list[Fit]:
        """Effects accepted together with ``fit`` (a stepped-sine pair's second element,
        `.stepped.SteppedSearch.companions`); none here."""
        return []

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

    def predictor(self, fit: Fit, joint: bool = False, earlier: Sequence[Fit] = ()
                  ) -> Predictor:
        """``fit``'s model FRFs on the fitting levels as a function of its parameters
        (`.outofsample`). Nuisance parameters after its own: ``joint``, a stiffness
        correction at its location (nonlinear candidates); ``earlier``, the effects already
        accepted (in the current model), each free by a correction (linear errors) or a
        scale of its force (elements), so that a candidate is not credited with the
        estimation error of an earlier one."""
        c = fit.cand
        if c.memory and fit.extra is None:   # a memory law fitted in all its parameters
            names = list(KINDS[c.kind].params)
            theta = np.array([fit.params[n] for n in names])
            return Predictor(lambda t: self.memory_frfs(c, dict(zip(names, t))), theta,
                             len(names), np.abs(theta), positive=True)
        name = LINEAR_PARAM[c.kind] if c.linear else coef_name(c.kind)
        own = [(c.kind, c.w)] if c.linear else []
        if not c.linear:
            self.ensure_basis(c, fit.extra)
        lin = own + ([(k, c.w) for k in JOINT_KINDS] if joint and not c.linear else []) + [
            (f.cand.kind, f.cand.w) for f in earlier if f.cand.linear]
        scaled = [self._element_index(f) for f in earlier if not f.cand.linear]
        k_lin = len(lin) - len(own)

        def predict(t: np.ndarray) -> list[np.ndarray]:
            terms = [(w, p * (1 + t[1 + k_lin + scaled.index(i)]) if i in scaled else p, key)
                     for i, (w, p, key) in enumerate(self.terms)]
            if not c.linear:
                terms.append((c.w, t[0], (c, fit.extra)))
            out = []
            for lf, hl, hm in zip(self.levels, self.H_lins, self.H_modes):
                for j, (kind, w) in enumerate(lin):
                    hl, hm = updated_receptance(hl, hm, kind, w, t[j if c.linear else j + 1],
                                                lf.freqs)
                out.append(model_frf(hl, lf, terms))
            return out
        theta = np.zeros(1 + k_lin + len(scaled))
        theta[0] = fit.params[name]
        scale = np.array([_size(theta[0], fit.ci95.get(name))]
                         + [self.linear_size(kind, w) for kind, w in lin[len(own):]]
                         + [1.0] * len(scaled))
        return Predictor(predict, theta, 1, scale,
                         joint_at=1 if joint and not c.linear else None)

    def _element_index(self, f: Fit) -> int:
        """Index of the current model's element added for the accepted fit ``f``."""
        for i in range(len(self.model.elements) - 1, -1, -1):
            el = self.model.elements[i]
            if el.kind == f.cand.kind and np.array_equal(el.w, f.cand.w):
                return i
        raise ValueError(f"{f.cand.label} is not in the model")

    def linear_size(self, kind: str, w: np.ndarray) -> float:
        """A small linear error of ``kind`` at ``w`` (1e-3 of the model's own along it)."""
        wq = correction_q(self.model, w)
        mat = {"mass_error": self.model.mass, "damping_error": self.model.damping,
               "stiffness_error": self.model.stiffness}[kind]
        return 1e-3 * max(abs(float(wq @ mat @ wq)), 1e-300)

    def deformation(self, c: Candidate, level: int) -> np.ndarray | None:
        """The measured deformation along ``c`` at fitting level ``level``; None where the
        search keeps no time series (`.separate`)."""
        return None

    def memory_frfs(self, c: Candidate, params: dict[str, float]) -> list[np.ndarray]:
        """Model FRFs of the fitting levels with memory element ``c`` (``params``) added;
        only searches that fit memory laws in all their parameters have it."""
        raise NotImplementedError(f"{type(self).__name__} fits no memory law directly")

    # --- screening ---------------------------------------------------------------------
    def _fit_coefficient(self, c: Candidate, extra: float | None) -> tuple[float, float, float]:
        """Weighted LS coefficient, its standard error and the resulting chi2."""
        num = den = 0.0
        ds = []
        for lf, hl, h0 in zip(self.levels, self.H_lins, self.H0s):
            d = (hl @ c.w)[:, :, None] * lf.T[(c, extra)][:, None, :]
            ds.append(d)
            num += np.sum((np.conj(d) * (lf.H - h0) / lf.var).real)
            den += np.sum(np.abs(d) ** 2 / lf.var)
        p = -num / den if den > 0 else 0.0
        spec = KINDS[c.kind]
        if spec.dissipative or spec.param(coef_name(c.kind)).positive:
            p = max(p, 0.0)   # negative dissipation (or slider stiffness) is not physical
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
                delta, se = fit_linear_error(c, self.levels, self.H_modes, self.H0_modes,
                                             self.H0s)
                if not self.linear_ok(c, delta):
                    continue
                x2 = sum(chi2(lf, updated_frf(c, delta, lf.freqs, hm, h0m, h0))
                         for lf, hm, h0m, h0 in zip(self.levels, self.H_modes, self.H0_modes,
                                                    self.H0s))
                name = LINEAR_PARAM[c.kind]
                fits.append(Fit(c, {name: delta}, {name: [delta - Z95 * se, delta + Z95 * se]},
                                x2, self.bic_gain(x2, c.n_params), {"estimator": "frf-fit"}))
                continue
            best = None
            for e in self.extra[c]:
                p, se, x2 = self._fit_coefficient(c, e)
                if best is None or x2 < best[2]:
                    best = (p, se, x2, e)
            p, se, x2, e = best
            if p <= 0 and KINDS[c.kind].param(coef_name(c.kind)).positive:
                continue   # no admissible element (a slider needs a positive stiffness)
            name = coef_name(c.kind)
            fits.append(Fit(c, scaled_params(c.kind, p, e), {name: [p - Z95 * se, p + Z95 * se]},
                            x2, self.bic_gain(x2, c.n_params), {"estimator": "frf-screen"},
                            extra=e))
        return sorted(fits, key=lambda f: -f.delta_bic)

    def linear_ok(self, c: Candidate, delta: float) -> bool:
        """A linear update must leave the mass positive definite and C, K semi-definite."""
        wq = correction_q(self.model, c.w)
        ww = np.outer(wq, wq)
        mat = {"mass_error": self.model.mass, "damping_error": self.model.damping,
               "stiffness_error": self.model.stiffness}[c.kind] + delta * ww
        ev = np.linalg.eigvalsh(mat).min()
        return bool(ev > 0 if c.kind == "mass_error" else ev >= -1e-9 * np.abs(mat).max())

class RandomSearch(Search):
    """`Search` on random recordings, with reverse-path refinement."""

    continuous_grid = True

    def __init__(self, model: Model, preps: list[Prepared], band: tuple[float, float],
                 nperseg: int, floor: float) -> None:
        self.preps, self.band, self.nperseg = preps, band, nperseg
        low = min(preps, key=lambda p: p.level)
        high = max(preps, key=lambda p: p.level)
        extra = candidate_extras(model, (low.x, low.v), (high.x, high.v), memory=True)
        levels = [self._level(model, extra, p, floor) for p in preps]
        reach = {c.dofs: REACH * max(float(np.abs(p.x @ c.w).max()) for p in preps)
                 for c in library(model.n_dof, model.points, model.support)}
        terms = [(el.w, 1.0, ("model", i)) for i, el in enumerate(model.elements)]
        for lf in levels:   # the starting model as the Welch estimate sees it
            lf.leakage = leakage_bias(stuck_linear(model), lf, terms)
        super().__init__(model, levels, extra)
        self.reach = reach

    def _level(self, model: Model, extra: dict, p: Prepared, floor: float) -> LevelFRF:
        bases: dict[Hashable, np.ndarray] = {}
        for i, el in enumerate(model.elements):
            bases[("model", i)] = element_force(el, p)
        for c, extras in extra.items():
            for e in extras:
                bases[(c, e)] = candidate_force(c, e, p)
        return level_frf(p, self.band, self.nperseg, bases, floor=floor)

    def deformation(self, c: Candidate, level: int) -> np.ndarray | None:
        return self.preps[level].x @ c.w

    def ensure_basis(self, c: Candidate, extra: float | None) -> None:
        for p, lf in zip(self.preps, self.levels):
            if (c, extra) not in lf.T:
                add_basis(lf, p, self.band, self.nperseg, (c, extra),
                          candidate_force(c, extra, p))

    def refine(self, fit: Fit, noise: str = "none") -> Fit:
        """Refine a shortlisted candidate: its grid value (`refine_grid`), then its
        coefficient re-estimated from the data by reverse path (memoryless kinds).

        ``noise`` is passed to `analysis.reverse_path.reverse_path`: "none" (H1) ranks the
        shortlist quickly; "auto" (noise-debiased when the records are noisy) gives the
        final estimate of the chosen candidate.
        """
        fit = self.refine_grid(fit)
        c = fit.cand
        if c.memory:
            return fit   # no reverse-path basis for a memory kind: the FRF fit stands
        name = coef_name(c.kind)
        known = {k: v for k, v in fit.params.items() if k != name}
        trial = self.model.with_elements(self.model.elements + [Element(c.kind, c.w, known)])
        recs = [Recording(p.fs, "random", p.force_dofs, p.force, p.x) for p in self.preps]
        opts: dict[str, Any] = {"band": self.band, "nperseg": self.nperseg, "noise": noise}
        if self.preps[0].period is not None:
            opts.update(nperseg=self.preps[0].period, window="boxcar", overlap=0.0)
        try:
            rp = reverse_path(recs, trial, ReversePathOptions(**opts))
        except (InputError, EstimationError) as exc:
            fit.evidence["reverse_path"] = f"not estimable: {exc}"
            return fit
        coef = rp.coefficients[-1]
        p = float(coef.value)
        if KINDS[c.kind].dissipative and p <= 0:
            fit.evidence["reverse_path"] = "negative dissipative coefficient"
            return fit
        lo, hi = self.bounds(c, fit.extra)
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
        x2 = 0.0
        for lf, hl in zip(self.levels, self.H_lins):
            terms = self.terms + [(c.w, p, (c, fit.extra))]
            x2 += chi2(lf, model_frf(hl, lf, terms))
        if x2 > fit.chi2:
            # The level FRFs are the criterion: an estimate that explains them worse than
            # the FRF fit (sensor noise in the basis, a law only near the truth) is reported,
            # not used.
            fit.evidence.update(evidence, reverse_path_estimate=p, reverse_path_chi2=x2,
                                estimator=fit.evidence.get("estimator", "frf-screen"))
            return fit
        return Fit(c, params, {name: [float(coef.ci95[0]), float(coef.ci95[1])]}, x2,
                   self.bic_gain(x2, c.n_params), evidence, extra=fit.extra)


def _size(value: float, ci: list[float] | tuple[float, float] | None) -> float:
    """Typical size of a parameter (its value, or its interval's half width when larger)."""
    half = abs(ci[1] - ci[0]) / 2 if ci is not None and np.all(np.isfinite(ci)) else 0.0
    return max(abs(value), half, 1e-300)


def corrected_model(model: Model, fit: Fit) -> Model:
    """The model with the chosen candidate added.

    Raises
    ------
    ModelError
        The candidate leaves the model's valid range (a compensated stuck stiffness or a
        negative linear error that makes the stiffness indefinite): the diagnosis rejects
        that candidate (`analysis.diagnose._policy.decide`).
    """
    try:
        return _corrected_model(model, fit)
    except ModelError as exc:
        raise ModelError(f"the fitted {fit.cand.kind} leaves the model's valid range "
                         f"({exc})") from None


def _corrected_model(model: Model, fit: Fit) -> Model:
    c = fit.cand
    if not c.linear:
        params = {k: v for k, v in fit.params.items() if k in KINDS[c.kind].all_params}
        elements = model.elements + [Element(c.kind, c.w, params)]
        if not c.compensated:
            return model.with_elements(elements, name=f"{model.name} + {c.kind}")
        wq = model.to_q(c.w)   # the stuck stiffness moves from the linear part to the element
        kd = params[KINDS[c.kind].initial_stiffness]
        return model.with_linear(model.mass, model.damping,
                                 model.stiffness - kd * np.outer(wq, wq), elements,
                                 f"{model.name} + {c.kind}")
    delta = next(iter(fit.params.values()))
    wq = correction_q(model, c.w)
    mats = {"mass": model.mass.copy(), "damping": model.damping.copy(),
            "stiffness": model.stiffness.copy()}
    mats[c.kind.split("_")[0]] += delta * np.outer(wq, wq)
    return model.with_linear(mats["mass"], mats["damping"], mats["stiffness"],
                             [Element(e.kind, e.w.copy(), dict(e.params))
                              for e in model.elements], f"{model.name} + {c.kind}")
