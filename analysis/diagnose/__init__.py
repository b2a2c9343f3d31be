"""Model-mismatch diagnosis: locate the mismatch, name the missing physics, model it.

`diagnose(model, recordings)` compares the model with recordings at several levels, tests
whether the structure behaves nonlinearly (homogeneity across levels), searches the one
candidate library (`candidates.library`: nonlinear elements and linear errors at every DOF
and DOF pair) by information criterion, estimates the chosen candidate's parameters (reverse
path for random data, harmonic-balance fit for stepped sine), searches again on the corrected
model for a further effect (accepted ones are refitted jointly) and shows the improvement on
a recording held back from fitting: FRFs per level and time residuals of replays of the
measured force (`replay`). See docs/diagnose.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..model import Model
from ..recording import Recording
from .candidates import Candidate, library
from .compare import FLOOR, choose_nperseg, level_frf, model_frf, unit_force, weighted_error
from .joint import joint_refit
from .locate import level_dependence, mismatch_band
from .prepare import (DiagnoseInputError, Prepared, analysis_band, prepare_random,
                      record_level, split_segment)
from .replay import horizon_samples, replay
from .report import METRIC, Diagnosis, LevelCurves, explain, time_fit
from .select import SHORTLIST, Fit, RandomSearch, Search, corrected_model

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

__all__ = ["diagnose", "Diagnosis", "Candidate", "library", "DiagnoseInputError"]


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


def _pick_holdout(levels: list[float], holdout: float | str | None) -> int | None:
    """Index (into ascending levels) held back; None means a held-back segment."""
    if holdout == "segment" or (holdout is None and len(levels) == 1):
        return None
    if holdout is None:
        return len(levels) // 2 if len(levels) >= 3 else 0
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
    return i


def diagnose(model: Model, recordings: Sequence[Recording], *,
             holdout: float | str | None = None, band: tuple[float, float] | None = None,
             nperseg: int | None = None, period: int | None = None,
             floor: float = FLOOR) -> Diagnosis:
    """Diagnose what ``model`` lacks to explain ``recordings``.

    Parameters
    ----------
    model : Model
        Starting model (complete: every element parameter given).
    recordings : sequence of Recording
        Random (or periodic multisine) runs, or stepped-sine runs, one level each.
    holdout : float or "segment", optional
        Level held back from fitting (default: the middle level of three or more, the lowest
        of two); "segment" (or a single recording) holds back the last 30 % of each run.
    band : (lo, hi), optional
        Analysis band, Hz (default: the excited band of the force).
    nperseg : int, optional
        Welch segment length (default: resolves the narrowest model resonance).
    period : int, optional
        Samples per period of a periodic drive (else the recording's ``layout.period``).
    floor : float
        Model-precision floor, relative FRF deviation treated as insignificant.

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
    preps = [prepare_random(r, band, f"level {record_level(r):g}",
                            period=int(p) if p else None) for r, p in zip(recs, per)]
    hold = _pick_holdout([p.level for p in preps], holdout)
    if hold is None:
        pairs = [split_segment(p) for p in preps]
        fit_preps, held = [a for a, _ in pairs], [b for _, b in pairs]
    else:
        fit_preps = [p for i, p in enumerate(preps) if i != hold]
        held = [preps[hold]]
    if min(p.x.shape[0] for p in fit_preps + held) < 4 * nps:
        raise DiagnoseInputError(f"records are too short for segments of {nps} samples; give "
                                 "longer runs or a smaller --nperseg")
    passes = []
    current = model
    for _ in range(MAX_EFFECTS):
        step = _search_pass(current, fit_preps, band, nps, floor,
                            [s.best.cand for s in passes if s.found])
        passes.append(step)
        if not step.found:
            break
        current = step.fixed
    first = passes[0]

    def change(without: Model, fits: list[Fit]) -> float:
        return model_change([_curves(without, _apply(model, fits), p, band, nps, floor, False)
                             for p in fit_preps])
    chosen = _pruned(model, first.search, [s.best for s in passes if s.found], change)
    current = _apply(model, chosen)
    horizon = horizon_samples(model, recs[0].fs)
    curves = [_curves(model, current, p, band, nps, floor, i >= len(fit_preps), horizon)
              for i, p in enumerate(fit_preps + held)]
    held_curves = [c for c in curves if c.held_back]
    before = float(np.mean([c.error_before for c in held_curves]))
    after = float(np.mean([c.error_after for c in held_curves]))
    dep = level_dependence(first.search.levels + (
        [_level(model, h, band, nps, floor) for h in held] if hold is not None else []))
    top = max(first.search.levels, key=lambda lf: lf.level)
    loc_band = mismatch_band(top, first.search.H0s[first.search.levels.index(top)])
    location = {"dofs": sorted({d for f in chosen for d in f.cand.dofs}),
                "band_hz": [loc_band[0], loc_band[1]] if chosen else None}
    d = Diagnosis(
        "discrepancy" if chosen else "adequate",
        dep.dependent if dep else None,
        [f.to_json() for f in chosen],
        [f.to_json() for f in first.pool[:8]],
        location,
        {"metric": METRIC, "before": before, "after": after,
         "held_back": [h.label for h in held], "time_residual": time_fit(held_curves)},
        current, curves,
        {"chi2_start": first.search.chi2_0, "n_values": first.search.n_values,
         "chi2_reduction": first.reduction, "band_hz": list(band), "nperseg": nps,
         "model_change": first.effect, "replay_horizon_samples": horizon,
         "passes": [s.to_json() for s in passes],
         "pruned_after_joint_refit": pruned_labels(passes, chosen),
         "level_dependence": dep.to_json() if dep else None,
         "residual_share_by_dof": _share(first.search)},
        warnings)
    d.explanation = explain(d, [f.cand for f in chosen])
    return d


def pruned_labels(passes: list[SearchPass], chosen: list[Fit]) -> list[str]:
    """Labels of accepted candidates that `_pruned` dropped."""
    kept = [f.cand for f in chosen]
    return [s.best.cand.label for s in passes if s.found and s.best.cand not in kept]


def _pruned(model: Model, search: Search, fits: list[Fit],
            change: Callable[[Model, list[Fit]], float]) -> list[Fit]:
    """Joint refit, then drop a later effect that the joint estimate makes irrelevant (its
    removal changes the model FRFs by less than `MIN_EFFECT`: it only stood in for the
    sequential error of an earlier estimate) and refit the rest."""
    chosen = joint_refit(model, search, fits)
    for k in range(len(chosen) - 1, 0, -1):
        others = chosen[:k] + chosen[k + 1:]
        if change(_apply(model, others), chosen) < MIN_EFFECT:
            return _pruned(model, search, [f for f in fits if f.cand != chosen[k].cand],
                           change)
    return chosen


def _apply(model: Model, fits: list[Fit]) -> Model:
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

    @property
    def best(self) -> Fit:
        return self.pool[0]

    def to_json(self) -> dict:
        b = self.pool[0] if self.pool else None
        return {"best": b.cand.label if b else None,
                "delta_bic": float(b.delta_bic) if b else None,
                "chi2_start": float(self.search.chi2_0),
                "chi2_reduction": float(self.reduction),
                "model_change": float(self.effect), "accepted": bool(self.found)}


def decide(model: Model, search: Search, pool: list[Fit],
           change: Callable[[Model], float], *, further: bool = False,
           accepted: Sequence[Candidate] = ()) -> SearchPass:
    """Accept the best candidate of ``pool`` not ``accepted`` in an earlier pass if it passes
    all three thresholds (a stricter misfit reduction for a ``further`` effect)."""
    pool = [f for f in pool if f.cand not in accepted]
    best = pool[0] if pool else None
    reduction = (search.chi2_0 - best.chi2) / search.chi2_0 if best else 0.0
    min_red = MIN_REDUCTION_NEXT if further else MIN_REDUCTION
    found = best is not None and best.delta_bic > BIC_MIN and reduction > min_red
    fixed = corrected_model(model, best) if found else model
    effect = change(fixed) if found else 0.0
    if found and effect < MIN_EFFECT:
        found, fixed = False, model
    return SearchPass(search, pool, reduction, found, fixed, effect)


def linear_only(search: Search) -> bool:
    """True when the fitting levels' FRFs are the same within their random error: then no
    nonlinear candidate is supported by the data (homogeneity, paper chapter 2)."""
    dep = level_dependence(search.levels)
    return dep is not None and not dep.dependent


def _search_pass(model: Model, fit_preps: list[Prepared], band, nps: int,
                 floor: float, accepted: list[Candidate]) -> SearchPass:
    """Screen the library, refine the best nonlinear ones by reverse path, decide."""
    search = RandomSearch(model, fit_preps, band, nps, floor)
    fits = search.screen()
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
    return decide(model, search, pool, change, further=bool(accepted), accepted=accepted)


def model_change(curves: list[LevelCurves]) -> float:
    """Relative rms change of the model FRFs made by the correction (fitting levels)."""
    num = sum(float(np.sum(np.abs(c.after - c.before) ** 2)) for c in curves)
    den = sum(float(np.sum(np.abs(c.measured) ** 2)) for c in curves)
    return float(np.sqrt(num / den))


def _share(search: RandomSearch) -> list[float]:
    from .compare import error_by_dof
    top = max(range(len(search.levels)), key=lambda i: search.levels[i].level)
    return [float(s) for s in error_by_dof(search.levels[top], search.H0s[top])]


def _level(model: Model, p: Prepared, band, nps: int, floor: float):
    bases = {("model", i): unit_force(el.kind, el.params, el.w, p)
             for i, el in enumerate(model.elements)}
    return level_frf(p, band, nps, bases, floor=floor)


def _predicted(model: Model, p: Prepared, band, nps: int, floor: float):
    lf = _level(model, p, band, nps, floor)
    terms = [(el.w, 1.0, ("model", i)) for i, el in enumerate(model.elements)]
    return lf, model_frf(model.linear_frf(lf.freqs), lf, terms)


def _curves(start: Model, fixed: Model, p: Prepared, band, nps: int, floor: float,
            held: bool, horizon: int | None = None) -> LevelCurves:
    """FRFs of one level before/after; with ``horizon``, also the short-horizon replays."""
    lf, h_before = _predicted(start, p, band, nps, floor)
    _, h_after = _predicted(fixed, p, band, nps, floor)
    c = LevelCurves(p.label, p.level, held, lf.freqs, lf.H, h_before, h_after,
                    weighted_error(lf, h_before), weighted_error(lf, h_after), lf.coh)
    if horizon is not None:
        c.replay_before = replay(start, p, horizon)
        c.replay_after = c.replay_before if fixed is start else replay(fixed, p, horizon)
    return c
