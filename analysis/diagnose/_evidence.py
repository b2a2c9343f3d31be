"""The evidence of a diagnosis as frozen dataclasses: rejections, search passes, the location
table, the misfit and the trend of the level dependence (`Evidence`, part of `._result`'s
`Diagnosis`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ._alignment import ResponseDelay
from ._json_fields import Json, opt, pair
from ._locate import LevelDependence


@dataclass(frozen=True)
class Rejection:
    """A candidate turned down, why, and at which stage (None within a pass's own list)."""

    candidate: str
    reason: str
    stage: str | None = None

    def to_json(self) -> Json:
        out = {"candidate": self.candidate, "reason": self.reason}
        if self.stage is not None:
            out["stage"] = self.stage
        return out

    @classmethod
    def from_json(cls, data: Json) -> Rejection:
        return cls(data["candidate"], data["reason"], data.get("stage"))


@dataclass(frozen=True)
class PassSummary:
    """One search pass: its best candidate and the decision."""

    best: str | None
    delta_bic: float | None
    chi2_start: float
    chi2_reduction: float
    model_change: float
    accepted: bool
    rejected: tuple[Rejection, ...] = ()

    def to_json(self) -> Json:
        return {"best": self.best, "delta_bic": self.delta_bic, "chi2_start": self.chi2_start,
                "chi2_reduction": self.chi2_reduction, "model_change": self.model_change,
                "accepted": self.accepted, "rejected": [r.to_json() for r in self.rejected]}

    @classmethod
    def from_json(cls, data: Json) -> PassSummary:
        return cls(data["best"], data["delta_bic"], data["chi2_start"], data["chi2_reduction"],
                   data["model_change"], data["accepted"],
                   tuple(Rejection.from_json(r) for r in data.get("rejected") or ()))


@dataclass(frozen=True)
class GroundedEnd:
    """The best grounded candidate at either end of a pair location."""

    points: tuple[str, ...]
    kind: str
    chi2_reduction: float

    def to_json(self) -> Json:
        return {"points": list(self.points), "kind": self.kind,
                "chi2_reduction": self.chi2_reduction}

    @classmethod
    def from_json(cls, data: Json) -> GroundedEnd:
        return cls(tuple(data["points"]), data["kind"], data["chi2_reduction"])


@dataclass(frozen=True)
class PairThrough:
    """The best joint (pair candidate) through a grounded location's point."""

    points: tuple[str, ...]
    kind: str
    chi2_reduction: float
    delta_bic: float
    relative_motion: float
    """``rms(x_j - x_i) / max(rms x_i, rms x_j)`` across the pair at the top fitting level."""

    def to_json(self) -> Json:
        return {"points": list(self.points), "kind": self.kind,
                "chi2_reduction": self.chi2_reduction, "delta_bic": self.delta_bic,
                "relative_motion": self.relative_motion}

    @classmethod
    def from_json(cls, data: Json) -> PairThrough:
        return cls(tuple(data["points"]), data["kind"], data["chi2_reduction"],
                   data["delta_bic"], data["relative_motion"])


@dataclass(frozen=True)
class LocationRow:
    """A location ranked by its best candidate (first search pass); a pair with the best
    grounded candidate at either end and its relative motion, a point with the best joint
    through it."""

    points: tuple[str, ...]
    dofs: tuple[int, ...]
    kind: str
    chi2_reduction: float
    delta_bic: float
    best_grounded_end: GroundedEnd | None = None
    relative_motion: float | None = None
    best_joint: PairThrough | None = None

    def to_json(self) -> Json:
        out = {"points": list(self.points), "dofs": list(self.dofs), "kind": self.kind,
               "chi2_reduction": self.chi2_reduction, "delta_bic": self.delta_bic}
        if self.best_grounded_end is not None:
            out["best_grounded_end"] = self.best_grounded_end.to_json()
        if self.relative_motion is not None:
            out["relative_motion"] = self.relative_motion
        if self.best_joint is not None:
            out["best_joint"] = self.best_joint.to_json()
        return out

    @classmethod
    def from_json(cls, data: Json) -> LocationRow:
        return cls(tuple(data["points"]), tuple(data["dofs"]), data["kind"],
                   data["chi2_reduction"], data["delta_bic"],
                   opt(GroundedEnd, data.get("best_grounded_end")),
                   data.get("relative_motion"), opt(PairThrough, data.get("best_joint")))


@dataclass(frozen=True)
class TrendPoint:
    """A level's error after the correction and its floor."""

    level: float
    error: float
    floor: float

    def to_json(self) -> Json:
        return {"level": self.level, "error": self.error, "floor": self.floor}

    @classmethod
    def from_json(cls, data: Json) -> TrendPoint:
        return cls(data["level"], data["error"], data["floor"])


@dataclass(frozen=True)
class Tried:
    """What the first search pass tried against what a discrepancy needs."""

    candidates: int
    best: str | None
    best_chi2_reduction: float
    best_delta_bic: float | None
    required_chi2_reduction: float
    required_delta_bic: float
    rejected: tuple[str, ...] = ()

    def to_json(self) -> Json:
        return {"candidates": self.candidates, "best": self.best,
                "best_chi2_reduction": self.best_chi2_reduction,
                "best_delta_bic": self.best_delta_bic,
                "required_chi2_reduction": self.required_chi2_reduction,
                "required_delta_bic": self.required_delta_bic, "rejected": list(self.rejected)}

    @classmethod
    def from_json(cls, data: Json) -> Tried:
        return cls(data["candidates"], data["best"], data["best_chi2_reduction"],
                   data["best_delta_bic"], data["required_chi2_reduction"],
                   data["required_delta_bic"], tuple(data.get("rejected") or ()))


@dataclass(frozen=True)
class Misfit:
    """Where the model still misfits beyond the floor (`policy.misfit_summary`)."""

    level: str
    band_hz: tuple[float, float]
    dofs: tuple[int, ...]
    points: tuple[str, ...]
    error_by_dof: tuple[float, ...]
    level_trend: tuple[TrendPoint, ...]
    tried: Tried

    def to_json(self) -> Json:
        return {"level": self.level, "band_hz": list(self.band_hz), "dofs": list(self.dofs),
                "points": list(self.points), "error_by_dof": list(self.error_by_dof),
                "level_trend": [t.to_json() for t in self.level_trend],
                "tried": self.tried.to_json()}

    @classmethod
    def from_json(cls, data: Json) -> Misfit:
        return cls(data["level"], pair(data["band_hz"]), tuple(data["dofs"]),
                   tuple(data["points"]), tuple(data["error_by_dof"]),
                   tuple(TrendPoint.from_json(t) for t in data["level_trend"]),
                   Tried.from_json(data["tried"]))


@dataclass(frozen=True)
class Evidence:
    """The numbers behind the verdict (first search pass, the passes, rejections, misfit).

    ``band_hz``, ``nperseg``, ``replay_horizon_samples``, ``locations`` and
    ``residual_share_by_dof`` are filled on random data (``response_delay`` there when one
    was taken out, `alignment`), ``odd_harmonic_ratio`` on stepped
    sine; None elsewhere (and then not written).
    """

    chi2_start: float | None = None
    n_values: float | None = None
    chi2_reduction: float | None = None
    band_hz: tuple[float, float] | None = None
    nperseg: int | None = None
    model_change: float | None = None
    replay_horizon_samples: int | None = None
    passes: tuple[PassSummary, ...] = ()
    locations: tuple[LocationRow, ...] | None = None
    pruned_after_joint_refit: tuple[str, ...] = ()
    rejected: tuple[Rejection, ...] = ()
    misfit: Misfit | None = None
    level_dependence: LevelDependence | None = None
    residual_share_by_dof: tuple[float, ...] | None = None
    odd_harmonic_ratio: float | None = None
    response_delay: ResponseDelay | None = None

    def to_json(self) -> Json:
        out: Json = {"chi2_start": self.chi2_start, "n_values": self.n_values,
                     "chi2_reduction": self.chi2_reduction}
        if self.band_hz is not None:
            out["band_hz"] = list(self.band_hz)
        if self.nperseg is not None:
            out["nperseg"] = self.nperseg
        out["model_change"] = self.model_change
        if self.replay_horizon_samples is not None:
            out["replay_horizon_samples"] = self.replay_horizon_samples
        out["passes"] = [p.to_json() for p in self.passes]
        if self.locations is not None:
            out["locations"] = [r.to_json() for r in self.locations]
        out.update(pruned_after_joint_refit=list(self.pruned_after_joint_refit),
                   rejected=[r.to_json() for r in self.rejected],
                   misfit=None if self.misfit is None else self.misfit.to_json(),
                   level_dependence=None if self.level_dependence is None
                   else self.level_dependence.to_json())
        if self.residual_share_by_dof is not None:
            out["residual_share_by_dof"] = list(self.residual_share_by_dof)
        if self.odd_harmonic_ratio is not None:
            out["odd_harmonic_ratio"] = self.odd_harmonic_ratio
        if self.response_delay is not None:
            out["response_delay"] = self.response_delay.to_json()
        return out

    @classmethod
    def from_json(cls, data: Json) -> Evidence:
        locations = data.get("locations")
        share = data.get("residual_share_by_dof")
        return cls(data.get("chi2_start"), data.get("n_values"), data.get("chi2_reduction"),
                   pair(data.get("band_hz")), data.get("nperseg"), data.get("model_change"),
                   data.get("replay_horizon_samples"),
                   tuple(PassSummary.from_json(p) for p in data.get("passes") or ()),
                   None if locations is None
                   else tuple(LocationRow.from_json(r) for r in locations),
                   tuple(data.get("pruned_after_joint_refit") or ()),
                   tuple(Rejection.from_json(r) for r in data.get("rejected") or ()),
                   opt(Misfit, data.get("misfit")),
                   opt(LevelDependence, data.get("level_dependence")),
                   None if share is None else tuple(share), data.get("odd_harmonic_ratio"),
                   opt(ResponseDelay, data.get("response_delay")))
