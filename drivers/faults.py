"""Typed fault specification: which faults an emulated device injects (plain data).

Campaign files name faults in ``[emulator.faults]``; the application validates them into a
`FaultSpec` and hands it to the emulators (`drivers.emulators.faults.FaultPlan` runs it), so
configuration code does not depend on emulator internals.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from .errors import DriverConfigError


@dataclass
class FaultSpec:
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

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "faults") -> "FaultSpec":
        """Validated spec from a table such as a campaign's ``[emulator.faults]``."""
        names = {f.name for f in fields(FaultSpec)}
        unknown = set(data) - names
        if unknown:
            raise DriverConfigError(f"{where}: unknown fault key(s) {sorted(unknown)}; use "
                                    f"{', '.join(sorted(names))}")
        for key, value in data.items():
            if not isinstance(value, (int, float)) or value < 0:
                raise DriverConfigError(f"{where}.{key} must be a number >= 0, got {value!r}")
        return cls(**data)
