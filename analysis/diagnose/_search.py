"""The diagnosis entry point (`diagnose`) and its random-data flow (`RandomFlow`): Welch
FRFs of prepared levels, reverse-path refinement, replays of the measured force; stepped sine
goes to `.stepped`. Both run on `.engine`."""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from ..models import Model
from ..plant import PlantError
from ..recordings import Recording, recording_clipping
from ._compare import (FLOOR, choose_nperseg, element_force, error_by_dof, level_frf, model_frf,
                      stuck_linear, weighted_error)
from ._compare import LevelFRF
from ._engine import Flow, Progress, Tick, run
from ._alignment import aligned
from ._leakage import Floor, leakage_bias, level_floor
from ._prepare import (DiagnoseInputError, Prepared, analysis_band, cleaned_exports, clipped_note,
                       level_name, prepare_random, prepared_band, record_level, split_segment)
from ._replay import Replay, horizon_samples, replay, steady_replay
from ._report import LevelCurves
from ._evidence import Evidence
from ._result import Diagnosis
from ._select import SHORTLIST, Fit, RandomSearch
from ._policy import BIC_MIN, MAX_EFFECTS, SearchPass, linear_only, other_kinds, pick_holdout
from ._where import location_table, screening

METRIC = ("coherence-weighted relative FRF error in the recorded response kind (rms over the "
          "analysis band) on the held-back recording")


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
        ``progress(done, total, stage)``.

    Returns
    -------
    Diagnosis
    """
    recs = _check(model, recordings)
    if all(r.excitation == "stepped-sine" for r in recs):
        from ._stepped import SteppedFlow
        return run(SteppedFlow(model, recs, holdout=holdout, floor=floor), progress)
    return run(RandomFlow(model, recs, holdout=holdout, band=band, nperseg=nperseg,
                          period=period, floor=floor), progress)


class RandomFlow(Flow):
    """Random (or periodic multisine) levels: the fitting levels, then the held-back ones
    (or every level's first 70 % and then its held-back last 30 %)."""

    metric = METRIC
    settle = True
    refit_on_reject = True

    def __init__(self, model: Model, recs: list[Recording], *, holdout: float | str | None,
                 band: tuple[float, float] | None, nperseg: int | None, period: int | None,
                 floor: float) -> None:
        super().__init__()
        if any(r.excitation != "random" for r in recs):
            self.warnings.append("stepped-sine runs ignored: the random runs were diagnosed")
            recs = [r for r in recs if r.excitation == "random"]
        if len({r.fs for r in recs}) > 1 or len({tuple(r.force_dofs) for r in recs}) > 1:
            raise DiagnoseInputError("the runs differ in sample rate or force DOFs; diagnose "
                                     "runs of one test set-up together")
        recs, notes = cleaned_exports(recs)
        self.warnings += notes
        recs.sort(key=record_level)
        per = [period or (r.layout.period if r.layout else None) for r in recs]
        n_min = min(r.force.shape[0] for r in recs)
        nps = nperseg if nperseg is not None else choose_nperseg(model, recs[0].fs, n_min)
        if band is None:
            band = analysis_band(recs[0], per[0] or nps)
        band = (float(band[0]), float(band[1]))
        clips = [recording_clipping(r, level_name(r)) for r in recs]
        preps = [prepare_random(r, band, level_name(r), period=int(p) if p else None,
                                clipped=c) for r, p, c in zip(recs, per, clips)]
        self.warnings += [clipped_note(c, q) for c, q in zip(clips, preps) if c is not None]
        preps, self.delay = aligned(preps, lambda p: _misfit(model, p, band, nps, floor),
                                    lambda p: _ratio(model, p, band, nps, floor))
        if self.delay is not None:
            self.warnings.append(self.delay.note())
        hold = pick_holdout([p.level for p in preps], holdout)
        if hold is None:
            pairs = [split_segment(p) for p in preps]
            fit_preps, held = [a for a, _ in pairs], [b for _, b in pairs]
        else:
            fit_preps = [p for i, p in enumerate(preps) if i not in hold]
            held = [preps[i] for i in hold]
        self.preps = fit_preps + held
        if min(p.x.shape[0] for p in self.preps) < 4 * nps:
            raise DiagnoseInputError(f"records are too short for segments of {nps} samples; "
                                     "give longer runs or a smaller --nperseg")
        self.model, self.band, self.nps, self.floor = model, band, nps, floor
        self.held = tuple(i >= len(fit_preps) for i in range(len(self.preps)))
        self.segment = hold is None
        self.horizon = horizon_samples(model, recs[0].fs)
        self.steps = MAX_EFFECTS + 1 + 2 * len(self.preps)
        self.floors = [level_floor(_level(model, p, band, nps, floor), floor)
                       for p in self.preps]

    def curve(self, start: Model, fixed: Model, i: int) -> LevelCurves:
        return _curves(start, fixed, self.preps[i], self.band, self.nps, self.floor,
                       self.held[i])

    def pool(self, current: Model, memoryless: bool) -> tuple[RandomSearch, list[Fit]]:
        """Screen the library, refine the best nonlinear ones by reverse path."""
        search = RandomSearch(current, [self.preps[i] for i in self.fit_idx], self.band,
                              self.nps, self.floor)
        fits = [f for f in screening(search) if not (memoryless and f.cand.memory)]
        if linear_only(search, [self.floors[i] for i in self.fit_idx]):
            fits = [f for f in fits if f.cand.linear]
        nonlinear = [f for f in fits if not f.cand.linear and f.delta_bic > 0]
        short = nonlinear[:SHORTLIST]
        refined = [search.refine(f) for f in short]
        # Every other kind at its best location joins with its screening fit, so that the
        # out-of-sample judgement (`policy.judged`) sees it however many kinds rank above it
        # in sample.
        pool = sorted(refined + other_kinds(nonlinear, SHORTLIST)
                      + [f for f in fits if f.cand.linear], key=lambda f: -f.delta_bic)
        lead = next((i for i, f in enumerate(refined) if f is pool[0]), None) if pool else None
        if lead is not None and pool[0].delta_bic > BIC_MIN:
            # Final estimate of the leading candidate, debiased for sensor noise when needed.
            final = search.refine(short[lead], noise="auto")
            pool[0] = final if final is not short[lead] else pool[0]
        return search, pool

    def held_levels(self) -> list[LevelFRF]:
        if self.segment:
            return []
        return [_level(self.model, p, self.band, self.nps, self.floor)
                for p, h in zip(self.preps, self.held) if h]

    def evidence(self, first: SearchPass, common: Evidence) -> Evidence:
        return replace(common, band_hz=self.band, nperseg=self.nps,
                       replay_horizon_samples=self.horizon, response_delay=self.delay,
                       locations=location_table(first.search, first.pool),
                       residual_share_by_dof=tuple(_share(first.search)))

    def start_replays(self, tick: Tick) -> list[Replay | None]:
        """Replays of the starting model (None, with a warning, where its simulation
        fails)."""
        out: list[Replay | None] = []
        for p in self.preps:
            tick(f"replay of {p.label}")
            try:
                out.append(_replay(self.model, p, self.horizon, self.band))
            except PlantError as exc:
                self.warnings.append(f"the starting model's replay of {p.label} fails ({exc}): "
                                     "no time residual for it")
                out.append(None)
        return out

    def corrected_replays(self, fixed: Model, tick: Tick) -> list[Replay]:
        out = []
        for p in self.preps:
            tick(f"replay of {p.label} (corrected model)")
            out.append(_replay(fixed, p, self.horizon, self.band))
        return out


def _replay(model: Model, p: Prepared, horizon: int, band: tuple[float, float]) -> Replay:
    """Steady-state replay of a periodic record, short-horizon replays of a random one."""
    if p.period is not None:
        hp, lp = prepared_band(p, band)
        return steady_replay(model, p, hp, lp)
    return replay(model, p, horizon)


def _share(search: RandomSearch) -> list[float]:
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


def _misfit(model: Model, p: Prepared, band, nps: int, floor: float) -> tuple[float, Floor]:
    """``model``'s misfit at one prepared level and the level's floor."""
    lf, h = _predicted(model, p, band, nps, floor)
    return weighted_error(lf, h), level_floor(lf, floor)


def _ratio(model: Model, p: Prepared, band, nps: int, floor: float
           ) -> tuple[np.ndarray, np.ndarray, float]:
    """One level's measured FRF over ``model``'s, its lines and their correlation."""
    lf, h = _predicted(model, p, band, nps, floor)
    return lf.freqs, lf.H / h, lf.bin_factor


def _curves(start: Model, fixed: Model, p: Prepared, band, nps: int, floor: float,
            held: bool) -> LevelCurves:
    """FRFs of one level before/after (the replays are added by `engine.correct`)."""
    lf, h_before = _predicted(start, p, band, nps, floor)
    _, h_after = _predicted(fixed, p, band, nps, floor) if fixed is not start else (lf, h_before)
    return LevelCurves(p.label, p.level, held, lf.freqs, lf.H, h_before, h_after,
                       weighted_error(lf, h_before), weighted_error(lf, h_after), lf.weight)
