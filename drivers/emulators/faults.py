"""Fault injection plan shared by the emulators (deterministic: counts frames, seeded bytes)."""

from __future__ import annotations

import time
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..errors import DriverConfigError


@dataclass
class FaultPlan:
    """Which faults to inject into a data stream, by frame number (0 = never).

    Attributes
    ----------
    garbage_every : int
        Before every k-th frame, write ``garbage_bytes`` random bytes (serial only).
    garbage_bytes : int
    drop_every : int
        Do not send every k-th frame (its samples are lost).
    duplicate_every : int
        Send every k-th frame twice.
    corrupt_every : int
        Flip one payload byte of every k-th frame (serial: CRC fails; frame lost).
    stall_at : int
        Stop sending at this frame for ``stall_seconds`` (``inf``: for good).
    stall_seconds : float
    disconnect_at : int
        Close the port / bus at this frame.
    seed : int
        Seed of the garbage bytes.
    """

    garbage_every: int = 0
    garbage_bytes: int = 37
    drop_every: int = 0
    duplicate_every: int = 0
    corrupt_every: int = 0
    stall_at: int = 0
    stall_seconds: float = float("inf")
    disconnect_at: int = 0
    seed: int = 0

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self.fault_at: float | None = None   # monotonic time of the first stall/disconnect

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "faults") -> "FaultPlan":
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise DriverConfigError(f"{where}: unknown fault key(s) {sorted(unknown)}; use "
                                    f"{', '.join(sorted(names))}")
        for key, value in data.items():
            if not isinstance(value, (int, float)) or value < 0:
                raise DriverConfigError(f"{where}.{key} must be a number >= 0, got {value!r}")
        return cls(**data)

    @staticmethod
    def _hit(every: int, k: int) -> bool:
        return every > 0 and k > 0 and k % every == 0

    def garbage(self, k: int) -> bytes:
        if self._hit(self.garbage_every, k):
            return self.rng.integers(0, 256, self.garbage_bytes, dtype=np.uint8).tobytes()
        return b""

    def drop(self, k: int) -> bool:
        return self._hit(self.drop_every, k)

    def duplicate(self, k: int) -> bool:
        return self._hit(self.duplicate_every, k)

    def corrupt(self, k: int) -> bool:
        return self._hit(self.corrupt_every, k)

    def stalled(self, k: int) -> float:
        """Seconds to stall before frame ``k`` (0 if none)."""
        if self.stall_at and k == self.stall_at:
            self.mark()
            return self.stall_seconds
        return 0.0

    def disconnect(self, k: int) -> bool:
        if self.disconnect_at and k == self.disconnect_at:
            self.mark()
            return True
        return False

    def mark(self) -> None:
        if self.fault_at is None:
            self.fault_at = time.monotonic()
