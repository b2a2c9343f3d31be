"""Fault injection shared by the emulators (deterministic: counts frames, seeded bytes)."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from ..faults import FaultSpec


@dataclass
class FaultPlan(FaultSpec):
    """A `FaultSpec` being run: garbage-byte generator and the time of the first fault."""

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self.fault_at: float | None = None   # monotonic time of the first stall/disconnect

    @classmethod
    def of(cls, spec: FaultSpec | None) -> "FaultPlan":
        """The plan running ``spec``: a plan as it is, a spec as a fresh plan, none: no faults."""
        if isinstance(spec, FaultPlan):
            return spec
        return cls(**asdict(spec)) if spec is not None else cls()

    @staticmethod
    def _hit(every: int, k: int) -> bool:
        return every > 0 and k > 0 and k % every == 0

    def garbage(self, k: int) -> bytes:
        """Garbage bytes to send before frame ``k`` (empty if none)."""
        if self._hit(self.garbage_every, k):
            return self.rng.integers(0, 256, self.garbage_bytes, dtype=np.uint8).tobytes()
        return b""

    def drop(self, k: int) -> bool:
        """Whether frame ``k`` is dropped."""
        return self._hit(self.drop_every, k)

    def duplicate(self, k: int) -> bool:
        """Whether frame ``k`` is sent twice."""
        return self._hit(self.duplicate_every, k)

    def corrupt(self, k: int) -> bool:
        """Whether frame ``k`` is sent with a bad checksum."""
        return self._hit(self.corrupt_every, k)

    def stalled(self, k: int) -> float:
        """Seconds to stall before frame ``k`` (0 if none)."""
        if self.stall_at and k == self.stall_at:
            self.mark()
            return self.stall_seconds
        return 0.0

    def disconnect(self, k: int) -> bool:
        """Whether the device disconnects at frame ``k`` (marks the fault time)."""
        if self.disconnect_at and k == self.disconnect_at:
            self.mark()
            return True
        return False

    def mark(self) -> None:
        """Record the time of the first fault (``fault_at``)."""
        if self.fault_at is None:
            self.fault_at = time.monotonic()
