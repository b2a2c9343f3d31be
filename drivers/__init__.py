"""Hardware I/O layer: shaker and DAQ contracts, backends and device emulators.

Open devices by URL with `open_shaker` / `open_daq` (see `drivers.registry`); every error is a
`drivers.errors.DriverError`.
"""

from .base import (DEFAULT_RAMP_TIME, Acquirer, AcqStats, Block, Channel, DeviceState,
                   SignalGenerator)
from .outputs import MultisineOutput, RandomOutput, SineOutput, SweepOutput
from .errors import (CommsError, DeviceError, Disconnected, DriverConfigError, DriverError,
                     DriverTimeout, ProtocolError, StateError, UnknownBackendError)
from .registry import DAQS, SHAKERS, open_daq, open_shaker

__all__ = [
    "DEFAULT_RAMP_TIME", "Acquirer", "AcqStats", "Block", "Channel", "DeviceState",
    "MultisineOutput", "RandomOutput", "SignalGenerator", "SineOutput", "SweepOutput",
    "CommsError", "DeviceError", "Disconnected", "DriverConfigError", "DriverError",
    "DriverTimeout", "ProtocolError", "StateError", "UnknownBackendError",
    "DAQS", "SHAKERS", "open_daq", "open_shaker",
]
