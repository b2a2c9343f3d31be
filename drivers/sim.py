"""In-process ``sim://`` backend: shaker and DAQ on a shared `SimRig`.

Both ends take the rig as ``rig=`` or find it by name in a process-wide table (like
python-can's ``virtual`` channels): ``sim://bench1`` opens the rig registered as ``bench1``
with `register_rig`.
"""

from __future__ import annotations

import threading

from .base import (DEFAULT_RAMP_TIME, Acquirer, Block, Channel, DeviceState,
                   SignalGenerator)
from .outputs import Output, SineOutput
from .errors import DriverConfigError, UnknownBackendError
from .rig import SimRig

_RIGS: dict[str, SimRig] = {}
_RIGS_LOCK = threading.Lock()


def register_rig(name: str, rig: SimRig) -> None:
    """Make ``rig`` reachable as ``sim://name``."""
    with _RIGS_LOCK:
        _RIGS[name] = rig


def unregister_rig(name: str) -> None:
    """Forget the rig registered as ``sim://name`` (nothing if none)."""
    with _RIGS_LOCK:
        _RIGS.pop(name, None)


def _find_rig(name: str, rig: SimRig | None) -> SimRig:
    if rig is not None:
        return rig
    with _RIGS_LOCK:
        if name in _RIGS:
            return _RIGS[name]
    raise UnknownBackendError(f"no simulated rig named '{name or '(default)'}'; pass rig= or "
                              "register one with drivers.sim.register_rig")


class SimShaker(SignalGenerator):
    """Shaker acting directly on the rig's drive."""

    def __init__(self, name: str = "", *, rig: SimRig | None = None,
                 ramp_time: float = DEFAULT_RAMP_TIME) -> None:
        self.rig = _find_rig(name, rig)
        self.ramp_time = ramp_time

    def configure(self, output: Output, level: float, *, timeout: float = 1.0) -> None:
        """Set the rig's waveform and level (`SignalGenerator.configure`)."""
        self._require(DeviceState.NEW, DeviceState.CONFIGURED, DeviceState.STOPPED,
                      action="configure")
        level = self.check_level(level)
        self.rig.set_output(output)
        self.rig.set_level(level)
        self._state = DeviceState.CONFIGURED

    def set_level(self, level: float, *, timeout: float = 1.0) -> None:
        """Change the drive level, V (`SignalGenerator.set_level`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.RUNNING, DeviceState.STOPPED,
                      action="set the level")
        self.rig.set_level(self.check_level(level))

    def set_frequency(self, freq: float, *, timeout: float = 1.0) -> None:
        """Change the sine frequency (`SignalGenerator.set_frequency`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.RUNNING, DeviceState.STOPPED,
                      action="set the frequency")
        self.rig.set_output(SineOutput(freq))

    def start(self, *, timeout: float = 1.0) -> None:
        """Switch the output on (ramped)."""
        self._require(DeviceState.CONFIGURED, DeviceState.STOPPED, action="start")
        self.rig.set_on(True, self.ramp_time)
        self._state = DeviceState.RUNNING

    def stop(self, *, timeout: float = 1.0) -> None:
        """Switch the output off (ramped); nothing if not running."""
        if self._state == DeviceState.RUNNING:
            self.rig.set_on(False, self.ramp_time)
            self._state = DeviceState.STOPPED

    def emergency_stop(self, *, timeout: float = 0.1) -> None:
        """Switch the output off with a ramp of at most 10 ms."""
        self.rig.set_on(False, min(self.ramp_time, 0.01))
        if self._state == DeviceState.RUNNING:
            self._state = DeviceState.STOPPED

    def close(self) -> None:
        """Stop and close."""
        if self._state != DeviceState.CLOSED:
            self.stop()
            self._state = DeviceState.CLOSED


class SimDaq(Acquirer):
    """DAQ reading the rig; each `read` advances the rig by one frame."""

    def __init__(self, name: str = "", *, rig: SimRig | None = None) -> None:
        super().__init__()
        self.rig = _find_rig(name, rig)
        self.frame_size = 64
        self._seq = 0
        self._first = 0

    def configure(self, fs: float, channels: list[Channel], *, frame_size: int = 64,
                  timeout: float = 1.0) -> None:
        """Set sample rate, channels and frame size (`Acquirer.configure`).

        Raises
        ------
        DriverConfigError
            A rate other than the rig's, or a channel the rig does not measure.
        """
        self._require(DeviceState.NEW, DeviceState.CONFIGURED, DeviceState.STOPPED,
                      action="configure")
        self.check_config(fs, channels, frame_size)
        if abs(fs - self.rig.fs) > 1e-9 * fs:
            raise DriverConfigError(f"DAQ sample rate {fs} Hz differs from the simulated "
                                    f"rig's {self.rig.fs} Hz; use the same rate for both")
        self.fs, self.channels, self.frame_size = float(fs), tuple(channels), frame_size
        self.rig.check_channels(channels)
        self._state = DeviceState.CONFIGURED

    def start(self, *, timeout: float = 1.0) -> None:
        """Start reading from sample 0 (`Acquirer.start`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.STOPPED, action="start")
        self._seq, self._first = 0, 0
        self._state = DeviceState.RUNNING

    def read(self, timeout: float = 1.0) -> Block:
        """Advance the rig by one frame and return its samples (`Acquirer.read`)."""
        self._require(DeviceState.RUNNING, action="read")
        samples = self.rig.advance(self.frame_size)
        data = samples.values(list(self.channels), self.rig.force_dofs)
        block = Block(self._seq, self._first, self._first / self.fs, data)
        self._seq += 1
        self._first += self.frame_size
        self.stats.frames += 1
        self.stats.samples += self.frame_size
        return block

    def stop(self, *, timeout: float = 1.0) -> None:
        """Stop; nothing if not running."""
        if self._state == DeviceState.RUNNING:
            self._state = DeviceState.STOPPED

    def close(self) -> None:
        """Close (the rig stays)."""
        self._state = DeviceState.CLOSED
