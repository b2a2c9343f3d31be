"""Device emulators backed by a `drivers.rig.SimRig`, so tests drive production code end to end.

`SerialShakerEmulator` and `SerialDaqEmulator` serve the serial protocols on real
pseudo-terminals; `CanDaqEmulator` serves the CAN protocol on any python-can bus. All run in
threads, share one rig (one loop through the structure) and inject the faults of a
`drivers.faults.FaultSpec` (run as a `FaultPlan`).
"""

from __future__ import annotations

import importlib
from typing import Any

from ._faults import FaultPlan

#: Emulators loaded on first use (PEP 562): the CAN one imports python-can.
_LAZY = {"SerialShakerEmulator": "_serial_emu", "SerialDaqEmulator": "_serial_emu",
         "CanDaqEmulator": "_can_emu", "ROWS_PER_TICK": "_can_emu"}

__all__ = ["FaultPlan", *_LAZY]


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    return value                    # not cached: the module's own name stays the one in use
