"""The diagnosis engine: one sequence of typed stages for random and stepped-sine data.

1. prepare: a `Flow` holds the levels in its order, which are held back and their floors
   (`.search.RandomFlow`, `.stepped.SteppedFlow`);
2. `search_passes`: each pass screens and locates every candidate of the library on the
   current model (`Flow.pool`) and `policy.decide`s out of sample (`.outofsample`); a found
   effect is added and the library searched again (at most `policy.MAX_EFFECTS`);
3. `correct`: joint refit and pruning of the found effects, then the final correction, which
   must replay (where the flow has replays);
4. `conclude`: verdict, location, held-back fit, evidence and the explanation.

What differs between the data types is passed in by the flow, as scipy.signal's
``_spectral_helper`` serves ``csd`` and ``welch``: how a level's model FRFs are computed
(`Flow.curve`), how a pass builds its ranked pool, the replays and the flow's own evidence.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from typing import Callable, Sequence

from ..models import Model
from ..plant import PlantError
from ._compare import LevelFRF
from ._leakage import Floor
from ._locate import level_dependence, mismatch_band
from ._policy import (BIC_MIN, MAX_EFFECTS, SearchPass, apply_fits, decide, misfit_summary,
                      model_change, pruned, pruned_labels)
from ._joint import joint_refit
from ._leakage_refit import leakage_refit, reported_intervals
from ._replay import Replay
from ._report import LevelCurves, explain, fit_summary
from ._evidence import Evidence, Rejection
from ._result import Diagnosis, Location, Verdict
from ._select import Fit, Search
from ._where import alternatives

Progress = Callable[[int, int, str], None]
"""``progress(done, total, stage)``: called as the diagnosis advances (search passes, joint
refit, replays of each level)."""

Tick = Callable[..., None]
"""``tick(stage)`` reports the start of the next step; ``tick(stage, finished=True)`` the end."""


class Flow(ABC):
    """What one kind of data brings to the engine: its levels (in the order the result lists
    them), which are held back, their floors, and the hooks below.

    Attributes
    ----------
    model : Model
        The starting model.
    held : tuple of bool
        Per level, whether it is held back from fitting.
    floors : list of Floor
        Per level, the FRF error an exact model would show (`leakage.level_floor`).
    metric : str
        What the held-back ``before`` / ``after`` measure.
    settle : bool
        Once the fitting levels lie within their floors, offer no further memory kind (a
        memory element would only absorb the sequential estimation error of the others).
    refit_on_reject : bool
        When the final correction's last effect is rejected, prune and refit the rest jointly
        again (else keep their joint estimates).
    steps : int
        Progress steps of the whole diagnosis.
    warnings : list of str
        Collected while the flow runs.
    """

    model: Model
    held: tuple[bool, ...]
    floors: list[Floor]
    metric: str
    settle: bool = False
    refit_on_reject: bool = False
    steps: int = MAX_EFFECTS + 1

    def __init__(self) -> None:
        self.warnings: list[str] = []

    @property
    def fit_idx(self) -> list[int]:
        """Indices of the fitting levels."""
        return [i for i, h in enumerate(self.held) if not h]

    @abstractmethod
    def curve(self, start: Model, fixed: Model, i: int) -> LevelCurves:
        """Level ``i`` measured and modelled by ``start`` (before) and ``fixed`` (after)."""

    @abstractmethod
    def pool(self, current: Model, memoryless: bool) -> tuple[Search, list[Fit]]:
        """A search of the library on ``current`` over the fitting levels and its ranked
        candidates, best first (``memoryless``: memory kinds withheld)."""

    @abstractmethod
    def held_levels(self) -> list[LevelFRF]:
        """The held-back levels' FRFs for the homogeneity test."""

    @abstractmethod
    def evidence(self, first: SearchPass, common: Evidence) -> Evidence:
        """``common`` with the flow's own evidence added."""

    def start_replays(self, tick: Tick) -> list[Replay | None] | None:
        """Replays of the starting model per level (None: the curves hold their own)."""
        return None

    def corrected_replays(self, fixed: Model, tick: Tick) -> list[Replay] | None:
        """Replays of the corrected model per level; raises `PlantError` when one fails."""
        return None


@dataclass(frozen=True)
class Passes:
    """The search passes (stage 2): the first one ranks the library on the starting model."""

    passes: tuple[SearchPass, ...]

    @property
    def first(self) -> SearchPass:
        return self.passes[0]

    @property
    def found(self) -> list[Fit]:
        """The effects accepted, in the order found."""
        return found(self.passes)


@dataclass(frozen=True)
class Correction:
    """The final correction (stage 3): its effects, the corrected model, every level's
    curves (floors and replays set) and every rejected candidate with its stage."""

    chosen: tuple[Fit, ...]
    model: Model
    curves: tuple[LevelCurves, ...]
    rejected: tuple[Rejection, ...]


def found(passes: Sequence[SearchPass]) -> list[Fit]:
    """The effects accepted by ``passes``, in the order found (a jointly accepted linear
    correction after its effect)."""
    return [f for s in passes if s.found for f in [s.best] + s.linear]


def ticker(progress: Progress | None, total: int) -> Tick:
    """``tick(stage)`` reports the start of the next step; ``finished=True`` the end."""
    done = [0]

    def tick(stage: str, finished: bool = False) -> None:
        done[0] = total if finished else done[0]
        if progress is not None:
            progress(done[0], total, stage)
        done[0] += 1
    return tick


def run(flow: Flow, progress: Progress | None = None) -> Diagnosis:
    """Every stage on a prepared flow."""
    tick = ticker(progress, flow.steps)
    passes = search_passes(flow, tick)
    return conclude(flow, passes, correct(flow, passes, tick), tick)


def search_passes(flow: Flow, tick: Tick) -> Passes:
    """Search passes until one finds nothing (at most `MAX_EFFECTS`); each accepts the
    candidate that wins out of sample (`policy.decide`)."""
    model = flow.model
    floors = [flow.floors[i] for i in flow.fit_idx]
    passes: list[SearchPass] = []
    current, settled = model, False
    for k in range(MAX_EFFECTS):
        tick(f"search pass {k + 1}")
        accepted = found(passes)
        search, pool = flow.pool(current, settled)
        start = current
        step = decide(current, search, pool, lambda fixed: model_change(
            [flow.curve(start, fixed, i) for i in flow.fit_idx]),
            floors, earlier=accepted)
        passes.append(step)
        if not step.found:
            break
        current = step.fixed
        if flow.settle:
            joint = apply_fits(model, joint_refit(model, passes[0].search, found(passes)))
            settled = all(flow.curve(model, joint, i).error_after <= flow.floors[i].limit
                          for i in flow.fit_idx)
    return Passes(tuple(passes))


def correct(flow: Flow, passes: Passes, tick: Tick) -> Correction:
    """Joint refit and pruning of the found effects, linear errors refitted with the Welch
    leakage of the model they make (`.leakage_refit`); the last effect is dropped while the
    corrected model's replay fails."""
    model, first = flow.model, passes.first
    tick("joint refit")
    chosen = leakage_refit(model, first.search, pruned(model, first.search, passes.found))
    rejected = [replace(r, stage=f"search pass {k + 1}") for k, s in enumerate(passes.passes)
                for r in s.rejected]
    before = flow.start_replays(tick)
    while True:
        current = apply_fits(model, chosen)
        curves = [flow.curve(model, current, i) for i in range(len(flow.held))]
        reason = after = None
        if chosen:
            try:
                after = flow.corrected_replays(current, tick)
            except PlantError as exc:
                reason = f"the corrected model's replay fails ({exc})"
        if reason is None:
            break
        rejected.append(Rejection(chosen[-1].cand.label, reason, "joint correction"))
        if flow.refit_on_reject:
            chosen = leakage_refit(model, first.search, pruned(model, first.search,
                                                               chosen[:-1])) if chosen[1:] else []
        else:
            chosen = chosen[:-1]
    curves = [replace(c, floor=fl) for c, fl in zip(curves, flow.floors)]
    if before is not None:
        curves = [replace(c, replay_before=b, replay_after=after[i] if chosen else b)
                  for i, (c, b) in enumerate(zip(curves, before))]
    chosen = reported_intervals(model, first.search, list(chosen))   # intervals only
    return Correction(tuple(chosen), current, tuple(curves), tuple(rejected))


def conclude(flow: Flow, passes: Passes, corr: Correction, tick: Tick) -> Diagnosis:
    """Verdict, location, held-back fit, evidence and explanation."""
    tick("done", finished=True)
    first, chosen, curves = passes.first, corr.chosen, corr.curves
    dep = level_dependence(first.search.levels + flow.held_levels())
    within = all(c.error_after <= c.floor.limit for c in curves)
    verdict = (Verdict.DISCREPANCY if chosen else Verdict.ADEQUATE if within
               else Verdict.UNEXPLAINED)
    misfit = None if within else misfit_summary(curves, first, corr.rejected)
    if verdict == Verdict.UNEXPLAINED:
        location = Location(misfit.dofs, misfit.points, misfit.band_hz)
    else:
        location = _location(flow.model, first, chosen)
    evidence = flow.evidence(first, Evidence(
        chi2_start=first.search.chi2_0, n_values=first.search.n_values,
        chi2_reduction=first.reduction, model_change=first.effect,
        passes=tuple(s.summary() for s in passes.passes),
        pruned_after_joint_refit=tuple(pruned_labels(list(passes.passes), list(chosen))),
        rejected=corr.rejected, misfit=misfit, level_dependence=dep))
    if verdict == Verdict.ADEQUATE:
        flow.warnings += below_floor(first, curves)
    kinds = {(s.best.cand.kind, s.best.cand.dofs): s.kinds for s in passes.passes if s.found}
    d = Diagnosis(verdict, dep.dependent if dep else None, location,
                  tuple(replace(f.result(), alternatives=kinds.get((f.cand.kind, f.cand.dofs),
                                                                   ()))
                        for f in chosen), fit_summary(flow.metric, curves),
                  ranking=tuple(f.result() for f in first.pool[:8]), evidence=evidence,
                  residuals=tuple(c.residuals() for c in curves),
                  warnings=tuple(flow.warnings), model=corr.model, curves=curves)
    return explain(d, [f.cand for f in chosen])


def below_floor(first: SearchPass, curves: Sequence[LevelCurves]) -> list[str]:
    """An adequate verdict's line when the first search's best candidate is significant in
    sample (BIC above `BIC_MIN`): an effect the recordings show, below every level's floor,
    so not named (the artifact twin with force dips: a gap lowers the misfit by 58 %, BIC
    +320, while `detect` finds the distortion; the 3.22 N level misfits 0.033 against a floor
    of 0.044). Nothing when no candidate stands out."""
    if not first.pool or first.best.delta_bic <= BIC_MIN:
        return []
    top = max(curves, key=lambda c: c.level)
    return [f"adequate within the floors, not without evidence: {first.best.cand.label} "
            f"lowers the weighted misfit in sample by {100 * first.reduction:.3g} % (BIC "
            f"{first.best.delta_bic:+.3g}), but every level lies within its floor ({top.label}: "
            f"{top.error_after:.3g} against {top.floor.limit:.3g}), so the effect is too small "
            "at these levels to be named; a higher level, or more periods or averages (a "
            "lower floor), would show it"]


def _location(model: Model, first: SearchPass, chosen: Sequence[Fit]) -> Location:
    """The chosen effects' DOFs, the band of the excess misfit at the highest fitting level of
    the first search (no band when nothing was chosen) and the locations the first search
    cannot separate from the first effect's (`where.alternatives`)."""
    search = first.search
    top = max(range(len(search.levels)), key=lambda i: search.levels[i].level)
    lo, hi = mismatch_band(search.levels[top], search.H0s[top])
    dofs = sorted({d for f in chosen for d in f.cand.dofs})
    alts = (alternatives(search, first.pool, chosen[0], [f.cand.dofs for f in chosen[1:]])
            if chosen else ())
    return Location(tuple(dofs), tuple(model.points[i] for i in dofs),
                    (lo, hi) if chosen else None, alts)
