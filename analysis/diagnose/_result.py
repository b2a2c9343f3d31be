"""The diagnosis result as frozen dataclasses, and its JSON (contracts sections 4, 5, 7).

`Diagnosis` is what `analysis.diagnose.diagnose` returns; its parts are typed fields, not
dictionary keys. ``Diagnosis.to_json()`` is the one way to the command's JSON (it carries
`SCHEMA_VERSION`) and ``Diagnosis.from_json()`` reads it back, including the layouts stored
before the version existed (docs/diagnose.md, "Result"). Fields that only one flow fills
(random data: ``band_hz``, ``nperseg``, ...; stepped sine: ``odd_harmonic_ratio``) are None
elsewhere and left out of the JSON.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any, Mapping

from ..models import Model
from ._leakage import Floor
from ._evidence import Evidence
from ._json_fields import Json, as_list, opt, pair
from ._locate import LevelDependence

if TYPE_CHECKING:
    from ._report import LevelCurves

SCHEMA_VERSION = 1
"""Version of the diagnosis JSON; results stored without one are read as the earlier
layouts (contracts section 4 alone, or per-level errors at the top level only)."""

RESULT_NAME = "diagnose"
"""Name under which a run stores its diagnosis (``nlid-lab diagnose --store``), where
``nlid-lab report`` finds it."""

class Verdict(StrEnum):
    """What the diagnosis concludes."""

    ADEQUATE = "adequate"
    DISCREPANCY = "discrepancy"
    UNEXPLAINED = "unexplained"


TIE_EVIDENCE = ("oos_gain", "oos_sd", "oos_reference", "oos_left")
"""Evidence a ``missing_physics`` entry with kind alternatives carries: its side of the tie."""


@dataclass(frozen=True)
class KindSeparation:
    """What would separate two tied kinds (`.separate.separation`): both fitted laws'
    equivalent stiffness at the highest fitting level's deformation scaled, and the distance
    of the FRFs they make there (`chi2` of that level's noise) against the tie's threshold
    (`.outofsample.tie_threshold`).

    Attributes
    ----------
    level : float
        The highest fitting level.
    threshold : float
        The tie's threshold (``chi2``): the gain difference within which the two tie.
    difference : float
        The two FRFs' distance at that level itself (``chi2``).
    at : float
        The scale of the level's deformation at which both are always given (1.5).
    difference_at : float
        The two FRFs' distance there.
    stiffness_at : (float, float)
        The named kind's and the alternative's equivalent stiffness there (N/m).
    separating : float or None
        The smallest scale (up to 4) at which the FRFs differ by more than the threshold: a level
        of about ``separating * level`` separates them; None: not within 4x.
    """

    level: float
    threshold: float
    difference: float
    at: float
    difference_at: float
    stiffness_at: tuple[float, float]
    separating: float | None

    def to_json(self) -> Json:
        return {"level": self.level, "threshold": self.threshold,
                "difference": self.difference,
                "at": self.at, "difference_at": self.difference_at,
                "stiffness_at": list(self.stiffness_at), "separating": self.separating}

    @classmethod
    def from_json(cls, data: Json) -> KindSeparation:
        return cls(data["level"], data["threshold"], data["difference"], data["at"],
                   data["difference_at"], pair(data["stiffness_at"]), data.get("separating"))


@dataclass(frozen=True)
class KindAlternative:
    """Another kind the data cannot tell from a found effect's (`.policy.kind_ties`): its
    location, its out-of-sample gain and deviation, and its BIC on the fitting levels
    (misfit plus ``ln N`` per parameter; the lowest of the tied is the one named); its
    parameters and their 95 % intervals as scored, what its gain was judged against
    (``oos_reference``, ``oos_left``: `.outofsample.Score`) and what would separate it from
    the named kind (None where not computed)."""

    kind: str
    dofs: tuple[int, ...]
    points: tuple[str, ...] | None
    oos_gain: float
    oos_sd: float
    bic: float
    params: Mapping[str, float] = field(default_factory=dict)
    ci95: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    oos_reference: float = 1.0
    oos_left: float = 0.0
    separation: KindSeparation | None = None

    def to_json(self) -> Json:
        out = {"kind": self.kind, "dofs": list(self.dofs), "points": as_list(self.points),
               "oos_gain": self.oos_gain, "oos_sd": self.oos_sd, "bic": self.bic,
               "params": dict(self.params), "ci95": {k: list(v) for k, v in self.ci95.items()},
               "oos_reference": self.oos_reference, "oos_left": self.oos_left}
        if self.separation is not None:
            out["separation"] = self.separation.to_json()
        return out

    @classmethod
    def from_json(cls, data: Json) -> KindAlternative:
        points, sep = data.get("points"), data.get("separation")
        return cls(data["kind"], tuple(data["dofs"]), None if points is None else tuple(points),
                   data["oos_gain"], data["oos_sd"], data["bic"], dict(data.get("params") or {}),
                   {k: pair(v) for k, v in (data.get("ci95") or {}).items()},
                   data.get("oos_reference", 1.0), data.get("oos_left", 0.0),
                   None if sep is None else KindSeparation.from_json(sep))


@dataclass(frozen=True)
class CandidateFit:
    """One fitted candidate: a chosen element (or linear error) or a ranking row.

    ``chi2``, ``delta_bic`` and ``evidence`` (what its estimator reports: ``estimator`` and
    that estimator's own numbers) are None / empty for a chosen one read back from JSON,
    which keeps only its physics (``missing_physics``).
    """

    kind: str
    w: tuple[float, ...]
    dofs: tuple[int, ...]
    points: tuple[str, ...] | None
    params: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    chi2: float | None = None
    delta_bic: float | None = None
    evidence: Mapping[str, Any] = field(default_factory=dict)
    stuck_stiffness_from_linear_part: bool = False
    alternatives: tuple[KindAlternative, ...] = ()
    """Kinds whose out-of-sample gains are within their uncertainty of this one's (a chosen
    effect only; written only when there are some)."""

    def to_json(self) -> Json:
        """A ranking row."""
        out = {"kind": self.kind, "w": list(self.w), "dofs": list(self.dofs),
               "points": as_list(self.points), "params": dict(self.params),
               "ci95": {k: list(v) for k, v in self.ci95.items()}, "chi2": self.chi2,
               "delta_bic": self.delta_bic, "evidence": dict(self.evidence)}
        if self.stuck_stiffness_from_linear_part:
            out["stuck_stiffness_from_linear_part"] = True
        return out

    def physics_json(self) -> Json:
        """A ``missing_physics`` entry (contracts section 4)."""
        out = {"kind": self.kind, "w": list(self.w), "dofs": list(self.dofs),
               "params": dict(self.params), "ci95": {k: list(v) for k, v in self.ci95.items()}}
        if self.points is not None:
            out["points"] = list(self.points)
        if self.stuck_stiffness_from_linear_part:
            # the corrected model's linear part lost the slider's stuck stiffness
            out["stuck_stiffness_from_linear_part"] = True
        if self.alternatives:
            out["alternatives"] = [a.to_json() for a in self.alternatives]
            # the numbers the tie was judged on (`.outofsample.tied`): this kind's side
            out["evidence"] = {k: self.evidence[k] for k in TIE_EVIDENCE if k in self.evidence}
        return out

    @classmethod
    def from_json(cls, data: Json) -> CandidateFit:
        """From a ranking row or a ``missing_physics`` entry."""
        points, w = data.get("points"), tuple(data["w"])
        dofs = data.get("dofs", [i for i, v in enumerate(w) if v])   # contracts 4: w alone
        return cls(data["kind"], w, tuple(dofs),
                   None if points is None else tuple(points), dict(data["params"]),
                   {k: pair(v) for k, v in (data.get("ci95") or {}).items()},
                   data.get("chi2"), data.get("delta_bic"), dict(data.get("evidence") or {}),
                   bool(data.get("stuck_stiffness_from_linear_part", False)),
                   tuple(KindAlternative.from_json(a) for a in data.get("alternatives") or ()))


@dataclass(frozen=True)
class Alternative:
    """A location the data cannot tell apart from the chosen one (contracts section 7): its
    best candidate's kind and BIC gain, why it is not separable, the measurement that would
    separate it and, when a pair links the two, the relative motion across that pair."""

    points: tuple[str, ...]
    w: tuple[float, ...]
    kind: str
    delta_bic: float
    why_not_separable: str
    separate_by: str = ""
    relative_motion: float | None = None

    def to_json(self) -> Json:
        out: Json = {"points": list(self.points), "w": list(self.w), "kind": self.kind,
                     "delta_bic": self.delta_bic, "why_not_separable": self.why_not_separable}
        if self.separate_by:
            out["separate_by"] = self.separate_by
        if self.relative_motion is not None:
            out["relative_motion"] = self.relative_motion
        return out

    @classmethod
    def from_json(cls, data: Json) -> Alternative:
        return cls(tuple(data["points"]), tuple(data["w"]), data["kind"], data["delta_bic"],
                   data["why_not_separable"], data.get("separate_by", ""),
                   data.get("relative_motion"))


@dataclass(frozen=True)
class Location:
    """Where the mismatch is: DOFs, their point names and the band (None when nothing was
    found); ``alternatives`` are written only when there are some."""

    dofs: tuple[int, ...]
    points: tuple[str, ...] | None
    band_hz: tuple[float, float] | None
    alternatives: tuple[Alternative, ...] = ()

    def to_json(self) -> Json:
        out: Json = {"dofs": list(self.dofs)}
        if self.points is not None:
            out["points"] = list(self.points)
        out["band_hz"] = as_list(self.band_hz)
        if self.alternatives:
            out["alternatives"] = [a.to_json() for a in self.alternatives]
        return out

    @classmethod
    def from_json(cls, data: Json) -> Location:
        points = data.get("points")
        return cls(tuple(data.get("dofs") or ()), None if points is None else tuple(points),
                   pair(data.get("band_hz")),
                   tuple(Alternative.from_json(a) for a in data.get("alternatives") or ()))


@dataclass(frozen=True)
class LevelError:
    """FRF error of one level before and after the correction, with its floor."""

    label: str | None
    level: float | None
    held_back: bool
    before: float
    after: float
    floor: Floor | None = None

    @property
    def within_floor(self) -> bool | None:
        """Whether the error after the correction is within the floor (None without one)."""
        return None if self.floor is None else bool(self.after <= self.floor.limit)

    def to_json(self) -> Json:
        out: Json = {"label": self.label, "level": self.level, "held_back": self.held_back,
                     "before": self.before, "after": self.after}
        if self.floor is not None:
            out.update(floor=self.floor.limit, floor_parts=self.floor.to_json(),
                       within_floor_before=bool(self.before <= self.floor.limit),
                       within_floor=bool(self.after <= self.floor.limit))
        return out

    @classmethod
    def from_json(cls, data: Json) -> LevelError:
        """Also the earlier top-level rows (``error_before`` / ``error_after``)."""
        parts = data.get("floor_parts")
        if parts is None and data.get("floor") is not None:
            parts = {"noise": None, "precision": None, "limit": data["floor"]}
        return cls(data.get("label"), data.get("level"), bool(data.get("held_back")),
                   data.get("before", data.get("error_before")),
                   data.get("after", data.get("error_after")), opt(Floor, parts))


@dataclass(frozen=True)
class TimeResidual:
    """Mean replay residual on the held-back recordings before and after."""

    metric: str
    before: float
    after: float

    def to_json(self) -> Json:
        return {"metric": self.metric, "before": self.before, "after": self.after}

    @classmethod
    def from_json(cls, data: Json) -> TimeResidual:
        return cls(data["metric"], data["before"], data["after"])


@dataclass(frozen=True)
class FitSummary:
    """The held-back fit (contracts sections 4 and 5): ``before`` and ``after`` on the
    held-back recordings in ``metric``, the replay residual and every level's errors."""

    metric: str
    before: float | None
    after: float | None
    held_back: tuple[str, ...] = ()
    time_residual: TimeResidual | None = None
    levels: tuple[LevelError, ...] = ()
    floor_method: str | None = None
    within_floor: bool | None = None
    explained: float | None = None

    def to_json(self) -> Json:
        return {"metric": self.metric, "before": self.before, "after": self.after,
                "held_back": list(self.held_back),
                "time_residual": None if self.time_residual is None
                else self.time_residual.to_json(),
                "levels": [lv.to_json() for lv in self.levels],
                "floor_method": self.floor_method, "within_floor": self.within_floor,
                "explained": self.explained}

    @classmethod
    def from_json(cls, data: Json, levels: list[Json] | None = None) -> FitSummary:
        """``levels``: the top-level rows of a result stored before ``fit.levels`` existed."""
        rows = data.get("levels") or levels or []
        return cls(data.get("metric", "misfit"), data.get("before"), data.get("after"),
                   tuple(data.get("held_back") or ()), opt(TimeResidual,
                                                           data.get("time_residual")),
                   tuple(LevelError.from_json(r) for r in rows), data.get("floor_method"),
                   data.get("within_floor"), data.get("explained"))


@dataclass(frozen=True)
class LevelResiduals:
    """Frequency (and, with replays, time) residual per response DOF of one level, before
    and after the correction."""

    label: str
    level: float
    held_back: bool
    frequency_before: tuple[float, ...]
    frequency_after: tuple[float, ...]
    time_before: tuple[float, ...] | None = None
    time_after: tuple[float, ...] | None = None

    def to_json(self) -> Json:
        out: Json = {"label": self.label, "level": self.level, "held_back": self.held_back,
                     "frequency": {"before": list(self.frequency_before),
                                   "after": list(self.frequency_after)}}
        if self.time_before is not None and self.time_after is not None:
            out["time"] = {"before": list(self.time_before), "after": list(self.time_after)}
        return out

    @classmethod
    def from_json(cls, data: Json) -> LevelResiduals:
        time = data.get("time") or {}
        return cls(data["label"], data["level"], data["held_back"],
                   tuple(data["frequency"]["before"]), tuple(data["frequency"]["after"]),
                   _tuple(time.get("before")), _tuple(time.get("after")))


def _tuple(v: Any) -> tuple | None:
    return None if v is None else tuple(v)


@dataclass(frozen=True)
class Diagnosis:
    """Outcome of `analysis.diagnose.diagnose`.

    Attributes
    ----------
    verdict : Verdict
        ``adequate``: every level within its floor (`report.FLOOR_METHOD`) and nothing found;
        ``discrepancy``: a correction found that worsens no level; ``unexplained``: the
        model misfits and nothing in the library explains enough (``evidence.misfit``).
    level_dependent : bool or None
        Whether the measured FRFs change with level beyond their random error.
    location : Location
    chosen : tuple of CandidateFit
        The accepted candidates, in the order the search passes found them (empty when
        adequate); JSON ``missing_physics``.
    fit : FitSummary
    explanation : str
        One paragraph a test engineer can act on.
    ranking : tuple of CandidateFit
        Best candidates of the first search pass with their evidence, best first.
    evidence : Evidence
    residuals : tuple of LevelResiduals
    warnings : tuple of str
    model : Model or None
        The corrected model (the starting one when adequate); None when read from JSON.
    curves : tuple of LevelCurves
        Measured and modelled FRFs per level (for figures); empty when read from JSON.
    """

    verdict: Verdict
    level_dependent: bool | None
    location: Location
    chosen: tuple[CandidateFit, ...]
    fit: FitSummary
    explanation: str = ""
    ranking: tuple[CandidateFit, ...] = ()
    evidence: Evidence = field(default_factory=Evidence)
    residuals: tuple[LevelResiduals, ...] = ()
    warnings: tuple[str, ...] = ()
    model: Model | None = field(default=None, compare=False)
    curves: tuple[LevelCurves, ...] = field(default=(), compare=False)

    def to_json(self) -> Json:
        """The command's JSON (contracts sections 4, 5, 7) with ``schema_version``."""
        return {
            "schema_version": SCHEMA_VERSION,
            "verdict": str(self.verdict),
            "level_dependent": self.level_dependent,
            "location": self.location.to_json(),
            "missing_physics": [c.physics_json() for c in self.chosen],
            "fit": self.fit.to_json(),
            "explanation": self.explanation,
            "ranking": [r.to_json() for r in self.ranking],
            "evidence": self.evidence.to_json(),
            "levels": [dict(lv.to_json(), error_before=lv.before, error_after=lv.after)
                       for lv in self.fit.levels],
            "residuals": [r.to_json() for r in self.residuals],
            "warnings": list(self.warnings),
        }

    @classmethod
    def from_json(cls, data: Json) -> Diagnosis:
        """A stored result: this version, or an earlier layout (no ``schema_version``)."""
        version = data.get("schema_version", 0)
        if version > SCHEMA_VERSION:
            raise ValueError(f"diagnosis schema version {version} is newer than this "
                             f"nlid-lab reads ({SCHEMA_VERSION}); update nlid-lab")
        fit = data.get("fit") or {}
        return cls(Verdict(data["verdict"]), data.get("level_dependent"),
                   Location.from_json(data.get("location") or {}),
                   tuple(CandidateFit.from_json(c) for c in data.get("missing_physics") or ()),
                   FitSummary.from_json(fit, data.get("levels")),
                   data.get("explanation", ""),
                   tuple(CandidateFit.from_json(r) for r in data.get("ranking") or ()),
                   Evidence.from_json(data.get("evidence") or {}),
                   tuple(LevelResiduals.from_json(r) for r in data.get("residuals") or ()),
                   tuple(data.get("warnings") or ()))
