"""One exception tree for every driver, backend and emulator.

``DriverError`` is the root. Bad configuration (a wrong URL, an unknown backend, a channel
that makes no sense) raises `DriverConfigError`, which is also an
`analysis.errors.InputError`, so the CLI reports it in one line and exits with code 2.
Everything that goes wrong while talking to a device is a `CommsError`: callers that must
make the rig safe catch that one class.
"""

from __future__ import annotations

from analysis.errors import InputError


class DriverError(Exception):
    """Root of all driver errors."""


class DriverConfigError(DriverError, InputError):
    """A driver was configured with values it cannot use (message names the fix)."""


class UnknownBackendError(DriverConfigError):
    """No backend is registered under the requested name or URL scheme."""


class StateError(DriverError):
    """A method was called in the wrong lifecycle state (e.g. read before start)."""


class CommsError(DriverError):
    """Communication with a device failed."""


class DriverTimeout(CommsError, TimeoutError):
    """A blocking call did not complete within its timeout (e.g. the data stream stalled)."""


class Disconnected(CommsError):
    """The device went away (port closed, bus shut down)."""


class ProtocolError(CommsError):
    """The device answered something that does not follow the protocol."""


class DeviceError(CommsError):
    """The device reported an error for a command (``ERR code,"text"``)."""
