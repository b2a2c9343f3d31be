"""Diagnosis on stepped-sine recordings: harmonic signatures, friction kinds, HBM refit.

Every step is sine-fitted (`analysis.spectral._sine_fit`, harmonics 1, 3, 5, 7). The element
deformation over one period is rebuilt from the fitted harmonics (noise-free by
construction), each candidate's restoring force is evaluated on it and its fundamental
``G_1`` gives the level FRF of the candidate model (measured-motion harmonic balance)::

    H_model = H_L (B F_1 - w G_1) / F_1

With ``T = G_1 / F_1`` this is the random-data identity, so the same `select.Search` ranks
the memoryless kinds and the linear errors; the memory kinds (sliders, also with their
stuck stiffness taken from the linear part) are screened on a slip-displacement grid with
``kd`` in closed form and fitted continuously from the best grid point
(`.stepped_memory`). The leading slider is then refitted by harmonic balance at each step's
own force (paper eq 33) and the held-back level is compared with a harmonic-balance
simulation of the corrected model.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable, Sequence

import numpy as np

from ..models import KINDS, Candidate, Element, Model, library
from ..errors import InputError, ModelError
from ..hbm import HBMError
from ..recordings import Recording, StepTable
from ..spectral import SteppedSineFRF, stepped_sine_frf
from ._compare import LevelFRF, chi2, stuck_stiffness
from ._prepare import level_name
from ._engine import Flow
from ._policy import BIC_MIN, MIN_REDUCTION, SearchPass, linear_only, pick_holdout
from ._replay import periodic_replay
from ._leakage import Floor, level_floor
from ._where import screening
from ._report import LevelCurves
from ._evidence import Evidence
from ._outofsample import Predictor
from ._select import (SHORTLIST, Fit, Search, candidate_extras, coef_name,
                     scaled_params, screened, unit_params)
from ._stepped_memory import (BACKBONE_ESTIMATOR, HARMONICS, N_TIME, BackboneEstimate,
                             backbone_applies, backbone_estimate, correction_fits, hbm_refit,
                             hbm_sweep, held_elements, held_mode, motion_chi2, refine, simulated_chi2,
                             slip_grid, stuck_limit, transfer, with_candidate)

PAIR_MIN = 2.0
"""Out-of-sample backbone score (a log likelihood) a pair must gain over its first kind
alone: the likelihood-ratio threshold of one more parameter at 95 % (chi2(1) / 2 = 1.92,
rounded up); a pure slider's own small bias is not taken for a second element."""
METRIC = ("relative first-harmonic FRF error (rms over steps and DOFs) of a harmonic-balance "
          "simulation on the held-back level")


def _noise_var(rec: Recording | StepTable, frf: SteppedSineFRF) -> np.ndarray:
    """Variance of each fundamental receptance, (n_steps, n_dof).

    Two parts: white noise from the sine-fit residual (``4 sigma^2 / n``), and a steady-state
    check: the fundamentals fitted to the two halves of the block differ when a transient
    has not died out; ``|X_a - X_b|^2 / 4`` is added for that. A table (no block) has the
    scatter of its steps about a single mode (`analysis.backbone.frf_noise`).
    """
    if isinstance(rec, StepTable):
        from ..backbone import frf_noise
        return np.broadcast_to(frf_noise(frf.freqs, frf.frf, 0), frf.frf.shape).copy()
    out = np.empty(frf.frf.shape)
    n = rec.response.shape[1]
    t = np.arange(n) / rec.fs
    half = n // 2
    for s, f in enumerate(frf.freqs):
        blk = rec.response[s]
        phase = 2 * np.pi * f * t[:, None] * np.asarray(frf.harmonics)[None, :]
        design = np.hstack([np.ones((n, 1)), np.cos(phase), np.sin(phase)])
        coef, *_ = np.linalg.lstsq(design, blk, rcond=None)
        sigma2 = np.var(blk - design @ coef, axis=0)
        x_a = np.linalg.lstsq(design[:half], blk[:half], rcond=None)[0][1]
        x_b = np.linalg.lstsq(design[half:], blk[half:], rcond=None)[0][1]
        out[s] = 4 * sigma2 / n / frf.force[s] ** 2 + (x_a - x_b) ** 2 / 4 / frf.force[s] ** 2
    return out


def _motion(frf: SteppedSineFRF, w: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Deformation and rate of ``w`` over one period of step ``s`` (from fitted harmonics)."""
    theta = 2 * np.pi * np.arange(N_TIME) / N_TIME
    h = np.asarray(frf.harmonics)
    U = frf.X[s] @ w
    e = np.exp(1j * np.outer(theta, h))
    om = 2 * np.pi * frf.freqs[s]
    return (e @ U).real, (e @ (1j * h * om * U)).real


def _level_motion(model: Model, frf: SteppedSineFRF) -> tuple[np.ndarray, np.ndarray]:
    """Deformations and rates of every DOF over one period of every step of a level,
    stacked ``(n_steps * N_TIME, n_dof)`` (the motion `.select.candidate_extras` scales)."""
    motion = [_motion(frf, np.eye(model.n_dof)[:, d], s) for s in range(frf.freqs.size)
              for d in range(model.n_dof)]
    x = np.array([m[0] for m in motion]).reshape(-1, model.n_dof, N_TIME)
    v = np.array([m[1] for m in motion]).reshape(-1, model.n_dof, N_TIME)
    return (x.transpose(0, 2, 1).reshape(-1, model.n_dof),
            v.transpose(0, 2, 1).reshape(-1, model.n_dof))


def _level(model: Model, rec: Recording, frf: SteppedSineFRF, extra: dict, floor: float,
           label: str) -> LevelFRF:
    H = frf.frf[:, :, None]
    var = _noise_var(rec, frf)[:, :, None] + floor**2 * np.abs(H) ** 2
    B = np.zeros((model.n_dof, 1))
    B[frf.force_dof, 0] = 1.0
    # model elements in the stuck form (`.compare.stuck_linear`): less the stuck stiffness
    x1 = frf.X[:, list(frf.harmonics).index(1)]                 # fundamental, (n_s, n_dof)
    T = {("model", i): transfer(frf, el.kind, el.params, el.w) - stuck_stiffness(el)
         * (x1 @ el.w / frf.force)[:, None] for i, el in enumerate(model.elements)}
    for c, extras in extra.items():
        for e in extras:
            T[(c, e)] = transfer(frf, c.kind, unit_params(c.kind, e), c.w, c.compensated)
    return LevelFRF(label, frf.level, frf.freqs, H, np.ones(H.shape), var, B, T, 1.0)


class SteppedSearch(Search):
    """`Search` plus the memory kinds, on stepped-sine levels."""

    def __init__(self, model: Model, frfs: list[SteppedSineFRF], recs: list[Recording],
                 floor: float) -> None:
        self.frfs, self.recs = frfs, recs
        order = sorted(range(len(frfs)), key=lambda i: frfs[i].level)
        # a grid at the highest level scales with its motion (a gap's width), not the
        # lowest's: the lowest level's rms put the gap's widths at 0.05-0.56 mm on
        # `sdof-gap-disp-stepped-z7`, a tenth of the 6.9 mm clearance that only level 12 closes
        extra = candidate_extras(model, _level_motion(model, frfs[order[0]]),
                                 _level_motion(model, frfs[order[-1]]))
        self.on_backbone = [c for c in library(model.n_dof, model.points, model.support)
                            if c.memory and screened(c) and backbone_applies(recs, c)]
        for c in library(model.n_dof, model.points, model.support):
            if c.memory and screened(c) and c not in self.on_backbone:
                extra[c] = slip_grid(frfs, c.w)
        levels = [_level(model, r, f, extra, floor, level_name(r))
                  for r, f in zip(recs, frfs)]
        self.partner: dict[Candidate, Fit] = {}
        """The second element of a slider's winning pair (`_paired`): simulated with it and
        accepted with it (`companions`)."""
        super().__init__(model, levels, extra)
        self.anchor = held_mode(model, recs) if self.on_backbone else None
        """The mode at the held point and the measured backbone the backbone fits use."""
        self.corrected: set[Candidate] = set()
        """Candidates whose linear part is corrected with them (`_estimate`)."""
        low = min(range(len(levels)), key=lambda i: levels[i].level)
        self.low = (low, level_floor(levels[low], floor).limit)
        """The lowest fitting level and its floor."""

    def ensure_basis(self, c: Candidate, extra: float | None) -> None:
        """Make ``(c, extra)`` available in every level's transfers (a grid value the
        backbone fit refined, `_on_backbone`), along the measured motion as `_level` does."""
        for lf, frf in zip(self.levels, self.frfs):
            if (c, extra) not in lf.T:
                lf.T[(c, extra)] = transfer(frf, c.kind, unit_params(c.kind, extra), c.w,
                                            c.compensated)

    def memory_frfs(self, c: Candidate, params: dict[str, float]) -> list[np.ndarray]:
        """Model FRFs of the fitting levels with slider ``c`` (``params``) added, for the
        out-of-sample score: simulated by harmonic balance at each step's own force, as the
        fits' misfit is (`.stepped_memory.simulated_chi2`; a slider fitted to the backbone
        is judged on the FRFs it predicts, not along the measured motion); along the
        measured motion (`.stepped_memory.transfer`) where the balance fails."""
        return self._simulated(c, params, lambda: [
            h0 - (hl @ c.w)[:, :, None] * transfer(frf, c.kind, params, c.w,
                                                  c.compensated)[:, None, :]
            for hl, h0, frf in zip(self.H_lins, self.H0s, self.frfs)], self._beside(c))

    def _beside(self, c: Candidate) -> Element | None:
        """The element of ``c``'s pair partner, if it has one."""
        p = self.partner.get(c)
        return None if p is None else Element(p.cand.kind, p.cand.w, dict(p.params))

    def companions(self, fit: Fit) -> list[Fit]:
        """A pair's second element, accepted with its slider (`_paired`): the pair was chosen
        on the backbone and judged on the FRFs together (`_pair_predictor`); then the linear
        part's correction at the point when it was judged with one (`_estimate`)."""
        p = self.partner.get(fit.cand)
        out = [] if p is None else [p]
        corr = self._correction(fit.cand, fit.params, self._beside(fit.cand))
        return out + ([] if corr is None else correction_fits(fit, corr))

    def _correction(self, c: Candidate, params: dict[str, float], beside: Element | None
                    ) -> tuple[float, float] | None:
        """The linear part's stiffness and damping correction at ``c``'s location with ``c``
        at ``params`` (and ``beside``) when ``c`` is corrected (`_estimate`), else None."""
        if c not in self.corrected or self.anchor is None:
            return None
        terms = [(c.kind, params, c.compensated)]
        if beside is not None:
            terms.append((beside.kind, beside.params, False))
        return self.anchor.correction(terms)

    def _estimate(self, c: Candidate, beside: Candidate | None = None
                  ) -> BackboneEstimate | None:
        """``c`` (and ``beside``) fitted to the backbone (`.stepped_memory.backbone_estimate`);
        when the model with that estimate misfits the lowest fitting level beyond its floor,
        fitted again with the linear part corrected with it (``anchored``: its frequency and
        damping at the held point such that the lowest level is reproduced with the element,
        the correction in the estimate, ``correction``): the linear part, fitted at
        that level, holds the element's share of it there (issue 24 item 1: a correction of
        the linear part jointly where the start model misfits). Where the element leaves the
        lowest level within its floor (it sticks there) nothing changes."""
        est = backbone_estimate(self.model, c, self.recs, beside=beside)
        if est is None or self.anchor is None:
            return est
        b = None if beside is None else Element(beside.kind, beside.w, dict(est.beside_params))
        low, limit = self.low
        try:
            m = with_candidate(self.model, c, est.params, b)
            h = hbm_sweep(m, self.frfs[low])[:, HARMONICS.index(1)]
        except (ModelError, HBMError):
            return est
        if not _error(self.frfs[low], h / self.frfs[low].force[:, None]) > limit:
            return est
        return backbone_estimate(self.model, c, self.recs, beside=beside, anchored=True) or est

    def _adopt(self, c: Candidate, anchored: bool) -> None:
        """``c`` is corrected (`_correction`) when the estimate it takes was ``anchored``."""
        if anchored:
            self.corrected.add(c)
        else:
            self.corrected.discard(c)

    def _simulated(self, c: Candidate, params: dict[str, float],
                   fallback: Callable[[], list[np.ndarray]], beside: Element | None = None
                   ) -> list[np.ndarray]:
        """The fitting levels' fundamental FRFs of the model with ``c`` (and ``beside``, its
        pair's second element) added, by harmonic balance at each step's own force;
        ``fallback()`` where the balance fails."""
        try:
            m = with_candidate(self.model, c, params, beside,
                               self._correction(c, params, beside))
            i1 = HARMONICS.index(1)
            return [(hbm_sweep(m, frf)[:, i1] / frf.force[:, None])[:, :, None]
                    for frf in self.frfs]
        except (ModelError, HBMError):
            return fallback()

    def predictor(self, fit: Fit, joint: bool = False, earlier: Sequence[Fit] = ()
                  ) -> Predictor:
        """`Search.predictor`; on response-controlled tables (where the sliders are fitted
        to the backbone and judged on the FRFs harmonic balance predicts) a memoryless
        nonlinear candidate judged alone is predicted the same way (`_simulated`, the same
        harmonics), not along the measured motion: that prediction, ``H_L (B F_1 - w G_1)
        / F_1`` with ``G_1`` from the measured response, carries the measured resonance of
        each level into the candidate's FRF, which a simulated model cannot."""
        c = fit.cand
        if c in self.partner and fit.extra is None:
            return self._pair_predictor(fit, self._beside(c))
        shift = _signed_shift(c.kind) if c.memory else np.zeros(1)
        if fit.extra is None and np.any(shift):
            # a signed parameter (iwan's chi) is judged from its lower bound, as a positive
            # one from zero: the score takes a memory law's parameters as positive
            names = list(KINDS[c.kind].params)
            theta = np.array([fit.params[n] for n in names]) - shift
            return Predictor(lambda t: self.memory_frfs(c, dict(zip(names, t + shift))),
                             theta, len(names), np.abs(theta), positive=True)
        if (self.model.elements and not c.memory and not joint
                and fit.evidence.get("estimator") == BACKBONE_ESTIMATOR):
            # a later pass's law fitted to the backbone beside the elements already there:
            # judged beside them as that fit kept them (its coefficient free)
            name = coef_name(c.kind)
            return Predictor(lambda t: self._simulated(
                c, scaled_params(c.kind, float(t[0]), fit.extra), lambda: list(self.H0s)),
                np.array([fit.params[name]]), 1, np.array([abs(fit.params[name])]))
        pred = super().predictor(fit, joint, earlier)
        if not self.on_backbone or c.linear or c.memory or pred.nuisance:
            return pred
        return replace(pred, predict=lambda t: self._simulated(
            c, scaled_params(c.kind, float(t[0]), fit.extra), lambda: pred.predict(t)))

    def _pair_predictor(self, fit: Fit, beside: Element) -> Predictor:
        """A pair (`_paired`) judged by one scale of its nonlinear strength (`_scaled_force`:
        the slider's slip force and the partner's coefficient together), the rest kept as
        the backbone fixed it, as a gridded kind is judged at its grid value: a one-step
        out-of-sample refit of four or five parameters from a backbone estimate is far
        outside its linear range on levels that drift in frequency (docs/backbone.md)."""
        c = fit.cand

        def predict(t: np.ndarray) -> list[np.ndarray]:
            b = Element(beside.kind, beside.w, _scaled_force(beside.kind, beside.params, t[0]))
            return self._simulated(c, _scaled_force(c.kind, fit.params, t[0]),
                                   lambda: list(self.H0s), b)
        return Predictor(predict, np.ones(1), 1, np.ones(1), positive=True)

    def fit_memory(self, fit: Fit) -> Fit | None:
        """A screened slider (best slip-displacement grid point, closed-form ``kd``) with
        every parameter fitted continuously (`.stepped_memory.refine`); None when it never
        slips in the data (then it is a stiffness error, one parameter fewer)."""
        c = fit.cand
        params, x2 = refine(fit, self.levels, self.frfs, self.H_lins, self.H0s,
                            stuck_limit(self.model, c))
        u_max = max(float(np.abs(f.X[:, list(f.harmonics).index(1)] @ c.w).max())
                    for f in self.frfs)
        if KINDS[c.kind].search.inactive(params, u_max):
            return None
        ev = dict(fit.evidence, estimator="measured-motion harmonic balance")
        return Fit(c, params, {}, x2, self.bic_gain(x2, c.n_params), ev)

    def backbone_fit(self, c: Candidate) -> Fit | None:
        """A slider fitted to the levels' backbone (`.stepped_memory.backbone_estimate`),
        its misfit that of the levels simulated by harmonic balance."""
        est = self._estimate(c)
        if est is None:
            return None
        params, ci = est.params, est.ci95
        self._adopt(c, est.anchored)
        x2 = simulated_chi2(self.model, c, params, self.levels, self.frfs,
                            correction=self._correction(c, params, None))
        if x2 is None:
            return None
        ev = dict(estimator=BACKBONE_ESTIMATOR, **est.evidence())
        return Fit(c, params, ci, x2, self.bic_gain(x2, c.n_params), ev)

    def screen(self) -> list[Fit]:
        """The library screened, a memoryless kind's grid value (a gap's width) refined
        continuously (`refine_grid`); the `SHORTLIST` best memory candidates (kind, location,
        compensation) refined from their best grid point (the others are left out), or every
        one fitted to the backbone of response-controlled tables."""
        fits = super().screen()
        # within the grid's span: a gap narrower than a quarter of the top level's rms is
        # closed nearly always, a stiffness error's double (refined below the span, one tied
        # with `chain-stiffness12-disp-stepped`'s stiffness error, gain 6.03e4 against 6.25e4)
        out = [f if f.cand.linear else self.refine_grid(f, within=True)
               for f in fits if not f.cand.memory]
        memory = [f for f in fits if f.cand.memory]   # best first
        out += [r for r in (self.fit_memory(f) for f in memory[:SHORTLIST]) if r]
        out += [r for r in (self.backbone_fit(c) for c in self.on_backbone) if r]
        if self.on_backbone and held_elements(self.model, self.recs[0].control_dof) is not None:
            out = self.backbone_kind(out)
        return sorted(out, key=lambda f: -f.delta_bic)

    def backbone_kind(self, fits: list[Fit]) -> list[Fit]:
        """On response-controlled tables the kind of element at the held point is the one
        that predicts the backbone best out of sample (`.stepped_memory.backbone_gain`:
        each level's frequency and damping from the kind fitted to the other levels'),
        against the mode with the elements the model already holds there: the other
        nonlinear kinds there are left out of the pool (each fit keeps its score in its
        evidence); whether the chosen one is accepted is then decided on the FRFs
        (`.policy.decide`). A memoryless law is scored by its own backbone fit, its pool
        entry keeps the FRF screening's estimate. In the first pass a kind is also scored
        with a second element beside it (`_paired`)."""
        scored: dict[tuple[str, bool], float] = {}
        partners = {f.cand.kind: f.cand for f in fits if backbone_applies(self.recs, f.cand)
                    and not f.cand.memory and not KINDS[f.cand.kind].dissipative}
        out = []
        for f in fits:
            if not backbone_applies(self.recs, f.cand):
                out.append(f)
                continue
            if f.evidence.get("estimator") != BACKBONE_ESTIMATOR:
                est = self._estimate(f.cand)
                if est is None:
                    continue
                f.evidence.update(est.evidence())
                if self.model.elements:
                    f = self._on_backbone(f, est)
                    if f is None:
                        continue
            if not self.model.elements:
                f = self._paired(f, [p for k, p in partners.items() if k != f.cand.kind])
            out.append(f)
            form = (f.cand.kind, f.cand.compensated)
            scored[form] = max(scored.get(form, -np.inf), f.evidence["backbone_oos_gain"])
        if not scored:
            return out
        best = max(scored, key=scored.__getitem__)
        return [f for f in out if not backbone_applies(self.recs, f.cand)
                or ((f.cand.kind, f.cand.compensated) == best
                    and "backbone_oos_gain" in f.evidence)]

    def _on_backbone(self, fit: Fit, est: BackboneEstimate) -> Fit | None:
        """A memoryless law's pool entry with its backbone estimate ``est`` (`_estimate`)
        beside the elements the model holds (a later pass: the FRF screening along the
        measured motion cannot tell its share from theirs); None when the model with it
        cannot be simulated."""
        c, grid = fit.cand, KINDS[fit.cand.kind].search.grid
        params, ci = est.params, est.ci95
        self._adopt(c, est.anchored)
        x2 = simulated_chi2(self.model, c, params, self.levels, self.frfs,
                            correction=self._correction(c, params, None))
        if x2 is None:
            return None
        extra = fit.extra
        if grid is not None and grid.param in params:
            extra = params[grid.param] / (params[coef_name(c.kind)] if grid.per else 1.0)
            self.ensure_basis(c, extra)
        ev = dict(fit.evidence, estimator=BACKBONE_ESTIMATOR)
        return Fit(c, params, ci, x2, self.bic_gain(x2, c.n_params), ev, extra)

    def _paired(self, fit: Fit, partners: list[Candidate]) -> Fit:
        """``fit`` scored as a pair with the partner (a conservative law at the same point:
        a stiffening one turns a slider's softening around) whose joint backbone fit scores
        best out of sample, when that beats the kind alone by more than `PAIR_MIN`; the
        partner is left to the next pass (judged there beside the element, as this one).
        A slider's pool entry then takes its parameters from the pair's fit, and is
        simulated (misfit, out-of-sample judgement) with the partner beside it: the pair is
        judged on the FRFs as it was chosen on the backbone."""
        best = None
        for p in partners:
            est = self._estimate(fit.cand, beside=p)
            if est is not None and (best is None or est.score.gain > best.score.gain):
                best = est
        alone = fit.evidence["backbone_oos_gain"]
        if best is None or best.score.gain <= alone + PAIR_MIN:
            return fit
        ev = dict(fit.evidence, **best.evidence(), backbone_oos_gain_alone=alone)
        if not best.anchored:                          # the pair's own estimate, not alone's
            ev.pop("linear_correction", None)
        if fit.evidence.get("estimator") != BACKBONE_ESTIMATOR:
            return replace(fit, evidence=ev)
        other = next(p for p in partners if p.kind == best.beside_kind)
        beside = Element(other.kind, other.w, dict(best.beside_params))
        self._adopt(fit.cand, best.anchored)
        x2 = simulated_chi2(self.model, fit.cand, best.params, self.levels, self.frfs, beside,
                            self._correction(fit.cand, best.params, beside))
        if x2 is None:
            self._adopt(fit.cand, "linear_correction" in fit.evidence)
            return fit
        bic = self.bic_gain(x2, fit.cand.n_params + other.n_params)
        self.partner[fit.cand] = Fit(other, dict(beside.params), dict(best.beside_ci95), x2,
                                     bic, dict(ev, estimator=f"{BACKBONE_ESTIMATOR}, beside "
                                               f"{fit.cand.kind}"))
        return Fit(fit.cand, best.params, best.ci95, x2, bic, ev)


def _scaled_force(kind: str, params: dict[str, float], scale: float) -> dict[str, float]:
    """Parameters of ``kind`` with its nonlinear strength scaled by ``scale``: a slider's
    slip force (its stuck stiffness, which the linear part holds, kept), a law's
    coefficient."""
    spec = KINDS[kind]
    names = {spec.search.grid.param} if spec.memory else {spec.coef}
    return {n: v * scale if n in names else v for n, v in params.items()}


def _signed_shift(kind: str) -> np.ndarray:
    """Per parameter of ``kind``: the lower bound of a signed one (not positive, bounded
    below zero), else 0."""
    out = []
    for n in KINDS[kind].params:
        p = KINDS[kind].param(n)
        out.append(p.bounds[0] if not p.positive and p.bounds is not None and p.bounds[0] < 0
                   else 0.0)
    return np.array(out)


def _error(frf: SteppedSineFRF, h: np.ndarray) -> float:
    return float(np.sqrt(np.sum(np.abs(frf.frf - h) ** 2) / np.sum(np.abs(frf.frf) ** 2)))


def _pool(model: Model, search: SteppedSearch, floors: list[Floor], warnings: list[str]
          ) -> list[Fit]:
    """Ranked fits of the whole library (nonlinear ones unless `policy.linear_only` with the
    fitting levels' ``floors``); a leading memory kind is refitted by HBM."""
    if linear_only(search, floors):
        return [f for f in screening(search) if f.cand.linear]
    pool = screening(search)
    best = pool[0]
    reduction = (search.chi2_0 - best.chi2) / search.chi2_0
    if not (best.cand.memory and best.delta_bic > BIC_MIN and reduction > MIN_REDUCTION
            and best.evidence.get("estimator") != BACKBONE_ESTIMATOR):
        return pool
    # Stick-slip is hysteresis with n -> infinity: the nested pair is decided by the
    # harmonic-balance fit itself (BIC with the residual variance unknown).
    rivals = [f for f in pool[:3] if f.cand.memory and f.cand.dofs == best.cand.dofs]
    refits = [hbm_refit(model, f, search.levels, search.frfs) for f in rivals]
    for f, _ in refits:
        f.chi2 = motion_chi2(f.cand, f.params, search.levels, search.frfs, search.H_lins,
                             search.H0s)
        f.delta_bic = search.bic_gain(f.chi2, f.cand.n_params)
    n_res = 2 * sum(f.frf.size for f in search.frfs)

    def hbm_bic(item: tuple[Fit, list[str]]) -> float:
        cost = item[0].evidence.get("hbm_cost")
        if cost is None:
            return np.inf
        return n_res * np.log(cost**2 / n_res) + item[0].cand.n_params * np.log(n_res)
    best, warn = min(refits, key=hbm_bic)
    warnings += warn
    for f, _ in refits:
        f.evidence["hbm_bic"] = hbm_bic((f, []))
    refitted = [f for f, _ in refits]
    return ([best] + [f for f in refitted if f is not best]
            + [f for f in pool if all(f.cand != r.cand for r in refitted)])


class SteppedFlow(Flow):
    """Stepped-sine levels in ascending order, some held back (`policy.pick_holdout`); the
    model's curves by harmonic balance, with periodic replays from the fitted harmonics."""

    metric = METRIC

    def __init__(self, model: Model, recs: Sequence[Recording], *,
                 holdout: float | str | None, floor: float) -> None:
        super().__init__()
        frfs = [stepped_sine_frf(r, HARMONICS) for r in recs]
        order = np.argsort([f.level for f in frfs])
        self.frfs, self.recs = [frfs[i] for i in order], [recs[i] for i in order]
        if len(frfs) < 2 or holdout == "segment":
            raise InputError("a stepped-sine diagnosis needs two or more levels (one is held "
                             "back); record another level")
        # as random data: the lowest of two, the middle one of three, every other interior
        # level of four or more (`policy.pick_holdout`)
        self.hold = pick_holdout([f.level for f in self.frfs], holdout)
        self.model, self.floor = model, floor
        self.held = tuple(i in self.hold for i in range(len(self.frfs)))
        self._cache: dict[tuple[int, int], tuple[Model, np.ndarray]] = {}
        self.floors = [level_floor(_level(model, r, f, {}, floor, ""), floor)
                       for r, f in zip(self.recs, self.frfs)]

    def _hbm(self, m: Model, i: int) -> np.ndarray:
        """`hbm_sweep` of level ``i``, cached per model (the entry keeps the model, so that its
        id is not reused by another one)."""
        hit = self._cache.get((id(m), i))
        if hit is None or hit[0] is not m:
            hit = self._cache[(id(m), i)] = (m, hbm_sweep(m, self.frfs[i]))
        return hit[1]

    def curve(self, start: Model, fixed: Model, i: int) -> LevelCurves:
        f, i1 = self.frfs[i], list(HARMONICS).index(1)
        xb, xa = self._hbm(start, i), self._hbm(fixed, i)
        hb, ha = xb[:, i1] / f.force[:, None], xa[:, i1] / f.force[:, None]
        held = [list(HARMONICS).index(h) for h in f.harmonics]    # a table: its own orders
        return LevelCurves(level_name(self.recs[i]), f.level, self.held[i], f.freqs,
                           f.frf[:, :, None], hb[:, :, None], ha[:, :, None],
                           _error(f, hb), _error(f, ha), None,
                           periodic_replay(f.freqs, f.harmonics, f.X, xb[:, held]),
                           periodic_replay(f.freqs, f.harmonics, f.X, xa[:, held]))

    def pool(self, current: Model, memoryless: bool) -> tuple[SteppedSearch, list[Fit]]:
        search = SteppedSearch(current, [self.frfs[i] for i in self.fit_idx],
                               [self.recs[i] for i in self.fit_idx], self.floor)
        return search, _pool(current, search, [self.floors[i] for i in self.fit_idx],
                             self.warnings)

    def held_levels(self) -> list[LevelFRF]:
        return [_level(self.model, self.recs[i], self.frfs[i], {}, self.floor, "held")
                for i in self.hold]

    def evidence(self, first: SearchPass, common: Evidence) -> Evidence:
        return replace(common, odd_harmonic_ratio=_odd_ratio(first.search.frfs[-1]))


def _odd_ratio(frf: SteppedSineFRF) -> float:
    """Largest |X_3| / |X_1| over steps and DOFs at a level (harmonic signature)."""
    h = list(frf.harmonics)
    if 3 not in h:
        return 0.0
    x1, x3 = np.abs(frf.X[:, h.index(1)]), np.abs(frf.X[:, h.index(3)])
    return float((x3 / np.maximum(x1, 1e-300)).max())
