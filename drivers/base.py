"""Driver contracts: the abstract shaker (`SignalGenerator`) and DAQ (`Acquirer`).

Lifecycle of both: ``configure -> start -> (read | set_level)* -> stop -> close``; both are
context managers (leaving the ``with`` block stops and closes, and a shaker ramps its drive to
zero). Every blocking call takes ``timeout`` in seconds.

Units: the shaker's level is the drive signal in volts (rms for random output, amplitude for
a sine); the DAQ delivers channels already divided by their sensitivity (volts per unit), so
values are in the channel's physical unit.
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from types import TracebackType
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from . import pauses
from .errors import CommsError, DriverConfigError, StateError

if TYPE_CHECKING:
    from .outputs import Output

T = TypeVar("T")
QUANTITIES = ("force", "displacement", "velocity", "acceleration")
#: s of silence beyond a transport frame's interval that count as a stalled stream: the
#: drive must be zero within 100 ms of a stall (docs/drivers.md "Drive-zero latency")
STALL_MARGIN = 0.06
#: s a live stream (heartbeats coming: the device is there) may go without samples before a
#: read gives up: room for an emulator computing its plant on a busy CPU; a device that
#: stops altogether is a stall, seen after `stall_timeout`
DATA_TIMEOUT = 0.5
UNITS = {"force": "N", "displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


@dataclass(frozen=True)
class Channel:
    """One DAQ input: what it measures, where, and how volts map to units.

    Parameters
    ----------
    name : str
        Label used in files and safety limits.
    quantity : {"force", "displacement", "velocity", "acceleration"}
    dof : int
        Structure DOF (0-based) the sensor sits on.
    sensitivity : float
        Volts per physical unit (e.g. 0.01 V/N for a force gauge).
    unit : str
        Physical unit; defaults to the SI unit of ``quantity``.
    """

    name: str
    quantity: str
    dof: int
    sensitivity: float = 1.0
    unit: str = ""

    def __post_init__(self) -> None:
        if self.quantity not in QUANTITIES:
            raise DriverConfigError(f"channel '{self.name}': quantity '{self.quantity}' is not "
                                    f"one of {', '.join(QUANTITIES)}")
        if not isinstance(self.dof, int) or self.dof < 0:
            raise DriverConfigError(f"channel '{self.name}': dof must be an integer >= 0 "
                                    f"(0-based), got {self.dof!r}")
        if not (isinstance(self.sensitivity, (int, float)) and math.isfinite(self.sensitivity)
                and self.sensitivity > 0):
            raise DriverConfigError(f"channel '{self.name}': sensitivity must be a positive "
                                    f"number of volts per unit, got {self.sensitivity!r}")
        if not self.unit:
            object.__setattr__(self, "unit", UNITS[self.quantity])


@dataclass
class Block:
    """A chunk of samples as it arrived from the DAQ.

    Attributes
    ----------
    seq : int
        Device sequence counter of the (first) frame in this chunk.
    first_sample : int
        Index of the first sample since the stream started.
    t0 : float
        Time of the first sample, ``first_sample / fs`` seconds after stream start.
    data : ndarray, shape (n, n_channels)
        Samples in physical units.
    gap : int
        Samples lost immediately before this chunk (0 if contiguous with the previous one).
    """

    seq: int
    first_sample: int
    t0: float
    data: np.ndarray
    gap: int = 0


@dataclass
class AcqStats:
    """Counters of a data stream; losses are never silent."""

    frames: int = 0
    samples: int = 0
    lost_frames: int = 0
    lost_samples: int = 0
    duplicate_frames: int = 0
    bad_frames: int = 0
    garbage_bytes: int = 0

    def as_dict(self) -> dict[str, int]:
        """The counters as a dict."""
        return dict(self.__dict__)


class DeviceState(StrEnum):
    """Where a shaker or DAQ is in its lifecycle (`SignalGenerator.state`, `Acquirer.state`)."""

    NEW = "new"
    CONFIGURED = "configured"
    RUNNING = "running"
    STOPPED = "stopped"
    CLOSED = "closed"


class _Lifecycle:
    """State bookkeeping and context management shared by both contracts."""

    _state: DeviceState = DeviceState.NEW

    @property
    def state(self) -> DeviceState:
        """Where the device is in its lifecycle."""
        return self._state

    def _require(self, *states: DeviceState, action: str) -> None:
        if self._state not in states:
            raise StateError(f"cannot {action} while {self._state}; expected "
                             f"{' or '.join(states)}")

    def __enter__(self):
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


#: Seconds a shaker ramps its drive to a new level or to zero (every backend's default).
DEFAULT_RAMP_TIME = 0.05


class SignalGenerator(_Lifecycle, ABC):
    """A shaker controller / signal generator with one drive output."""

    ramp_time: float = DEFAULT_RAMP_TIME

    @abstractmethod
    def configure(self, output: Output, level: float, *, timeout: float = 1.0) -> None:
        """Select the waveform and the level (volts) it starts at."""

    @abstractmethod
    def set_level(self, level: float, *, timeout: float = 1.0) -> None:
        """Change the drive level (volts) while running or before start."""

    @abstractmethod
    def set_frequency(self, freq: float, *, timeout: float = 1.0) -> None:
        """Change the sine frequency, phase-continuously, without stopping the output."""

    @abstractmethod
    def start(self, *, timeout: float = 1.0) -> None:
        """Switch the drive output on."""

    @abstractmethod
    def stop(self, *, timeout: float = 1.0) -> None:
        """Ramp the drive to zero over `ramp_time` and switch the output off."""

    @abstractmethod
    def emergency_stop(self, *, timeout: float = 0.1) -> None:
        """Ramp the drive to zero as fast as the device allows; never raises on comms loss
        of a device that is already silent, but does raise if the command could not be sent."""

    @abstractmethod
    def close(self) -> None:
        """Release the device; a running output is stopped first."""

    def check_link(self) -> None:
        """Raise the `CommsError` a background link check (e.g. the watchdog feeder) met.

        Cheap; callers that stream for long without commanding the shaker call it per chunk.
        """

    @staticmethod
    def check_level(level: float) -> float:
        """``level`` as a float, after checking it is a finite number of volts >= 0.

        Raises
        ------
        DriverConfigError
        """
        if not (isinstance(level, (int, float)) and math.isfinite(level) and level >= 0):
            raise DriverConfigError(f"drive level must be a finite number of volts >= 0, "
                                    f"got {level!r}")
        return float(level)


def default_stall_timeout(interval: float) -> float:
    """Seconds without data after which a stream counts as stalled.

    Parameters
    ----------
    interval : float
        Seconds between the device's transport frames (0 if it streams continuously).

    Returns
    -------
    float
        ``interval + STALL_MARGIN``: a stream that is on time never stays silent that long,
        and a stall is seen `STALL_MARGIN` after the frame that did not come.
    """
    return max(float(interval), 0.0) + STALL_MARGIN


#: s a wait may overrun before its thread counts as having been starved, and the longest
#: second wait then (`wait_for_data`): time for the process's other threads to run once
LATE, LATE_GRACE = 0.005, 0.02


def wait_for_data(wait: Callable[[float], T], timeout: float) -> T:
    """``wait(timeout)``, not blaming the device for this process's own lateness.

    When the wait comes back empty, it looks once more without waiting (the thread may run
    well after its wait ended: data that came meanwhile counts). When this process was
    paused for more than `LATE` of the wait (`drivers.pauses`, or the wait came back that
    late: a device emulated in it could not send either), it waits once more for that long,
    at most `LATE_GRACE`.

    Parameters
    ----------
    wait : callable
        ``wait(seconds)``: what arrives within ``seconds``, falsy if nothing.
    timeout : float
        Seconds of the first wait.

    Returns
    -------
    object
        What ``wait`` returned last.
    """
    pauses.start()
    start = time.monotonic()
    got = wait(timeout)
    if got:
        return got
    now = time.monotonic()
    lost = max(now - start - timeout, pauses.paused(start, now))
    return wait(min(lost, LATE_GRACE) if lost > LATE else 0.0)


def check_stall_timeout(value: float | None) -> float | None:
    """``value`` as a float if it is a stall timeout (finite, > 0 s), None if None.

    Raises
    ------
    DriverConfigError
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not (math.isfinite(value) and value > 0):
        raise DriverConfigError(f"stall_timeout must be a number of seconds > 0, got {value!r}")
    return float(value)


class Acquirer(_Lifecycle, ABC):
    """A DAQ streaming blocks of samples with sequence numbers and timestamps."""

    fs: float = 0.0
    channels: tuple[Channel, ...] = ()
    stats: AcqStats
    #: seconds without data after which `read` reports a stalled stream (0: the backend
    #: cannot stall, e.g. the in-process ``sim://`` DAQ)
    stall_timeout: float = 0.0

    def __init__(self) -> None:
        self.stats = AcqStats()

    @abstractmethod
    def configure(self, fs: float, channels: list[Channel], *, frame_size: int = 64,
                  timeout: float = 1.0) -> None:
        """Set sample rate, channel table and the samples per transport frame."""

    @abstractmethod
    def start(self, *, timeout: float = 1.0) -> None:
        """Start streaming (sample 0 is the first sample after this call)."""

    @abstractmethod
    def read(self, timeout: float = 1.0) -> Block:
        """Return the next chunk; `DriverTimeout` if none arrives within ``timeout``."""

    @abstractmethod
    def stop(self, *, timeout: float = 1.0) -> None:
        """Stop streaming."""

    def close(self) -> None:
        """Stop streaming if needed (a dead link is ignored) and release the device."""
        if self._state == DeviceState.CLOSED:
            return
        try:
            self.stop(timeout=0.5)
        except CommsError:
            pass
        finally:
            self._release()
            self._state = DeviceState.CLOSED

    def _release(self) -> None:
        """Free the transport (port, bus); nothing by default."""

    @staticmethod
    def check_config(fs: float, channels: list[Channel], frame_size: int) -> None:
        """Check a DAQ configuration before sending it.

        Parameters
        ----------
        fs : float
            Sample rate, Hz (positive).
        channels : list of Channel
            At least one.
        frame_size : int
            Samples per frame.

        Raises
        ------
        DriverConfigError
        """
        if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
            raise DriverConfigError(f"sample rate must be a positive number of Hz, got {fs!r}")
        if not channels:
            raise DriverConfigError("the DAQ needs at least one channel")
        names = [c.name for c in channels]
        if len(set(names)) != len(names):
            raise DriverConfigError(f"channel names must be unique, got {names}")
        if not (isinstance(frame_size, int) and 1 <= frame_size <= 4096):
            raise DriverConfigError(f"frame_size must be an integer in 1..4096, "
                                    f"got {frame_size!r}")
