"""Device emulators backed by a `drivers.rig.SimRig`, so tests drive production code end to end.

`SerialShakerEmulator` and `SerialDaqEmulator` serve the serial protocols on real
pseudo-terminals; `CanDaqEmulator` serves the CAN protocol on any python-can bus. All run in
threads, share one rig (one loop through the structure) and inject the faults of a
`drivers.faults.FaultSpec` (run as a `FaultPlan`).
"""

from .faults import FaultPlan

__all__ = ["FaultPlan"]
