"""What the diagnosis accepts: evidence thresholds, hold-out choice, the decision between
candidates and the pruning after a joint refit (shared by the random and stepped-sine
searches)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np

from ..errors import ModelError
from ..models import Candidate, Model
from ._compare import weighted_error
from ._joint import joint_refit, jointly_distinct, misfit_intervals
from ._leakage import Floor
from ._locate import level_dependence
from ._prepare import DiagnoseInputError
from ._report import LevelCurves
from ._outofsample import Z as OOS_Z, Score, reference, refitted, score, tie_threshold, tied
from ._evidence import Misfit, PassSummary, Rejection, Tried, TrendPoint
from ._result import KindAlternative
from ._encompass import encompassing
from ._separate import Law, separation
from ._select import Fit, Search, coef_name, corrected_model, scaled_params
from ._where import MAX_ALTERNATIVES

BIC_MIN = 10.0
"""BIC gain ("very strong" evidence, Kass & Raftery) above which a leading candidate is
worth its expensive final estimate (reverse path with noise, harmonic-balance refit); not a
selection rule: selection is `.outofsample`."""


MIN_REDUCTION = 0.25
"""The same gate's relative misfit reduction (stepped sine's harmonic-balance refit)."""


SCORED = 12
"""Candidates of a pass judged out of sample: the best in sample (BIC), in every pass, and
beside them the best in sample of every other kind (`judged`)."""


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
    return [f.cand.label for s in passes if s.found for f in [s.best] + s.linear
            if f.cand not in kept]


def distinct(fit: Fit) -> bool:
    """Every parameter interval of ``fit`` excludes zero (no interval: nothing to judge)."""
    return all(lo > 0 or hi < 0 for lo, hi in fit.ci95.values())


def pruned(model: Model, search: Search, fits: list[Fit]) -> list[Fit]:
    """Joint refit, then drop the latest effect not distinguishable from zero on the
    intervals the diagnosis reports (`._joint.misfit_intervals`: the misfit left, not the
    noise alone; such an effect only stands in for the sequential or model-form error of
    another estimate) and refit the rest, unless all such effects together are
    distinguishable from zero (`._joint.jointly_distinct`: two effects acting on nearly
    the same motion each hold zero alone). Returns the joint refit's own intervals (the
    reported ones are computed once, on the final set)."""
    chosen = joint_refit(model, search, fits)
    if len(chosen) < 2:
        return chosen
    loose = [i for i, r in enumerate(misfit_intervals(model, search, chosen))
             if not distinct(r)]
    if not loose or jointly_distinct(model, search, chosen, loose):
        return chosen
    return pruned(model, search, [f for f in fits if f.cand != chosen[loose[-1]].cand])


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
    linear: list[Fit] = field(default_factory=list)
    """The linear correction accepted jointly with ``best`` (`with_linear_part`), or the
    second element of a pair (`Search.companions`)."""
    kinds: tuple[KindAlternative, ...] = ()
    """The other kinds the data cannot tell from ``best``'s (`kind_ties`)."""

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
"""Candidates with a significant out-of-sample gain that lose on another count and are
listed as rejected (per pass)."""


def beyond_floor(search: Search, floors: Sequence[Floor]) -> list[bool]:
    """Per fitting level of ``search`` (``floors`` in its order), whether its model misfits
    the level beyond the level's floor."""
    return [weighted_error(lf, h) > fl.limit
            for lf, h, fl in zip(search.levels, search.H0s, floors)]


def decide(model: Model, search: Search, pool: list[Fit], change: Callable[[Model], float],
           floors: Sequence[Floor], *, earlier: Sequence[Fit] = ()) -> SearchPass:
    """Nothing when every fitting level lies within its floor (``floors``, in the search's
    order: the model is adequate there) and its misfit does not change with level
    (`residual_dependent`; when it does, nonlinear candidates only); else accept the
    candidate of ``pool`` with the largest out-of-sample gain that wins
    (`.outofsample.Score.wins`); the `SCORED` best in sample are judged (`judge`: a
    nonlinear one jointly with a stiffness correction at its location where the data
    support it, `supported`), every one with the ``earlier`` accepted effects free.
    The first effect is judged against the start model's own misfit on the levels within
    their floor (`.outofsample.reference`), a further one against the noise alone.
    An element kind already accepted at a location is not offered again there (either
    form: the joint refit corrects its estimate). Candidates with a significant gain that
    lose on another count, or that leave the model's valid range, are kept in ``rejected``
    with their reason."""
    beyond = beyond_floor(search, floors)
    if not any(beyond):
        if not residual_dependent(search):
            return SearchPass(search, pool, _reduction(search, pool[0]) if pool else 0.0,
                              False, model, 0.0)
        pool = [f for f in pool if not f.cand.linear]
    taken = {(f.cand.kind, f.cand.dofs) for f in earlier}
    pool = [f for f in pool if (f.cand.kind, f.cand.dofs) not in taken]
    labels = [lf.label for lf in search.levels]
    # The start model's own misfit where it is declared within its floor scales what the
    # first effect is judged against; a further effect must explain more than all the rest
    # (the start model's error and the earlier estimates' model-form error included).
    ref = 1.0 if earlier else reference(search.levels, search.H0s, [not b for b in beyond])

    candidates = judged(pool)
    scored = judge(search, candidates, earlier, ref)
    winning = {id(f) for f, s in scored if s.wins}
    ranked = list({id(f): f for f, _ in scored}.values())
    ranked += [f for f in pool if all(f is not g for g in candidates)]
    rejected: list[Rejection] = []

    def reject(f: Fit, reason: str) -> None:
        if len(rejected) < MAX_TRIED:
            rejected.append(Rejection(f.cand.label, reason))
            f.evidence["rejected"] = reason

    refused: set[int] = set()
    for f, s in scored:
        if not s.wins:
            if s.gain > OOS_Z * s.deviation and id(f) not in winning:
                reject(f, s.reason(labels))
            continue
        if id(f) in refused:
            continue
        f, s, kinds = kind_ties(search, [fs for fs in scored if id(fs[0]) not in refused],
                                f, s)
        if kinds:   # the numbers the explanation compares are the named one's
            f.evidence.update(s.evidence(), oos_bic=bic(search, f, s))
        fits = with_linear_part(search, f, s) + search.companions(f)
        try:
            fixed = apply_fits(model, fits)
        except ModelError as exc:   # this candidate only: the next one is tried
            reject(f, str(exc))
            refused.add(id(f))
            continue
        return SearchPass(search, [fits[0]] + [g for g in ranked if g is not f],
                          _reduction(search, fits[0]), True, fixed, change(fixed), rejected,
                          fits[1:], kinds)
    pair = None if earlier or refused else held_pair(model, search, scored, ref)
    if pair is not None:
        rejected = [r for r in rejected if r.candidate != pair[0].cand.label]
        pair[0].evidence.pop("rejected", None)
        fixed = apply_fits(model, pair)
        return SearchPass(search, [pair[0]] + [g for g in ranked if g is not scored[0][0]],
                          _reduction(search, scored[0][0]), True, fixed, change(fixed),
                          rejected, pair[1:])
    first = _reduction(search, ranked[0]) if ranked else 0.0
    return SearchPass(search, ranked, first, False, model, 0.0, rejected)


def held_pair(model: Model, search: Search, scored: Sequence[tuple[Fit, Score]], ref: float
              ) -> list[Fit] | None:
    """The first effect accepted together with a second one, when the best first effect
    (``scored[0]``, scored against ``ref``) loses only on the worst-level check: the library
    is judged again with it held in (as in a further pass, `judge`: the second credited
    only with what it adds), and the best winner is accepted with it only if the pair,
    refitted jointly, passes every check of a single effect against the start model
    (`.outofsample.Score.wins` on ``search.H0s`` at ``ref``) and the held effect's own
    parameter stays distinguishable from zero in that fit. Returns the pair refitted
    jointly (`._joint.joint_refit`; the second with its stiffness correction when scored
    with one) or None. A held effect must be a linear error: the search's model does not
    hold an element added for a nonlinear one (`.select.Search.predictor`)."""
    lead, s0 = scored[0]
    if not (s0.distinct and s0.gain > OOS_Z * s0.deviation and s0.gain > s0.left
            and s0.harmed is not None and lead.cand.linear):
        return None
    others = [f for f, _ in scored if (f.cand.kind, f.cand.dofs) != (lead.cand.kind,
                                                                       lead.cand.dofs)]
    kept = [(f, dict(f.evidence)) for f in others]   # the first pass's numbers stay
    second = next(((f, s) for f, s in judge(search, others, [lead], 1.0) if s.wins), None)
    for f, ev in kept:
        f.evidence.clear()
        f.evidence.update(ev)
    if second is None:
        return None
    f, s = second
    both = score(search.levels, search.H0s, search.predictor(f, s.joint is not None, [lead]),
                 ref)
    held = both.interval[-1]
    if not (both.wins and (held[0] > 0 or held[1] < 0)):
        return None
    f.evidence.update(s.evidence(), pair_with=lead.cand.label, pair_gain=both.gain,
                      pair_sd=both.deviation)
    return joint_refit(model, search, [lead] + with_linear_part(search, f, s))


def judge(search: Search, candidates: Sequence[Fit], earlier: Sequence[Fit], ref: float
          ) -> list[tuple[Fit, Score]]:
    """Each candidate's out-of-sample score, best gain first: alone, or jointly with a
    stiffness correction at its location where the data support the correction
    (`supported`; linear errors and memory laws fitted in all their parameters alone); the
    numbers recorded in its evidence."""
    base = baseline(search, candidates, earlier)
    alone = [(f, score(search.levels, base, search.predictor(f, False, earlier), ref))
             for f in candidates]
    out = []
    for f, s in alone:
        if not f.cand.linear and not (f.cand.memory and f.extra is None):
            pair = score(search.levels, base, search.predictor(f, True, earlier), ref)
            k = n_params(f, pair)
            if supported(s, pair, [sg for g, sg in alone if sg.wins and n_params(g, sg) < k]):
                s = pair
        f.evidence.update(s.evidence())
        out.append((f, s))
    return sorted(out, key=lambda fs: -fs[1].gain)


def baseline(search: Search, candidates: Sequence[Fit], earlier: Sequence[Fit]
             ) -> list[np.ndarray]:
    """What a candidate's gain is measured from: the current model, or with ``earlier``
    accepted effects, the current model with them refitted alone (`.outofsample.refitted`:
    a further candidate scored with them free is credited only with what it adds)."""
    for f in candidates if earlier else ():
        if not (f.cand.memory and f.extra is None):
            return refitted(search.levels, search.predictor(f, False, earlier))
    return search.H0s


def supported(alone: Score, pair: Score, simpler: Sequence[Score]) -> bool:
    """Whether the data support a candidate's joint stiffness correction: the correction's
    95 % interval on all fitting levels excludes zero, and the pair predicts out of sample
    better, beyond the uncertainty of the two (`.outofsample.tied`), than the candidate
    alone and than every candidate that wins alone with fewer parameters (``simpler``).
    Whatever the start model's provenance: one fitted where the structure is already
    nonlinear holds that level's equivalent stiffness, which the correction takes out."""
    if pair.joint is None or pair.interval[1] == (0.0, 0.0):
        return False
    return all(pair.gain > s.gain and not tied(s, pair) for s in [alone, *simpler])


def n_params(fit: Fit, s: Score) -> int:
    """The candidate's parameters as scored: coefficients, nuisance and a refined grid
    value."""
    return len(s.estimate) + (fit.extra is not None)


def bic(search: Search, fit: Fit, s: Score) -> float:
    """The candidate's BIC on the fitting levels as scored: its misfit plus ``ln N`` per
    parameter (coefficients, nuisance and a refined grid value)."""
    return float(s.chi2 + n_params(fit, s) * np.log(search.n_values))


def kind_ties(search: Search, scored: Sequence[tuple[Fit, Score]], f: Fit, s: Score
              ) -> tuple[Fit, Score, tuple[KindAlternative, ...]]:
    """The winner named among the kinds the data cannot tell from ``f`` (the winner with the
    largest gain), and the others as `KindAlternative`s. A kind is tied with ``f`` when it
    wins too and their gains differ by less than the difference's uncertainty
    (`.outofsample.tied`). Among the tied (each kind at its best gain) the one that
    encompasses all the others (`.encompass.encompassing`: it still wins out of sample on
    the model holding any other, and no other on the model holding it) is named alone, with
    them in its evidence (``encompasses``): the data do tell them apart. Else the tie stands
    and the one with the lowest `bic` is named: at equal fit, the one with fewer
    parameters. At most `.where.MAX_ALTERNATIVES` are listed, the best scored first, each
    with its parameters, the numbers of its side of the tie and what would separate it from
    the named one at the highest fitting level (`.separate.separation`)."""
    best: dict[str, tuple[Fit, Score]] = {}
    for g, sg in scored:
        if sg.wins and g.cand.kind not in best and (g is f or tied(s, sg)):
            best[g.cand.kind] = (g, sg)
    if len(best) < 2:
        return f, s, ()
    won = encompassing(search, list(best.values()))
    if won is not None:
        f, s = won
        f.evidence["encompasses"] = ", ".join(k for k in best if k != f.cand.kind)
        return f, s, ()
    f, s = min(best.values(), key=lambda gs: bic(search, *gs))
    f.evidence.update(oos_reference=float(s.ref), oos_left=float(s.left))
    named = as_scored(f, s)
    out = []
    for g, sg in best.values():
        if g is not f:
            law = as_scored(g, sg)
            out.append(KindAlternative(g.cand.kind, g.cand.dofs, tuple(g.cand.points),
                                       sg.gain, sg.sd, bic(search, g, sg), law.params,
                                       law.ci95, float(sg.ref), float(sg.left),
                                       separation(search, named, law,
                                                  tie_threshold(s, sg))))
    return f, s, tuple(out[:MAX_ALTERNATIVES])


def as_scored(fit: Fit, s: Score) -> Law:
    """``fit``'s law as it was scored: its parameters at the joint estimate with its
    stiffness correction when it was scored jointly with one (else as fitted)."""
    if s.joint is None or fit.cand.memory and fit.extra is None:
        return Law(fit.cand, dict(fit.params), {k: (v[0], v[1]) for k, v in fit.ci95.items()})
    name = coef_name(fit.cand.kind)
    ci = dict({k: (v[0], v[1]) for k, v in fit.ci95.items()}, **{name: s.interval[0]})
    return Law(fit.cand, scaled_params(fit.cand.kind, s.estimate[0], fit.extra), ci,
               float(s.joint))


def other_kinds(fits: list[Fit], n: int) -> list[Fit]:
    """The best of ``fits`` (best first) of every kind and form not among the first ``n``."""
    seen = {(f.cand.kind, f.cand.compensated) for f in fits[:n]}
    out = []
    for f in fits[n:]:
        if (f.cand.kind, f.cand.compensated) not in seen:
            seen.add((f.cand.kind, f.cand.compensated))
            out.append(f)
    return out


def judged(pool: Sequence[Fit]) -> list[Fit]:
    """The candidates of ``pool`` (best in sample first) judged out of sample: the `SCORED`
    best, and the best of every element kind (and form) not among them. An element kind
    that explains the data only together with a correction of the linear part ranks low in
    sample, where the linear error is unexplained; its out-of-sample judgement must not hang
    on how many other kinds the library holds."""
    head = list(pool[:SCORED])
    return head + other_kinds(head + [f for f in pool[SCORED:] if not f.cand.linear], SCORED)


def with_linear_part(search: Search, fit: Fit, s: Score) -> list[Fit]:
    """The accepted effect, and with it the stiffness correction at its location when it was
    scored jointly with one distinguishable from zero: both at their joint estimate."""
    if s.joint is None or s.interval[1] == (0.0, 0.0):
        return [fit]
    c = fit.cand
    ev = {"estimator": f"joint fit with {c.label}"}
    params = scaled_params(c.kind, s.estimate[0], fit.extra)
    name = coef_name(c.kind)
    own = Fit(c, params, {name: list(s.interval[0])}, s.chi2, fit.delta_bic,
              dict(fit.evidence, estimator="joint fit with the stiffness correction",
                   sequential_estimate=fit.params[name]), extra=fit.extra)
    lin = Candidate("stiffness_error", c.dofs, c.n_dof, names=c.names)
    return [own, Fit(lin, {"delta_stiffness": s.estimate[1]},
                     {"delta_stiffness": list(s.interval[1])}, s.chi2, fit.delta_bic, ev)]


def _reduction(search: Search, fit: Fit) -> float:
    return float((search.chi2_0 - fit.chi2) / search.chi2_0)


def residual_dependent(search: Search) -> bool:
    """True when the current model's misfit changes with level beyond the random error
    (the homogeneity test on the residuals ``H - H_model`` of the lowest and highest fitting
    level): within every floor, the model still misses how the structure changes with
    level, which only a nonlinear candidate can explain. On the starting linear model this
    is the level-dependence test of the measured FRFs."""
    dep = level_dependence([replace(lf, H=lf.H - h) for lf, h in zip(search.levels,
                                                                      search.H0s)])
    return dep is not None and dep.dependent


def linear_only(search: Search, floors: Sequence[Floor]) -> bool:
    """True when no nonlinear candidate is supported by the data: the fitting levels' FRFs
    are the same within their random error (homogeneity, paper chapter 2) and the floors
    (``floors``, in the search's order) do not already show a misfit that grows with level
    (`misfit_grows`). The gate may order the search, never forbid the candidates that could
    explain a misfit the floors show: the band-wide homogeneity test dilutes a change
    confined to a resonance's lines among hundreds of unchanged ones."""
    if misfit_grows(search, floors):
        return False
    dep = level_dependence(search.levels)
    return dep is not None and not dep.dependent


def misfit_grows(search: Search, floors: Sequence[Floor]) -> bool:
    """True when the highest fitting level misfits the current model beyond its floor while
    the lowest lies within its own (``floors`` in the search's order)."""
    beyond = beyond_floor(search, floors)
    order = np.argsort([lf.level for lf in search.levels])
    return len(order) > 1 and beyond[order[-1]] and not beyond[order[0]]


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
                  0.0, 0.0, tuple(r.candidate for r in rejected))
    return Misfit(c.label, (float(c.freqs[i0]), float(c.freqs[i1])), tuple(dofs),
                  tuple(first.search.model.points[i] for i in dofs), tuple(per_dof),
                  tuple(TrendPoint(x.level, x.error_after, x.floor.limit)
                        for x in sorted(curves, key=lambda x: x.level)), tried)
