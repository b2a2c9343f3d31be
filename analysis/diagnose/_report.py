"""Per-level curves of a diagnosis, its held-back fit, the rejection test and the
explanation paragraph (the result types: `.result`)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from ..models import Candidate
from ._leakage import Floor
from ._outofsample import Z as OOS_Z
from ._replay import Replay
from ._result import (Alternative, CandidateFit, Diagnosis, FitSummary, KindAlternative,
                     LevelError, LevelResiduals, TimeResidual, Verdict)

FLOOR_METHOD = ("a level lies within its floor when its FRF error is at most sqrt(precision^2 + "
                "noise^2 + 3.72 sd): noise = the H1 random error expected from the measured "
                "coherence and number of Welch averages (Bendat & Piersol), or for a one-input "
                "periodic record from the spread of its periods (Pintelon & Schoukens), sd = the standard "
                "deviation of its square (bin correlation included; 3.72 = one-sided p 1e-4), "
                "precision = the 1 % model-precision floor; the model FRF is compared through "
                "the Welch window's leakage kernel (analysis.diagnose.leakage)")
# The text names the method as the command's JSON has always named it (golden outputs stay
# byte for byte); its code is the room's private `_leakage` module.
TIME_METRIC = ("relative rms of the response residual of replays of the measured force "
               "through the model (the steady state of a periodic drive, in the recorded "
               "response kind; short horizons restarted from the measured state otherwise, "
               "in displacement), mean over DOFs, on the held-back recording")


@dataclass(frozen=True, eq=False)
class LevelCurves:
    """Measured and modelled FRFs of one level, for before/after overlays."""

    label: str
    level: float
    held_back: bool
    freqs: np.ndarray
    measured: np.ndarray
    before: np.ndarray
    after: np.ndarray
    error_before: float
    error_after: float
    coh: np.ndarray | None = None
    replay_before: Replay | None = None
    replay_after: Replay | None = None
    floor: Floor | None = None

    def level_error(self) -> LevelError:
        """Error before/after the correction and the level's floor."""
        return LevelError(self.label, self.level, self.held_back, self.error_before,
                          self.error_after, self.floor)

    def frequency_residual(self, model: np.ndarray) -> list[float]:
        """Relative (coherence-weighted) FRF error per response DOF."""
        g = np.ones(self.measured.shape) if self.coh is None else self.coh
        num = np.sum(g * np.abs(self.measured - model) ** 2, axis=(0, 2))
        den = np.sum(g * np.abs(self.measured) ** 2, axis=(0, 2))
        return [float(v) for v in np.sqrt(num / np.maximum(den, 1e-300))]

    def residuals(self) -> LevelResiduals:
        """Time and frequency residuals per DOF, before and after the correction."""
        time = self.replay_before is not None and self.replay_after is not None
        return LevelResiduals(
            self.label, self.level, self.held_back,
            tuple(self.frequency_residual(self.before)),
            tuple(self.frequency_residual(self.after)),
            tuple(self.replay_before.residual.tolist()) if time else None,
            tuple(self.replay_after.residual.tolist()) if time else None)


def fit_summary(metric: str, curves: Sequence[LevelCurves]) -> FitSummary:
    """The held-back fit in ``metric`` (mean over the held-back levels), with every level's
    errors and floor and the explained share of the squared error."""
    held = [c for c in curves if c.held_back]
    b2 = sum(c.error_before**2 for c in curves)
    a2 = sum(c.error_after**2 for c in curves)
    return FitSummary(
        metric, float(np.mean([c.error_before for c in held])),
        float(np.mean([c.error_after for c in held])), tuple(c.label for c in held),
        time_fit(held), tuple(c.level_error() for c in curves), FLOOR_METHOD,
        all(c.floor is None or c.error_after <= c.floor.limit for c in curves),
        float(1 - a2 / b2) if b2 > 0 else 0.0)


def change(before: float, after: float) -> str:
    """``"rises from a to b"`` / ``"falls from a to b"`` / ``"stays at a"``, from the numbers."""
    if f"{before:.3g}" == f"{after:.3g}":
        return f"stays at {before:.3g}"
    return f"{'rises' if after > before else 'falls'} from {before:.3g} to {after:.3g}"


def time_fit(held: Sequence[LevelCurves]) -> TimeResidual | None:
    """Mean replay residual (over DOFs and held-back recordings) before and after."""
    reps = [(c.replay_before, c.replay_after) for c in held
            if c.replay_before is not None and c.replay_after is not None]
    if not reps:
        return None
    return TimeResidual(TIME_METRIC, float(np.mean([b.residual.mean() for b, _ in reps])),
                        float(np.mean([a.residual.mean() for _, a in reps])))


def _fmt(params: Mapping[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in params.items())


UNCONFIRMED = 0.5   # held-back error kept above this fraction: the found physics is tentative


def explain(d: Diagnosis, cands: Sequence[Candidate]) -> Diagnosis:
    """``d`` with its explanation: one paragraph a test engineer can act on, built from the
    numbers (``cands``: the chosen candidates).

    When the corrected model does not at least halve the held-back error, a warning is added to
    ``d.warnings`` and the paragraph says the finding is tentative; so is one when the location
    is ambiguous (``d.location.alternatives``).
    """
    fit = d.fit
    if d.location.alternatives:
        d = replace(d, warnings=d.warnings + (
            "the location is ambiguous between " + " and ".join(
                [", ".join(d.chosen[0].points or map(str, d.chosen[0].dofs))]
                + [", ".join(a.points) for a in d.location.alternatives])
            + ": the data cannot separate them (location.alternatives says why and what "
            "measurement would)",))
    for c in d.chosen:
        if c.alternatives:
            d = replace(d, warnings=d.warnings + (
                f"the kind is ambiguous: {_kinds(c)} explain the data equally (the "
                "missing_physics entry's alternatives hold the numbers and what measurement "
                "would separate them)",))
    if d.verdict == Verdict.DISCREPANCY and fit.after > UNCONFIRMED * fit.before:
        warning = (f"the held-back recording does not confirm the finding (error "
                   f"{change(fit.before, fit.after)}): the fitting levels cannot tell the "
                   "candidates apart")
        return replace(d, warnings=d.warnings + (warning,), explanation=_explain(d, cands)
                       + " The held-back recording does not confirm this, so treat it as "
                       "tentative: record more levels spanning the nonlinearity (the held-back "
                       "level should exercise it) and diagnose again.")
    return replace(d, explanation=_explain(d, cands))


def place(dofs: Sequence[int], points: Sequence[str] | None) -> str:
    """``at joint, payload`` when the points are named, else ``on DOF(s) 1, 2``."""
    if points and list(points) != [str(i) for i in dofs]:
        return f"at {', '.join(points)}"
    return f"on DOF(s) {', '.join(map(str, dofs))}"


def _levels_text(d: Diagnosis, after: bool) -> str:
    parts = []
    for lv in sorted(d.fit.levels, key=lambda lv: lv.level):
        err = (change(lv.before, lv.after) if after else f"{lv.before:.3g}")
        fl = f", floor {lv.floor.limit:.3g}" if lv.floor is not None else ""
        parts.append(f"{lv.label}{' (held back)' if lv.held_back else ''} {err}{fl}")
    return "; ".join(parts)


def _rejected_text(d: Diagnosis) -> str:
    rej = d.evidence.rejected
    if not rej:
        return ""
    return " Rejected: " + "; ".join(f"{r.candidate} ({r.reason})" for r in rej) + "."


def _trend(errors: list[float]) -> str:
    """How the error (ascending levels) changes with level, in words."""
    steps = np.diff(errors)
    if len(errors) < 2 or max(errors) <= 1.5 * min(errors):
        return "is about the same at every level"
    if np.all(steps >= 0):
        return "grows with level"
    if np.all(steps <= 0):
        return "falls with level"
    return "changes from level to level without a monotonic trend"


LIBRARY = ("nonlinear stiffness, damping and friction elements and linear mass, "
           "stiffness and damping errors at every DOF and DOF pair")


def _explain(d: Diagnosis, cands: Sequence[Candidate]) -> str:
    lvl = ("The measured FRFs change with excitation level beyond their random error, so the "
           "structure is nonlinear. " if d.level_dependent else
           "The measured FRFs do not change with level beyond their random error. "
           if d.level_dependent is False else "")
    lvl += _support_text(d)
    if d.verdict == Verdict.ADEQUATE:
        return (lvl + f"Every level lies within its noise and model-precision floor (FRF error "
                f"by level: {_levels_text(d, False)}) and no candidate in the library "
                f"({LIBRARY}) improves the fit significantly: the model is adequate for these "
                f"recordings, up to {_top(d)} (the highest level recorded; what acts only "
                "above it, or below every floor, these recordings cannot show)."
                + _rejected_text(d))
    if d.verdict == Verdict.UNEXPLAINED:
        return lvl + _unexplained(d)
    return lvl + _discrepancy(d, cands)


def _top(d: Diagnosis) -> str:
    """The label of the highest level."""
    return max(d.fit.levels, key=lambda lv: lv.level).label


def _unexplained(d: Diagnosis) -> str:
    m = d.evidence.misfit
    tried = m.tried
    how = _trend([t.error for t in m.level_trend])
    oos = d.ranking[0].evidence if d.ranking else {}
    best = (f" The best candidate ({tried.best}) removes "
            f"{100 * max(tried.best_chi2_reduction, 0.0):.3g} % of the weighted misfit in "
            f"sample; judged out of sample it gains {oos['oos_gain']:.3g} (uncertainty "
            f"{oos['oos_sd']:.3g}), and it needs {OOS_Z:g} times its uncertainty, more "
            "than the misfit it leaves beyond the noise (beyond the start model's own misfit "
            "at the levels within their floor, for a first effect), a parameter "
            "distinguishable from zero and no level predicted worse by the fit on the others."
            if tried.best and "oos_gain" in oos else "")
    return (f"The model misfits beyond the noise and model-precision floor and nothing "
            f"in the library ({tried.candidates} candidates: {LIBRARY}) explains enough: "
            f"the misfit is largest at {m.level} between {m.band_hz[0]:.3g} and "
            f"{m.band_hz[1]:.3g} Hz {place(m.dofs, m.points)}, and it "
            f"{how} (FRF error by level: {_levels_text(d, False)}).{best}"
            + _rejected_text(d) + " The missing physics is outside the library (for "
            "example a frequency-dependent stiffness, an unmodelled mode or DOF, or another "
            "nonlinear law): check the structure there and extend the model by hand.")


def _discrepancy(d: Diagnosis, cands: Sequence[Candidate]) -> str:
    band = d.location.band_hz
    fit = d.fit
    what = " and ".join(dict.fromkeys("a linear model error" if c.linear else
                                      "missing nonlinear physics" for c in cands))
    band_txt = f" between {band[0]:.3g} and {band[1]:.3g} Hz" if band else ""
    found = "; ".join(f"{c.kind.replace('_', ' ')} {c.where} ({_fmt(ch.params)}"
                      + ("; its stuck stiffness moved out of the linear part)"
                         if c.compensated else ")")
                      for c, ch in zip(cands, d.chosen))
    runner = ""
    chosen = d.chosen[0]
    others = [r for r in d.ranking if (r.kind, r.dofs) != (chosen.kind, chosen.dofs)]
    if others:
        r = others[0]
        at = ", ".join(r.points if r.points is not None else map(str, r.dofs))
        runner = (f" The next-best explanation ({r.kind} at {at}) gains "
                  f"{r.delta_bic:.3g} BIC points against {chosen.delta_bic:.3g}.")
    second = (" A second search on the corrected model found the further effect."
              if len(cands) > 1 else "")
    tres = fit.time_residual
    time_txt = (f" (time residual of the replays {change(tres.before, tres.after)})"
                if tres else "")
    rest = ""
    if fit.within_floor is False:
        out = [lv.label for lv in fit.levels if lv.within_floor is False]
        rest = (f" The corrected model still misfits {', '.join(out)} beyond the floor: it "
                f"explains {100 * fit.explained:.3g} % of the squared FRF error, the rest is "
                "unexplained (see evidence.misfit).")
    ties = "".join(_kind_tie(ch) + _encompassed(ch) for ch in d.chosen)
    return (f"The mismatch is {what}{band_txt}: {found}.{_ambiguity(cands[0], d)}{ties}{runner}"
            f"{second} With it the held-back FRF error {change(fit.before, fit.after)}"
            f"{time_txt}; by level: {_levels_text(d, True)}.{rest}" + _rejected_text(d)
            + f" Check {_advice(cands, d.location.alternatives)} and keep the corrected model "
            "file for further simulation.")


def _support_text(d: Diagnosis) -> str:
    """What the model's ``[support]`` did to the search (nothing without one)."""
    sup = d.model.support if d.model is not None else None
    if sup is None:
        return ""
    if sup.free:
        return ("The model is free or suspended ([support] free = true): no element to ground "
                "was searched, only linear errors there (suspension stiffness and damping, "
                "mass). ")
    if not sup.points:
        return ("None of the model's support points is measured ([support]): no element to "
                "ground was searched, only linear errors there. ")
    pts = ", ".join(d.model.points[i] for i in sup.points)
    return (f"The model is supported at {pts} ([support]): elements to ground were searched "
            "only there. ")


def _where_alt(a: Alternative) -> str:
    """An alternative location in words: a support, a joint or the structure there (numbered
    points as ``DOF i``, as `Candidate.where` words them)."""
    pts = [f"DOF {p}" if p.isdigit() else p for p in a.points]
    kind = a.kind.replace("_", " ")
    if a.kind.endswith("_error"):
        at = f"at {pts[0]}" if len(pts) == 1 else f"between {pts[0]} and {pts[1]}"
        return f"the structure {at} ({kind})"
    if len(pts) == 1:
        return f"the support at {pts[0]} ({kind})"
    return f"the joint between {pts[0]} and {pts[1]} ({kind})"


def _ambiguity(c: Candidate, d: Diagnosis) -> str:
    """``ambiguous between ... and ...``: the alternatives the data cannot separate from the
    first effect's location, why, and what would separate them."""
    alts = d.location.alternatives
    if not alts:
        return ""
    whys = "; ".join(f"{_where_alt(a)}: {a.why_not_separable} (BIC +{a.delta_bic:.4g})"
                     for a in alts)
    how = "; ".join(dict.fromkeys(a.separate_by for a in alts if a.separate_by))
    return (f" The location is ambiguous between {_one(c)} and "
            f"{' and '.join(_where_alt(a) for a in alts)}: {whys}."
            + (f" To separate them: {how}." if how else ""))


def _one(c: Candidate) -> str:
    """A found candidate's location in words: a grounded finding is a support (its point to
    ground), a relative one the joint between its points, a linear error the structure there;
    never a grounded finding worded as a joint (contracts section 7)."""
    if c.linear:
        return f"the structure {c.where} (its {c.kind.replace('_error', '')})"
    if len(c.dofs) == 1:
        at = c.points[0] if c.names else f"DOF {c.points[0]}"
        return f"the support at {at} (the element acts from {at} to ground)"
    return f"the joint {c.where}"


def _advice(cands: Sequence[Candidate], alts: Sequence[Alternative] = ()) -> str:
    """What to look at: every found location (`_one`), and the ones the data cannot separate
    from the first (``alts``) as the alternatives they are."""
    found = " and ".join(dict.fromkeys(_one(c) for c in cands))
    if not alts:
        return found
    return f"{found}, or (ambiguous) " + " or ".join(_where_alt(a) for a in alts)


def _kinds(c: CandidateFit) -> str:
    """``cubic spring, quadratic spring and gap``: a found effect's kind and its tied ones."""
    names = [k.replace("_", " ") for k in [c.kind] + [a.kind for a in c.alternatives]]
    return ", ".join(names[:-1]) + " and " + names[-1]


def _kind_tie(c: CandidateFit) -> str:
    """The kinds the data cannot tell apart at one found effect, from the numbers, which is
    named (`.policy.kind_ties`) and what measurement would separate them
    (`.separate.separation`); empty without alternatives."""
    if not c.alternatives:
        return ""
    gains = [a.oos_gain for a in c.alternatives]
    own = c.evidence.get("oos_gain")
    if own is not None:
        gains = [float(own)] + gains
    spread = 100 * (max(gains) - min(gains)) / max(abs(max(gains)), 1e-300)
    seps = [_separate_by(c.kind, a) for a in c.alternatives]
    how = " ".join(t for t in seps if t) or ("A level beyond the fitted ones would separate "
                                             "them.")
    return (f" {_kinds(c).capitalize()} explain the data equally (out-of-sample gains "
            + ", ".join(f"{g:.4g}" for g in gains)
            + f": within {spread:.2g} %, inside their uncertainty): the kind is ambiguous. "
            f"{how} The "
            f"{c.kind.replace('_', ' ')} is named: of the tied kinds, the lowest BIC on the "
            "fitting levels (misfit plus ln N per parameter: at equal fit, the fewest "
            "parameters); the others' parameters are in the missing_physics entry's "
            "alternatives.")


def _encompassed(c: CandidateFit) -> str:
    """The kinds that tied with a found effect's out of sample but that it encompasses
    (`.encompass.encompassing`); empty when none."""
    others = c.evidence.get("encompasses")
    if not others:
        return ""
    kind = c.kind.replace("_", " ")
    names = " and the ".join(k.replace("_", " ") for k in others.split(", "))
    return (f" The {kind} is named over the {names}, whose out-of-sample "
            f"gains tie with its: added to the model holding any of them the {kind} still "
            "wins out of sample, and none of them does added to the model holding the "
            f"{kind} (encompassing test).")


def _separate_by(named: str, a: KindAlternative) -> str:
    """What would separate the named kind from the tied ``a``, from its numbers ("" when
    not computed)."""
    sep = a.separation
    if sep is None:
        return ""
    one, other = named.replace("_", " "), a.kind.replace("_", " ")
    at = (f"At {sep.at:g} x the deformation of the highest fitting level ({sep.level:.3g}) "
          f"the {one} and the {other} predict equivalent stiffnesses "
          f"{sep.stiffness_at[0]:.4g} and {sep.stiffness_at[1]:.4g} N/m, FRFs differing by a "
          f"misfit of {sep.difference_at:.3g} (at the level itself {sep.difference:.3g}) "
          f"against the {sep.threshold:.3g} within which they tie")
    if sep.separating is None:
        return (at + ": up to 4 x that deformation their FRFs stay within it; a level "
                "beyond the fitted ones cannot separate them by the FRF.")
    if sep.separating <= 1.0:
        return (at + ": the models differ at the highest level already, but the data there "
                "cannot tell which is right; a higher level (their difference grows "
                f"{sep.difference_at / max(sep.difference, 1e-300):.2g}x by {sep.at:g} x the "
                "deformation) or a level of another excitation would.")
    return (at + f": a level moving the structure about {sep.separating:.2g} x as far (about "
            f"{sep.separating * sep.level:.3g}, the force scaling roughly with it) would "
            "separate them.")
