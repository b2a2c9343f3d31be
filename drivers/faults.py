"""Typed fault specification: which faults an emulated device injects (plain data).

Campaign files name faults in ``[emulator.faults]``; the application validates them into a
`FaultSpec` and hands it to the emulators (`drivers.emulators._faults.FaultPlan` runs it), so
configuration code does not depend on emulator internals.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from analysis.documents import TomlTable

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
    def from_dict(cls, data: TomlTable, where: str = "faults") -> "FaultSpec":
        """Validated spec from a table such as a campaign's ``[emulator.faults]``."""
        names = {f.name for f in fields(FaultSpec)}
        unknown = set(data) - names
        if unknown:
            raise DriverConfigError(f"{where}: unknown fault key(s) {sorted(unknown)}; use "
                                    f"{', '.join(sorted(names))}")
        for key, value in data.items():
            check_fault_value(key, value, where)
        return cls(**data)


#: fault keys holding a duration in seconds; every other key counts frames or bytes
DURATIONS = ("stall_seconds",)
MAX_GARBAGE_BYTES = 1 << 16  # random bytes written before a frame


def check_fault_value(key: str, value: Any, where: str = "faults") -> None:
    """Raise `DriverConfigError` unless ``value`` suits fault key ``key``: a whole number
    >= 0 for counts, or a duration in seconds >= 0 (``inf``: for good, never NaN)."""
    if key in DURATIONS:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0
        if not ok:  # False for NaN
            raise DriverConfigError(f"{where}.{key} must be a duration in seconds >= 0 (inf: "
                                    f"for good), got {value!r}")
    elif not (isinstance(value, int) and not isinstance(value, bool) and value >= 0):
        raise DriverConfigError(f"{where}.{key} must be a whole number >= 0 (a frame number or "
                                f"count; 0 = never), got {value!r}")
    elif key == "garbage_bytes" and value > MAX_GARBAGE_BYTES:
        raise DriverConfigError(f"{where}.{key} must be at most {MAX_GARBAGE_BYTES}, got "
                                f"{value!r}")
