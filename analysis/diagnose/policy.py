"""What the diagnosis accepts: evidence thresholds, hold-out choice, the decision between
candidates and the pruning after a joint refit (shared by the random and stepped-sine
searches)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..errors import ModelError
from ..models import Candidate, Model
from .compare import FLOOR
from .joint import joint_refit
from .locate import level_dependence
from .prepare import DiagnoseInputError
from .report import LevelCurves
from .result import Misfit, PassSummary, Rejection, Tried, TrendPoint
from .select import Fit, Search, corrected_model

BIC_MIN = 10.0
"""Minimum BIC gain ("very strong" evidence, Kass & Raftery) for a discrepancy."""


MIN_REDUCTION = 0.25
"""Minimum relative reduction of the weighted misfit for a discrepancy."""


MIN_REDUCTION_NEXT = 0.5
"""The same for a further effect (second pass): what remains after a correction holds the
first estimate's error and model-form approximations, so a further effect must explain at
least half of it."""


MIN_EFFECT = 2 * FLOOR
"""Minimum relative change of the fitting levels' model FRFs the correction must make."""


MAX_EFFECTS = 3
"""Search passes: after a found effect the library is searched again on the corrected model
(a candidate already accepted is not offered again: the joint refit corrects its estimate)."""


def pick_holdout(levels: list[float], holdout: float | str | None) -> list[int] | None:
    """Indices (into ascending levels) held back; None means a held-back segment.

    Default: the lowest of two levels, the middle one of three, and every other interior
    level of four or more (indices 1, 3, ...: the lowest and highest levels are always
    fitted, so held-back levels are interpolated, never extrapolated)."""
    if holdout == "segment" or (holdout is None and len(levels) == 1):
        return None
    if holdout is None:
        if len(levels) >= 4:
            return list(range(1, len(levels) - 1, 2))
        return [len(levels) // 2 if len(levels) >= 3 else 0]
    try:
        target = float(holdout)
    except (TypeError, ValueError):
        raise DiagnoseInputError(f"holdout {holdout!r} must be a level (number) or "
                                 "'segment'") from None
    i = int(np.argmin([abs(lv - target) for lv in levels]))
    if abs(levels[i] - target) > 0.05 * max(abs(target), 1e-12):
        raise DiagnoseInputError(f"no recording at level {target:g}; levels are "
                                 f"{', '.join(f'{lv:g}' for lv in levels)}")
    if len(levels) == 1:
        raise DiagnoseInputError("holding back the only level leaves nothing to fit; give "
                                 "more levels or --holdout segment")
    return [i]


def pruned_labels(passes: list[SearchPass], chosen: list[Fit]) -> list[str]:
    """Labels of accepted candidates that `pruned` dropped."""
    kept = [f.cand for f in chosen]
    return [s.best.cand.label for s in passes if s.found and s.best.cand not in kept]


def pruned(model: Model, search: Search, fits: list[Fit],
            change: Callable[[Model, list[Fit]], float]) -> list[Fit]:
    """Joint refit, then drop a later effect that the joint estimate makes irrelevant (its
    removal changes the model FRFs by less than `MIN_EFFECT`: it only stood in for the
    sequential error of an earlier estimate) and refit the rest."""
    chosen = joint_refit(model, search, fits)
    for k in range(len(chosen) - 1, 0, -1):
        others = chosen[:k] + chosen[k + 1:]
        if change(apply_fits(model, others), chosen) < MIN_EFFECT:
            return pruned(model, search, [f for f in fits if f.cand != chosen[k].cand],
                           change)
    return chosen


def apply_fits(model: Model, fits: Sequence[Fit]) -> Model:
    """The model with every accepted candidate added, in order."""
    for f in fits:
        model = corrected_model(model, f)
    return model


@dataclass
class SearchPass:
    """One search of the library on the current model and its decision."""

    search: Search
    pool: list[Fit]
    reduction: float
    found: bool
    fixed: Model
    effect: float
    rejected: list[Rejection] = field(default_factory=list)

    @property
    def best(self) -> Fit:
        return self.pool[0]

    def summary(self) -> PassSummary:
        """The pass as a result row."""
        b = self.pool[0] if self.pool else None
        return PassSummary(b.cand.label if b else None, float(b.delta_bic) if b else None,
                           float(self.search.chi2_0), float(self.reduction),
                           float(self.effect), bool(self.found), tuple(self.rejected))


MAX_TRIED = 4
"""Candidates passing the thresholds that a pass tries when a better one is vetoed."""


def decide(model: Model, search: Search, pool: list[Fit],
           change: Callable[[Model], float], *, further: bool = False,
           accepted: Sequence[Candidate] = (),
           veto: Callable[[Fit], str | None] | None = None) -> SearchPass:
    """Accept the best candidate of ``pool`` not ``accepted`` in an earlier pass that passes
    all three thresholds (a stricter misfit reduction for a ``further`` effect) and that
    ``veto`` (candidate -> reason or None) does not reject; the vetoed ones are kept
    in ``rejected`` with their reason, and the next candidate is tried (at most
    `MAX_TRIED`)."""
    pool = [f for f in pool if f.cand not in accepted]
    min_red = MIN_REDUCTION_NEXT if further else MIN_REDUCTION
    rejected: list[Rejection] = []
    first = (search.chi2_0 - pool[0].chi2) / search.chi2_0 if pool else 0.0
    first_effect = 0.0
    for best in pool[:MAX_TRIED]:
        reduction = (search.chi2_0 - best.chi2) / search.chi2_0
        if not (best.delta_bic > BIC_MIN and reduction > min_red):
            break
        try:
            fixed = corrected_model(model, best)
        except ModelError as exc:   # this candidate only: the next one is tried
            rejected.append(Rejection(best.cand.label, str(exc)))
            best.evidence["rejected"] = str(exc)
            continue
        effect = change(fixed)
        first_effect = first_effect or effect
        if effect < MIN_EFFECT:
            break
        reason = veto(best) if veto is not None else None
        if reason is None:
            rest = [f for f in pool if f is not best]
            return SearchPass(search, [best] + rest, reduction, True, fixed, effect, rejected)
        rejected.append(Rejection(best.cand.label, reason))
        best.evidence["rejected"] = reason
    return SearchPass(search, pool, first, False, model, first_effect, rejected)


def linear_only(search: Search) -> bool:
    """True when the fitting levels' FRFs are the same within their random error: then no
    nonlinear candidate is supported by the data (homogeneity, paper chapter 2)."""
    dep = level_dependence(search.levels)
    return dep is not None and not dep.dependent


def model_change(curves: list[LevelCurves]) -> float:
    """Relative rms change of the model FRFs made by the correction (fitting levels)."""
    num = sum(float(np.sum(np.abs(c.after - c.before) ** 2)) for c in curves)
    den = sum(float(np.sum(np.abs(c.measured) ** 2)) for c in curves)
    return float(np.sqrt(num / den))


def misfit_summary(curves: Sequence[LevelCurves], first: SearchPass,
                   rejected: Sequence[Rejection]) -> Misfit:
    """Where the model still misfits beyond the floor: the worst level (error over floor),
    the band holding the central 90 % of its coherence-weighted squared error, its DOFs above
    the floor, the error at every level, and what the search tried."""
    ratio = [c.error_after / c.floor.limit for c in curves]
    c = curves[int(np.argmax(ratio))]
    g = np.ones(c.measured.shape) if c.coh is None else c.coh
    e = np.sum(g * np.abs(c.measured - c.after) ** 2, axis=(1, 2))
    cum = np.cumsum(e) / max(e.sum(), 1e-300)
    i0 = int(np.searchsorted(cum, 0.05))
    i1 = int(min(np.searchsorted(cum, 0.95), c.freqs.size - 1))
    per_dof = c.frequency_residual(c.after)
    dofs = [i for i, v in enumerate(per_dof) if v > c.floor.limit] or [int(np.argmax(per_dof))]
    best = first.pool[0] if first.pool else None
    tried = Tried(len(first.search.cands), best.cand.label if best else None,
                  float(first.reduction), float(best.delta_bic) if best else None,
                  MIN_REDUCTION, BIC_MIN, tuple(r.candidate for r in rejected))
    return Misfit(c.label, (float(c.freqs[i0]), float(c.freqs[i1])), tuple(dofs),
                  tuple(first.search.model.points[i] for i in dofs), tuple(per_dof),
                  tuple(TrendPoint(x.level, x.error_after, x.floor.limit)
                        for x in sorted(curves, key=lambda x: x.level)), tried)


def joint_veto(model: Model, first: Callable[[], Search], accepted: list[Fit],
               judge: Callable[[Model, Model], str | None]) -> Callable[[Fit], str | None]:
    """Veto of a further candidate: the accepted effects plus it, refitted jointly on the
    first search's levels (as the final correction will be), judged against the correction
    without it (``judge(previous, corrected)`` -> reason or None). The first estimates of a
    sequential search are biased by the effects not yet found, so the sequentially corrected
    model is not what is judged."""
    if not accepted:
        return lambda fit: judge(model, corrected_model(model, fit))
    previous = apply_fits(model, joint_refit(model, first(), accepted))
    return lambda fit: judge(previous, apply_fits(model, joint_refit(model, first(),
                                                                 accepted + [fit])))
