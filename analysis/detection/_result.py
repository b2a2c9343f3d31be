"""What `detect` returns: one typed record per test and the verdict, with their JSON.

The JSON is the command's (``nlid-lab detect --json``): the keys of each test, in the order
`KEYS` gives per method, plus ``schema_version`` first. `Detection.from_json` reads it back,
so that ``Detection.from_json(d.to_json()) == d``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from enum import StrEnum
from typing import Any

SCHEMA_VERSION = 1
"""Version of `Detection`'s JSON (``schema_version``)."""


class Verdict(StrEnum):
    """The outcome of `detect`."""

    NONLINEAR = "nonlinear"
    NO_EVIDENCE = "no evidence"


class TestMethod(StrEnum):
    """The tests `detect` runs (docs/detect.md)."""

    __test__ = False                     # not a pytest class

    LEVEL_DEPENDENCE = "level-dependence"
    BLA = "bla"
    STEPPED_LEVEL_DEPENDENCE = "stepped-level-dependence"
    SWEEP_HARMONICS = "sweep-harmonics"
    SWEEP_HYSTERESIS = "sweep-hysteresis"
    SWEEP_LEVEL_DEPENDENCE = "sweep-level-dependence"


_SHARES = ("method", "nonlinear", "share_flagged", "share_limit", "band_hz", "by_output")
KEYS: dict[TestMethod, tuple[str, ...]] = {
    TestMethod.LEVEL_DEPENDENCE: _SHARES + ("levels", "resolution_hz", "median_change_db"),
    TestMethod.BLA: _SHARES + ("levels", "realizations", "periods", "median_change_db"),
    TestMethod.STEPPED_LEVEL_DEPENDENCE: _SHARES + ("levels", "median_change_db"),
    TestMethod.SWEEP_HARMONICS: ("method", "share_flagged", "share_limit", "nonlinear", "tests",
                                 "band_hz", "levels", "direction", "by_output"),
    TestMethod.SWEEP_HYSTERESIS: ("method", "nonlinear", "separation_hz", "allowed_hz", "jumps",
                                  "band_hz", "levels", "directions", "by_output"),
    TestMethod.SWEEP_LEVEL_DEPENDENCE: _SHARES + ("levels", "direction", "median_change_db"),
}
"""The JSON keys of each test method, in the order the command writes them."""


@dataclass(frozen=True)
class SweepJump:
    """Where one sweep direction jumps (`analysis.detection._detect_sweep.hysteresis`).

    Attributes
    ----------
    freq_hz : float
        Midpoint of the largest change of the tracked ``|H|``.
    ratio : float
        ``|H|`` after over before it.
    jump : bool
        Steeper than a linear mode of the measured bandwidth allows.
    delay_hz, spacing_hz : float
        The linear mode's sweep delay and the point spacing there.
    """

    freq_hz: float
    ratio: float
    jump: bool
    delay_hz: float
    spacing_hz: float

    def to_json(self) -> dict[str, Any]:
        """``{"freq_hz": ..., "ratio": ..., "jump": ..., "delay_hz": ..., "spacing_hz": ...}``."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class Jumps:
    """The jumps of an up/down sweep pair."""

    up: SweepJump
    down: SweepJump


@dataclass(frozen=True)
class DetectionTest:
    """One test of `detect` (docs/detect.md): which fields a method fills is `KEYS`.

    Attributes
    ----------
    method : TestMethod
    nonlinear : bool
    share_flagged, share_limit : float
        Share of the lines (tests) beyond the noise and the share chance allows.
    band_hz : (lo, hi) or None
        Where lines were flagged (a nonlinear test) or None.
    by_output : tuple of float or None
        Share flagged per response channel.
    levels : tuple of (float or None)
        The levels compared (one for a single-level test).
    resolution_hz, median_change_db, realizations, periods, direction, tests, separation_hz,
    allowed_hz, jumps, directions
        Per method (`KEYS`), None where the method has none.
    labels : tuple of str
        The levels as people read them (``12.4 N rms`` where a file named none); for the
        summary only, not in the JSON (``levels`` holds the nominal values, null for none).
    """

    __test__ = False                     # not a pytest class

    method: TestMethod
    nonlinear: bool
    share_flagged: float | None = None
    share_limit: float | None = None
    band_hz: tuple[float, float] | None = None
    by_output: tuple[float, ...] | None = None
    levels: tuple[float | None, ...] = ()
    resolution_hz: float | None = None
    median_change_db: tuple[float, ...] | None = None
    realizations: int | None = None
    periods: int | None = None
    direction: str | None = None
    tests: int | None = None
    separation_hz: float | None = None
    allowed_hz: float | None = None
    jumps: Jumps | None = None
    directions: tuple[str, ...] | None = None
    labels: tuple[str, ...] = field(default=(), compare=False)

    def with_(self, **changes: Any) -> DetectionTest:
        """A copy with ``changes`` (sequences as tuples)."""
        return replace(self, **{k: _frozen(v) for k, v in changes.items()})

    def to_json(self) -> dict[str, Any]:
        """The test's entry of the command's ``tests`` list (`KEYS` order)."""
        out = {}
        for key in KEYS[self.method]:
            value = getattr(self, key)
            if key == "jumps":
                value = {"up": value.up.to_json(), "down": value.down.to_json()}
            elif isinstance(value, tuple):
                value = list(value)
            out[key] = str(value) if key == "method" else value
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> DetectionTest:
        """Inverse of `to_json`."""
        method = TestMethod(data["method"])
        kw = {k: _frozen(data[k]) for k in KEYS[method] if k != "method"}
        if kw.get("jumps") is not None:
            kw["jumps"] = Jumps(SweepJump(**data["jumps"]["up"]),
                                SweepJump(**data["jumps"]["down"]))
        return cls(method=method, **kw)


@dataclass(frozen=True)
class Detection:
    """Result of `analysis.detection.detect`.

    Attributes
    ----------
    verdict : Verdict
        ``nonlinear`` when any test is.
    tests : tuple of DetectionTest
    notes : tuple of str
        What could not be tested, and what was left out (interference lines).
    """

    tests: tuple[DetectionTest, ...]
    notes: tuple[str, ...] = field(default=())

    @property
    def verdict(self) -> Verdict:
        """``nonlinear`` when any test is, else ``no evidence``."""
        return Verdict.NONLINEAR if any(t.nonlinear for t in self.tests) \
            else Verdict.NO_EVIDENCE

    def to_json(self) -> dict[str, Any]:
        """``{"schema_version", "verdict", "tests", "notes"}`` (docs/detect.md)."""
        return {"schema_version": SCHEMA_VERSION, "verdict": str(self.verdict),
                "tests": [t.to_json() for t in self.tests], "notes": list(self.notes)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Detection:
        """Inverse of `to_json`; refuses another schema version."""
        got = data.get("schema_version")
        if got != SCHEMA_VERSION:
            raise ValueError(f"detect JSON of schema_version {got}, this version reads "
                             f"{SCHEMA_VERSION}; re-run the command to write it again")
        return cls(tuple(DetectionTest.from_json(t) for t in data["tests"]),
                   tuple(data["notes"]))


def _frozen(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_frozen(v) for v in value)
    return value
