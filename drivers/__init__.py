"""Hardware I/O layer: shaker and DAQ contracts, backends and device emulators.

Open devices by URL with `open_shaker` / `open_daq` (see `drivers.registry`); every error is a
`drivers.errors.DriverError`.
"""

from .base import (Acquirer, AcqStats, Block, Channel, MultisineOutput, RandomOutput,
                   SignalGenerator, SineOutput)
from .errors import (CommsError, DeviceError, Disconnected, DriverConfigError, DriverError,
                     DriverTimeout, ProtocolError, StateError, UnknownBackendError)
from .registry import open_daq, open_shaker

__all__ = [
    "Acquirer", "AcqStats", "Block", "Channel", "MultisineOutput", "RandomOutput",
    "SignalGenerator", "SineOutput",
    "CommsError", "DeviceError", "Disconnected", "DriverConfigError", "DriverError",
    "DriverTimeout", "ProtocolError", "StateError", "UnknownBackendError",
    "open_daq", "open_shaker",
]
