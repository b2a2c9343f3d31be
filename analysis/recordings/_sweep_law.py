"""The law of a swept sine and what a recording says about its sweep (contracts section 5).

`SweepLaw` is the sweep as generated (``sweep_start_hz``, ``sweep_stop_hz``, ``sweep_law``,
``sweep_rate``); `Sweep` is what a swept-sine `Recording` carries: the law, whether it was
estimated from the force (an export that names no sweep parameters) and how many samples were
trimmed from the record's ends to keep only the sweep.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RecordingError

SWEEP_LAWS = ("linear", "log")
#: the recording keys of a sweep, in `Sweep.keys` order
SWEEP_KEYS = ("sweep_start_hz", "sweep_stop_hz", "sweep_law", "sweep_rate", "sweep_estimated",
              "sweep_trimmed_lead", "sweep_trimmed_tail")
LAW_KEYS = SWEEP_KEYS[:4]


@dataclass(frozen=True)
class SweepLaw:
    """A linear or logarithmic sweep.

    Attributes
    ----------
    start_hz, stop_hz : float
        First and last frequency; ``stop < start`` is a down-sweep.
    law : {"linear", "log"}
    rate : float
        Hz/s for a linear sweep, octaves per minute for a logarithmic one (positive).
    """

    start_hz: float
    stop_hz: float
    law: str = "log"
    rate: float = 1.0

    def __post_init__(self) -> None:
        if self.law not in SWEEP_LAWS:
            raise RecordingError(f"sweep_law '{self.law}' is not one of {', '.join(SWEEP_LAWS)}")
        values = (self.start_hz, self.stop_hz, self.rate)
        if not all(np.isfinite(v) and v > 0 for v in values) or self.start_hz == self.stop_hz:
            raise RecordingError("a sweep needs two different positive frequencies and a "
                                 "positive sweep_rate (Hz/s linear, octaves/min log)")

    @property
    def direction(self) -> int:
        """+1 for an up-sweep, -1 for a down-sweep."""
        return 1 if self.stop_hz > self.start_hz else -1

    @property
    def duration(self) -> float:
        """Seconds from start to stop."""
        if self.law == "linear":
            return abs(self.stop_hz - self.start_hz) / self.rate
        return abs(np.log2(self.stop_hz / self.start_hz)) / (self.rate / 60.0)

    def _beta(self) -> float:
        """Signed log rate, 1/s (``f = f0 exp(beta t)``)."""
        return self.direction * self.rate / 60.0 * np.log(2.0)

    def frequency(self, t: np.ndarray | float) -> np.ndarray:
        """Instantaneous frequency at time ``t`` (s from the start), Hz."""
        t = np.asarray(t, dtype=float)
        if self.law == "linear":
            return self.start_hz + self.direction * self.rate * t
        return self.start_hz * np.exp(self._beta() * t)

    def time(self, freq: np.ndarray | float) -> np.ndarray:
        """Time at which the sweep passes ``freq``, s."""
        f = np.asarray(freq, dtype=float)
        if self.law == "linear":
            return (f - self.start_hz) / (self.direction * self.rate)
        return np.log(f / self.start_hz) / self._beta()

    def phase(self, t: np.ndarray | float) -> np.ndarray:
        """Phase ``θ(t) = 2π ∫ f dt``, rad, zero at the start."""
        t = np.asarray(t, dtype=float)
        if self.law == "linear":
            return 2 * np.pi * (self.start_hz * t + 0.5 * self.direction * self.rate * t * t)
        b = self._beta()
        return 2 * np.pi * self.start_hz * np.expm1(b * t) / b


@dataclass(frozen=True)
class Sweep:
    """The sweep of a swept-sine recording.

    Attributes
    ----------
    law : SweepLaw
        The sweep, starting at the record's first sample.
    estimated : bool
        True when the law was read off the force (the file named no sweep parameters).
    trimmed_lead, trimmed_tail : int
        Samples cut from the start (before the sweep) and from the end (trailing zeros) of
        the source record when the law was estimated.
    """

    law: SweepLaw
    estimated: bool = False
    trimmed_lead: int = 0
    trimmed_tail: int = 0

    def keys(self) -> dict[str, np.ndarray]:
        """The recording keys (`SWEEP_KEYS`) of this sweep."""
        lw = self.law
        return {"sweep_start_hz": np.float64(lw.start_hz), "sweep_stop_hz": np.float64(lw.stop_hz),
                "sweep_law": np.str_(lw.law), "sweep_rate": np.float64(lw.rate),
                "sweep_estimated": np.int64(self.estimated),
                "sweep_trimmed_lead": np.int64(self.trimmed_lead),
                "sweep_trimmed_tail": np.int64(self.trimmed_tail)}

    @classmethod
    def from_keys(cls, keys: dict) -> "Sweep":
        """A sweep from its recording keys (all of `LAW_KEYS`; the others default)."""
        missing = [k for k in LAW_KEYS if k not in keys]
        if missing:
            raise RecordingError(f"swept-sine keys {missing} missing; give all of "
                                 f"{', '.join(LAW_KEYS)} or none (then they are estimated)")
        try:
            law = SweepLaw(float(np.asarray(keys["sweep_start_hz"])),
                           float(np.asarray(keys["sweep_stop_hz"])),
                           str(np.asarray(keys["sweep_law"])),
                           float(np.asarray(keys["sweep_rate"])))
            lead, tail = (int(np.asarray(keys.get(k, 0))) for k in SWEEP_KEYS[5:])
        except (TypeError, ValueError) as exc:
            raise RecordingError(f"swept-sine keys: {exc}") from None
        if lead < 0 or tail < 0:
            raise RecordingError("sweep_trimmed_lead and sweep_trimmed_tail must be >= 0")
        return cls(law, bool(np.asarray(keys.get("sweep_estimated", False))), lead, tail)
