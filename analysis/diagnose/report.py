"""The diagnosis result, its JSON (contracts section 4) and the explanation paragraph."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..model import Model
from .candidates import Candidate
from .replay import Replay

METRIC = ("coherence-weighted relative FRF error (rms over the analysis band) on the "
          "held-back recording")
TIME_METRIC = ("relative rms of the displacement residual of short-horizon replays of the "
               "measured force (restarted from the measured state), mean over DOFs, on the "
               "held-back recording")


@dataclass
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

    def frequency_residual(self, model: np.ndarray) -> list[float]:
        """Relative (coherence-weighted) FRF error per response DOF."""
        g = np.ones(self.measured.shape) if self.coh is None else self.coh
        num = np.sum(g * np.abs(self.measured - model) ** 2, axis=(0, 2))
        den = np.sum(g * np.abs(self.measured) ** 2, axis=(0, 2))
        return [float(v) for v in np.sqrt(num / np.maximum(den, 1e-300))]

    def residuals(self) -> dict[str, Any]:
        """Time and frequency residuals per DOF, before and after the correction."""
        out: dict[str, Any] = {"label": self.label, "level": self.level,
                               "held_back": self.held_back,
                               "frequency": {"before": self.frequency_residual(self.before),
                                             "after": self.frequency_residual(self.after)}}
        if self.replay_before is not None and self.replay_after is not None:
            out["time"] = {"before": self.replay_before.residual.tolist(),
                           "after": self.replay_after.residual.tolist()}
        return out


@dataclass
class Diagnosis:
    """Outcome of `analysis.diagnose.diagnose`.

    Attributes
    ----------
    verdict : {"adequate", "discrepancy"}
    level_dependent : bool or None
        Whether the measured FRFs change with level beyond their random error.
    chosen : list of dict
        The accepted candidates as JSON (kind, w, dofs, params, ci95, evidence), in the
        order the search passes found them (empty when adequate).
    ranking : list of dict
        Best candidates with their evidence, best first.
    location : dict
        ``dofs`` and ``band_hz``.
    fit : dict
        ``metric``, ``before``, ``after`` on the held-back recording, and
        ``time_residual`` (the replay residual before/after, `TIME_METRIC`).
    model : Model
        The corrected model (the starting one when adequate).
    curves : list of LevelCurves
    """

    verdict: str
    level_dependent: bool | None
    chosen: list[dict[str, Any]]
    ranking: list[dict[str, Any]]
    location: dict[str, Any]
    fit: dict[str, Any]
    model: Model
    curves: list[LevelCurves] = field(default_factory=list)
    evidence: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    explanation: str = ""

    def missing_physics(self) -> list[dict[str, Any]]:
        return [{"kind": c["kind"], "w": c["w"], "dofs": c["dofs"], "params": c["params"],
                 "ci95": c.get("ci95", {})} for c in self.chosen]

    def to_json(self) -> dict[str, Any]:
        """Contracts section 4 dictionary (plus ranking, evidence and per-level errors)."""
        return {
            "verdict": self.verdict,
            "level_dependent": self.level_dependent,
            "location": self.location,
            "missing_physics": self.missing_physics(),
            "fit": self.fit,
            "explanation": self.explanation,
            "ranking": self.ranking,
            "evidence": self.evidence,
            "levels": [{"label": c.label, "level": c.level, "held_back": c.held_back,
                        "error_before": c.error_before, "error_after": c.error_after}
                       for c in self.curves],
            "residuals": [c.residuals() for c in self.curves],
            "warnings": self.warnings,
        }


def time_fit(held: list[LevelCurves]) -> dict[str, Any] | None:
    """Mean replay residual (over DOFs and held-back recordings) before and after."""
    reps = [(c.replay_before, c.replay_after) for c in held
            if c.replay_before is not None and c.replay_after is not None]
    if not reps:
        return None
    return {"metric": TIME_METRIC,
            "before": float(np.mean([b.residual.mean() for b, _ in reps])),
            "after": float(np.mean([a.residual.mean() for _, a in reps]))}


def _fmt(params: dict[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in params.items())


UNCONFIRMED = 0.5   # held-back error kept above this fraction: the found physics is tentative


def explain(d: Diagnosis, cands: list[Candidate]) -> str:
    """One paragraph a test engineer can act on.

    When the corrected model does not at least halve the held-back error, a warning is added to
    ``d.warnings`` and the paragraph says the finding is tentative.
    """
    fit = d.fit
    if d.verdict != "adequate" and fit["after"] > UNCONFIRMED * fit["before"]:
        d.warnings.append(
            f"the held-back recording does not confirm the finding (error {fit['before']:.3g} "
            f"-> {fit['after']:.3g}): the fitting levels cannot tell the candidates apart")
        return (_explain(d, cands) + " The held-back recording does not confirm this, so treat "
                "it as tentative: record more levels spanning the nonlinearity (the held-back "
                "level should exercise it) and diagnose again.")
    return _explain(d, cands)


def _explain(d: Diagnosis, cands: list[Candidate]) -> str:
    band = d.location.get("band_hz")
    lvl = ("The measured FRFs change with excitation level beyond their random error, so the "
           "structure is nonlinear. " if d.level_dependent else
           "The measured FRFs do not change with level beyond their random error. "
           if d.level_dependent is False else "")
    fit = d.fit
    if d.verdict == "adequate":
        return (lvl + "No candidate in the library (nonlinear stiffness, damping and friction "
                "elements and linear mass, stiffness and damping errors at every DOF and DOF "
                "pair) improves the fit significantly: the model is adequate for these "
                f"recordings (held-back FRF error {fit['before']:.3g}).")
    what = " and ".join(dict.fromkeys("a linear model error" if c.linear else
                                      "missing nonlinear physics" for c in cands))
    band_txt = f" between {band[0]:.3g} and {band[1]:.3g} Hz" if band else ""
    found = "; ".join(f"{c.kind.replace('_', ' ')} {c.where} ({_fmt(ch['params'])})"
                      for c, ch in zip(cands, d.chosen))
    runner = ""
    if len(d.ranking) > 1:
        r = d.ranking[1]
        runner = (f" The next-best explanation ({r['kind']} at DOFs {r['dofs']}) gains "
                  f"{r['delta_bic']:.3g} BIC points against {d.ranking[0]['delta_bic']:.3g}.")
    second = (" A second search on the corrected model found the further effect."
              if len(cands) > 1 else "")
    tres = fit.get("time_residual")
    time_txt = (f" (short-horizon time residual from {tres['before']:.3g} to "
                f"{tres['after']:.3g})" if tres else "")
    where = " and ".join(dict.fromkeys(c.where for c in cands))
    return (lvl + f"The mismatch is {what}{band_txt}: {found}.{runner}{second} Adding it "
            f"reduces the held-back FRF error from {fit['before']:.3g} to {fit['after']:.3g}"
            f"{time_txt}. Check the structure {where} (joint, support or added mass) and keep "
            "the corrected model file for further simulation.")
