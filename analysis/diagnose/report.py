"""The diagnosis result, its JSON (contracts section 4) and the explanation paragraph."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..model import Model
from .candidates import Candidate

METRIC = ("coherence-weighted relative FRF error (rms over the analysis band) on the "
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


@dataclass
class Diagnosis:
    """Outcome of `analysis.diagnose.diagnose`.

    Attributes
    ----------
    verdict : {"adequate", "discrepancy"}
    level_dependent : bool or None
        Whether the measured FRFs change with level beyond their random error.
    chosen : dict or None
        The selected candidate as JSON (kind, w, dofs, params, ci95, evidence).
    ranking : list of dict
        Best candidates with their evidence, best first.
    location : dict
        ``dofs`` and ``band_hz``.
    fit : dict
        ``metric``, ``before``, ``after`` on the held-back recording.
    model : Model
        The corrected model (the starting one when adequate).
    curves : list of LevelCurves
    """

    verdict: str
    level_dependent: bool | None
    chosen: dict[str, Any] | None
    ranking: list[dict[str, Any]]
    location: dict[str, Any]
    fit: dict[str, Any]
    model: Model
    curves: list[LevelCurves] = field(default_factory=list)
    evidence: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    explanation: str = ""

    def missing_physics(self) -> list[dict[str, Any]]:
        if self.chosen is None:
            return []
        c = self.chosen
        out = {"kind": c["kind"], "w": c["w"], "dofs": c["dofs"], "params": c["params"],
               "ci95": c.get("ci95", {})}
        return [out]

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
            "warnings": self.warnings,
        }


def _fmt(params: dict[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in params.items())


def explain(d: Diagnosis, cand: Candidate | None) -> str:
    """One paragraph a test engineer can act on."""
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
    assert cand is not None and d.chosen is not None
    what = ("a linear model error" if cand.linear else "missing nonlinear physics")
    band_txt = f" between {band[0]:.3g} and {band[1]:.3g} Hz" if band else ""
    runner = ""
    if len(d.ranking) > 1:
        r = d.ranking[1]
        runner = (f" The next-best explanation ({r['kind']} at DOFs {r['dofs']}) gains "
                  f"{r['delta_bic']:.3g} BIC points against {d.chosen['delta_bic']:.3g}.")
    return (lvl + f"The mismatch is {what}{band_txt}: {cand.kind.replace('_', ' ')} "
            f"{cand.where} ({_fmt(d.chosen['params'])}).{runner} Adding it reduces the "
            f"held-back FRF error from {fit['before']:.3g} to {fit['after']:.3g}. Check the "
            f"structure {cand.where} (joint, support or added mass) and keep the corrected "
            "model file for further simulation.")
