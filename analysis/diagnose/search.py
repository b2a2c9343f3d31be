"""The diagnosis entry point and its search over random-data levels (`diagnose`); stepped
sine goes to `.stepped`."""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from ..models import Model
from ..plant import PlantError
from ..recordings import Recording
from .candidates import Candidate
from .compare import (FLOOR, choose_nperseg, element_force, level_frf, model_frf,
                      stuck_linear, weighted_error)
from .leakage import leakage_bias, level_floor
from .locate import level_dependence, mismatch_band
from .prepare import (DiagnoseInputError, Prepared, analysis_band, level_name, prepare_random,
                      prepared_band, record_level, split_segment)
from .replay import Replay, horizon_samples, replay, steady_replay
from .report import METRIC, Diagnosis, LevelCurves, explain, level_fit, time_fit, worsened
from .select import SHORTLIST, Fit, RandomSearch
from .joint import joint_refit
from .policy import (BIC_MIN, location_table, MAX_EFFECTS, SearchPass, _apply, _pick_holdout,
                     _pruned, decide, joint_veto, linear_only, misfit_summary, model_change,
                     pruned_labels)


def _check(model: Model, recordings: Sequence[Recording]) -> list[Recording]:
    recs = list(recordings)
    if not recs:
        raise DiagnoseInputError("no recordings given; pass at least one run")
    for r in recs:
        if r.n_dof != model.n_dof:
            raise DiagnoseInputError(
                f"a recording has {r.n_dof} response channels but the model has {model.n_dof} "
                "DOFs; the diagnosis needs every DOF measured")
    model.require_complete("a diagnosis")
    return recs


Progress = Callable[[int, int, str], None]
"""``progress(done, total, stage)``: called as the diagnosis advances (search passes, joint
refit, replays of each level)."""


def diagnose(model: Model, recordings: Sequence[Recording], *,
             holdout: float | str | None = None, band: tuple[float, float] | None = None,
             nperseg: int | None = None, period: int | None = None,
             floor: float = FLOOR, progress: Progress | None = None) -> Diagnosis:
    """Diagnose what ``model`` lacks to explain ``recordings``.

    Parameters
    ----------
    model : Model
        Starting model (complete: every element parameter given).
    recordings : sequence of Recording
        Random (or periodic multisine) runs, or stepped-sine runs, one level each.
    holdout : float or "segment", optional
        Level held back from fitting (default: the lowest of two levels, the middle one of
        three, every other interior level of four or more); "segment" (or a single
        recording) holds back the last 30 % of each run.
    band : (lo, hi), optional
        Analysis band, Hz (default: the excited band of the force).
    nperseg : int, optional
        Welch segment length (default: resolves the narrowest model resonance).
    period : int, optional
        Samples per period of a periodic drive (else the recording's ``layout.period``).
    floor : float
        Model-precision floor, relative FRF deviation treated as insignificant.
    progress : callable, optional
        ``progress(done, total, stage)`` (random data).

    Returns
    -------
    Diagnosis
    """
    recs = _check(model, recordings)
    if all(r.excitation == "stepped-sine" for r in recs):
        from .stepped import diagnose_stepped
        return diagnose_stepped(model, recs, holdout=holdout, floor=floor)
    warnings = []
    if any(r.excitation != "random" for r in recs):
        warnings.append("stepped-sine runs ignored: the random runs were diagnosed")
        recs = [r for r in recs if r.excitation == "random"]
    if len({r.fs for r in recs}) > 1 or len({tuple(r.force_dofs) for r in recs}) > 1:
        raise DiagnoseInputError("the runs differ in sample rate or force DOFs; diagnose "
                                 "runs of one test set-up together")
    recs.sort(key=record_level)
    per = [period or (r.layout.period if r.layout else None) for r in recs]
    n_min = min(r.force.shape[0] for r in recs)
    nps = nperseg if nperseg is not None else choose_nperseg(model, recs[0].fs, n_min)
    if band is None:
        band = analysis_band(recs[0], per[0] or nps)
    band = (float(band[0]), float(band[1]))
    preps = [prepare_random(r, band, level_name(r),
                            period=int(p) if p else None) for r, p in zip(recs, per)]
    hold = _pick_holdout([p.level for p in preps], holdout)
    if hold is None:
        pairs = [split_segment(p) for p in preps]
        fit_preps, held = [a for a, _ in pairs], [b for _, b in pairs]
    else:
        fit_preps = [p for i, p in enumerate(preps) if i not in hold]
        held = [preps[i] for i in hold]
    all_preps = fit_preps + held
    if min(p.x.shape[0] for p in all_preps) < 4 * nps:
        raise DiagnoseInputError(f"records are too short for segments of {nps} samples; give "
                                 "longer runs or a smaller --nperseg")
    tick = _ticker(progress, MAX_EFFECTS + 1 + 2 * len(all_preps))
    floors = [level_floor(_level(model, p, band, nps, floor), floor) for p in all_preps]

    def judge(previous: Model, fixed: Model) -> str | None:
        return worsened([_curves(previous, fixed, p, band, nps, floor, i >= len(fit_preps))
                         for i, p in enumerate(all_preps)], floors)

    passes: list[SearchPass] = []
    current = model
    settled = False
    for k in range(MAX_EFFECTS):
        tick(f"search pass {k + 1}")
        found = [s.best for s in passes if s.found]
        step = _search_pass(current, fit_preps, band, nps, floor, [f.cand for f in found],
                            joint_veto(model, lambda: passes[0].search, found, judge),
                            memoryless=settled)
        passes.append(step)
        if not step.found:
            break
        current = step.fixed
        # With every fitting level within its floor (the effects so far refitted jointly, as
        # the final correction will be), a further effect must be one the joint refit can
        # re-estimate with the others: a memory element would only absorb their sequential
        # estimation error.
        joint = _apply(model, joint_refit(model, passes[0].search,
                                          [s.best for s in passes if s.found]))
        settled = all(_curves(model, joint, p, band, nps, floor, False).error_after <= fl.limit
                      for p, fl in zip(fit_preps, floors))
    first = passes[0]

    def change(without: Model, fits: list[Fit]) -> float:
        return model_change([_curves(without, _apply(model, fits), p, band, nps, floor, False)
                             for p in fit_preps])
    tick("joint refit")
    chosen = _pruned(model, first.search, [s.best for s in passes if s.found], change)
    rejected = [dict(r, stage=f"search pass {k + 1}") for k, s in enumerate(passes)
                for r in s.rejected]
    horizon = horizon_samples(model, recs[0].fs)
    start_replays = _replays(model, all_preps, horizon, band, warnings, tick)
    while True:   # the final correction must not worsen a level, and its replay must run
        current = _apply(model, chosen)
        curves = [_curves(model, current, p, band, nps, floor, i >= len(fit_preps))
                  for i, p in enumerate(all_preps)]
        reason = worsened(curves, floors) if chosen else None
        if reason is None and chosen:
            try:
                after_replays = []
                for p in all_preps:
                    tick(f"replay of {p.label} (corrected model)")
                    after_replays.append(_replay(current, p, horizon, band))
            except PlantError as exc:
                reason = f"the corrected model's replay fails ({exc})"
        if reason is None:
            break
        rejected.append({"candidate": chosen[-1].cand.label, "reason": reason,
                         "stage": "joint correction"})
        chosen = _pruned(model, first.search, chosen[:-1], change) if chosen[1:] else []
    for c, fl, before in zip(curves, floors, start_replays):
        c.floor = fl
        c.replay_before = before
        c.replay_after = after_replays[curves.index(c)] if chosen else before
    tick("done", finished=True)
    held_curves = [c for c in curves if c.held_back]
    before = float(np.mean([c.error_before for c in held_curves]))
    after_err = float(np.mean([c.error_after for c in held_curves]))
    dep = level_dependence(first.search.levels + (
        [_level(model, h, band, nps, floor) for h in held] if hold is not None else []))
    top = max(first.search.levels, key=lambda lf: lf.level)
    loc_band = mismatch_band(top, first.search.H0s[first.search.levels.index(top)])
    dofs = sorted({d for f in chosen for d in f.cand.dofs})
    location = {"dofs": dofs, "points": [model.points[i] for i in dofs],
                "band_hz": [loc_band[0], loc_band[1]] if chosen else None}
    within = all(c.error_after <= c.floor.limit for c in curves)
    verdict = "discrepancy" if chosen else "adequate" if within else "unexplained"
    misfit = None
    if not within:
        misfit = misfit_summary(curves, first, rejected)
        if verdict == "unexplained":
            location = {"dofs": misfit["dofs"], "points": misfit["points"],
                        "band_hz": misfit["band_hz"]}
    d = Diagnosis(
        verdict,
        dep.dependent if dep else None,
        [f.to_json() for f in chosen],
        [f.to_json() for f in first.pool[:8]],
        location,
        {"metric": METRIC, "before": before, "after": after_err,
         "held_back": [h.label for h in held], "time_residual": time_fit(held_curves),
         **level_fit(curves)},
        current, curves,
        {"chi2_start": first.search.chi2_0, "n_values": first.search.n_values,
         "chi2_reduction": first.reduction, "band_hz": list(band), "nperseg": nps,
         "model_change": first.effect, "replay_horizon_samples": horizon,
         "passes": [s.to_json() for s in passes],
         "locations": location_table(first.search, first.pool),
         "pruned_after_joint_refit": pruned_labels(passes, chosen),
         "rejected": rejected, "misfit": misfit,
         "level_dependence": dep.to_json() if dep else None,
         "residual_share_by_dof": _share(first.search)},
        warnings)
    d.explanation = explain(d, [f.cand for f in chosen])
    return d


def _ticker(progress: Progress | None, total: int) -> Callable[..., None]:
    """``tick(stage)`` reports the start of the next step; ``finished=True`` the end."""
    done = [0]

    def tick(stage: str, finished: bool = False) -> None:
        done[0] = total if finished else done[0]
        if progress is not None:
            progress(done[0], total, stage)
        done[0] += 1
    return tick


def _replay(model: Model, p: Prepared, horizon: int, band: tuple[float, float]) -> Replay:
    """Steady-state replay of a periodic record, short-horizon replays of a random one."""
    if p.period is not None:
        hp, lp = prepared_band(p, band)
        return steady_replay(model, p, hp, lp)
    return replay(model, p, horizon)


def _replays(model: Model, preps: list[Prepared], horizon: int, band: tuple[float, float],
             warnings: list[str], tick: Callable[[str], None]) -> list[Replay | None]:
    """Replays of the starting model (None, with a warning, where its simulation fails)."""
    out: list[Replay | None] = []
    for p in preps:
        tick(f"replay of {p.label}")
        try:
            out.append(_replay(model, p, horizon, band))
        except PlantError as exc:
            warnings.append(f"the starting model's replay of {p.label} fails ({exc}): no "
                            "time residual for it")
            out.append(None)
    return out


def _search_pass(model: Model, fit_preps: list[Prepared], band, nps: int,
                 floor: float, accepted: list[Candidate],
                 veto: Callable[[Fit], str | None], memoryless: bool = False) -> SearchPass:
    """Screen the library, refine the best nonlinear ones by reverse path, decide
    (``memoryless``: memory kinds are not offered)."""
    search = RandomSearch(model, fit_preps, band, nps, floor)
    fits = [f for f in search.screen() if not (memoryless and f.cand.memory)]
    if linear_only(search):
        fits = [f for f in fits if f.cand.linear]
    nonlinear = [f for f in fits if not f.cand.linear and f.delta_bic > 0][:SHORTLIST]
    refined = [search.refine(f) for f in nonlinear]
    pool = sorted(refined + [f for f in fits if f.cand.linear], key=lambda f: -f.delta_bic)
    if pool and not pool[0].cand.linear and pool[0].delta_bic > BIC_MIN:
        # Final estimate of the leading candidate, debiased for sensor noise when needed.
        screened = nonlinear[refined.index(pool[0])]
        final = search.refine(screened, noise="auto")
        pool[0] = final if final is not screened else pool[0]

    def change(fixed: Model) -> float:
        return model_change([_curves(model, fixed, p, band, nps, floor, False)
                             for p in fit_preps])
    return decide(model, search, pool, change, further=bool(accepted), accepted=accepted,
                  veto=veto)


def _share(search: RandomSearch) -> list[float]:
    from .compare import error_by_dof
    top = max(range(len(search.levels)), key=lambda i: search.levels[i].level)
    return [float(s) for s in error_by_dof(search.levels[top], search.H0s[top])]


def _level(model: Model, p: Prepared, band, nps: int, floor: float):
    bases = {("model", i): element_force(el, p) for i, el in enumerate(model.elements)}
    return level_frf(p, band, nps, bases, floor=floor)


def _predicted(model: Model, p: Prepared, band, nps: int, floor: float):
    lf = _level(model, p, band, nps, floor)
    terms = [(el.w, 1.0, ("model", i)) for i, el in enumerate(model.elements)]
    linear = stuck_linear(model)
    lf.leakage = leakage_bias(linear, lf, terms)
    return lf, model_frf(linear.linear_frf(lf.freqs), lf, terms)


def _curves(start: Model, fixed: Model, p: Prepared, band, nps: int, floor: float,
            held: bool) -> LevelCurves:
    """FRFs of one level before/after (the replays are added by `diagnose`)."""
    lf, h_before = _predicted(start, p, band, nps, floor)
    _, h_after = _predicted(fixed, p, band, nps, floor) if fixed is not start else (lf, h_before)
    return LevelCurves(p.label, p.level, held, lf.freqs, lf.H, h_before, h_after,
                       weighted_error(lf, h_before), weighted_error(lf, h_after), lf.weight)
