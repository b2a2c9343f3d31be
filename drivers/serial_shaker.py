"""``serial://`` shaker controller speaking the SCPI-style command set of docs/drivers.md.

Link watchdog: the driver arms the controller's watchdog (``SYST:WDOG <s>``); a small process
of its own (`drivers.watchdog_beat`) writes ``SYST:WDOG:BEAT`` (no reply) every eighth of the
period, and a daemon thread checks the link (``SYST:WDOG:FEED``, whose reply says the
controller hears us) every period. A controller without ``BEAT`` is fed by that thread
alone, every eighth of the period. If the host dies (even by SIGKILL) or the cable is
pulled, the beats stop and the controller ramps the drive to zero on its own once the period
has passed.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

from .base import DEFAULT_RAMP_TIME, DeviceState, SignalGenerator
from .outputs import (MultisineOutput, Output, RandomOutput, SineOutput, SweepOutput,
                      check_output)
from .errors import CommsError, DeviceError, DriverConfigError, DriverTimeout
from .serial_link import SerialLink
from .watchdog_beat import BeatProcess

FEEDS_PER_PERIOD = 8
MIN_WATCHDOG = 0.02  # s; shorter periods leave no room for a feed round trip
#: s; with the controller's 10 ms emergency ramp the drive is zero within 100 ms of a cut or
#: hung link (docs/drivers.md "Drive-zero latency"); a feed goes out every 10 ms
DEFAULT_WATCHDOG = 0.08
#: s a feed's reply may take before the link counts as dead; longer than the period, as the
#: controller was fed when the line arrived and zeroes the drive by itself if none does
FEED_REPLY_TIMEOUT = 0.25
#: s; with beats feeding the controller (`drivers.watchdog_beat`) the thread's feed replies
#: only tell the host the link is alive (the controller zeroes the drive by itself)
LINK_CHECK_PATIENCE = 0.5


def _random(output: RandomOutput) -> list[str]:
    cmds = [f"SOUR:RAND:SEED {int(output.seed)}"] if output.seed is not None else []
    return cmds + [f"SOUR:RAND:BAND {output.band[0]:.9g},{output.band[1]:.9g}",
                   "SOUR:FUNC RAND"]


def _multisine(output: MultisineOutput) -> list[str]:
    cmds = [f"SOUR:MSIN:SEED {int(output.seed)}"] if output.seed is not None else []
    return cmds + [f"SOUR:MSIN:BAND {output.band[0]:.9g},{output.band[1]:.9g}",
                   f"SOUR:MSIN:PER {output.period}", "SOUR:FUNC MSIN"]


def _sweep(output: SweepOutput) -> list[str]:
    return [f"SOUR:SWE:STAR {output.start_hz:.12g}", f"SOUR:SWE:STOP {output.stop_hz:.12g}",
            f"SOUR:SWE:LAW {output.law.upper()}", f"SOUR:SWE:RATE {output.rate:.12g}",
            "SOUR:FUNC SWE"]


def _sine(output: SineOutput) -> list[str]:
    return ["SOUR:FUNC SIN", f"SOUR:FREQ {output.freq:.12g}"]


#: The commands that select each output this controller plays (`drivers.outputs`).
_WAVEFORMS: dict[type, Callable[..., list[str]]] = {
    RandomOutput: _random, MultisineOutput: _multisine, SweepOutput: _sweep, SineOutput: _sine}


class SerialShaker(SignalGenerator):
    """Shaker controller on a serial port.

    Parameters
    ----------
    port : str
        Device path or pyserial URL.
    baud : int
        Baud rate (ignored by pseudo-terminals).
    ramp_time : float
        Seconds over which `stop` ramps the drive down.
    watchdog : float
        Link watchdog period, seconds (0 disables it): the controller zeroes the drive when
        it hears nothing from the host for this long (default `DEFAULT_WATCHDOG`).
    """

    def __init__(self, port: str, baud: int = 115200, *, ramp_time: float = DEFAULT_RAMP_TIME,
                 watchdog: float = DEFAULT_WATCHDOG) -> None:
        if not (isinstance(watchdog, (int, float)) and math.isfinite(watchdog)
                and (watchdog == 0 or MIN_WATCHDOG <= watchdog <= 60)):
            raise DriverConfigError(f"shaker watchdog must be 0 (off) or {MIN_WATCHDOG:g}..60 "
                                    f"s, got {watchdog!r}")
        self.link = SerialLink(port, baud, what="shaker")
        self.ramp_time = ramp_time
        self.watchdog = float(watchdog)
        self.feed_error: CommsError | None = None
        self._halt = threading.Event()
        self._feeder: threading.Thread | None = None
        self._beat: BeatProcess | None = None
        try:
            self.idn = self.link.command("*IDN?", 1.0)
            if self.watchdog:
                self._arm_watchdog()
        except BaseException:
            if self._beat is not None:
                self._beat.stop()
            self.link.close()
            raise

    def _arm_watchdog(self) -> None:
        self._beat = self._start_beat()     # beating before the watchdog is armed
        try:
            self.link.command(f"SYST:WDOG {self.watchdog:.6g}", 1.0)
        except DeviceError as exc:
            raise DriverConfigError(f"shaker on {self.link.port} has no link watchdog "
                                    f"(SYST:WDOG: {exc}); use a controller that has one, or "
                                    "open it with ?watchdog=0 to run unguarded") from None
        self._feeder = threading.Thread(target=self._feed, name="shaker-watchdog",
                                        daemon=True)
        self._feeder.start()

    def _start_beat(self) -> BeatProcess | None:
        """The beat process, if the controller takes ``SYST:WDOG:BEAT`` and the port has a
        descriptor to hand it; None otherwise (the feeder thread then feeds alone)."""
        fd = self.link.fileno()
        if fd is None:
            return None
        try:
            if self.link.command("SYST:WDOG:BEAT?", 1.0) != "1":
                return None
        except DeviceError:
            return None
        return BeatProcess(fd, self.watchdog / FEEDS_PER_PERIOD)

    def _feed(self) -> None:
        """Feed the controller's watchdog until closed; stop at the first failure (the
        controller then zeroes the drive, and `check_link` reports why).

        Feeds are posted without waiting for their replies (collected at the next feed, or
        by the next command): a feed's round trip through a busy host and controller may
        take longer than the period, and waiting for it spaced the feeds out by as much
        (20-40 ms apart instead of 10, gaps over 80 ms on a loaded machine: false trips)."""
        if self._beat is not None:       # beats feed it: this thread only checks the link
            period, patience = self.watchdog, LINK_CHECK_PATIENCE
        else:
            period = self.watchdog / FEEDS_PER_PERIOD
            patience = max(self.watchdog, FEED_REPLY_TIMEOUT)
        while not self._halt.wait(period):
            if not self.link.lock.acquire(blocking=False):
                continue  # a command is going out: that feeds it
            try:
                late = self.link.collect()
                if self.link.owed_error is not None:
                    raise DeviceError(f"shaker rejected 'SYST:WDOG:FEED': "
                                      f"{self.link.owed_error}")
                if self._beat is not None and not self._beat.alive():
                    raise DriverTimeout("the shaker watchdog's beat process ended")
                if late > patience:
                    raise DriverTimeout(f"shaker on {self.link.port} did not answer "
                                        f"'SYST:WDOG:FEED' within {patience:g} s")
                if time.monotonic() - self.link.last_command >= period:
                    self.link.post("SYST:WDOG:FEED")   # else a command just fed it
            except CommsError as exc:
                self.feed_error = exc
                self.link.forget_owed()     # a dead line lost them; the next command starts
                return                      # clean
            finally:
                self.link.lock.release()

    def _send(self, cmd: str, timeout: float) -> None:
        """A command; a timeout on a guarded link says the controller zeroes the drive."""
        try:
            self.link.command(cmd, timeout)
        except DriverTimeout as exc:
            if not self.watchdog:
                raise
            raise DriverTimeout(f"{exc}: the link is lost; the controller's watchdog "
                                f"({self.watchdog:g} s) zeroes the drive by itself") from None

    def check_link(self) -> None:
        """Raise the `CommsError` the watchdog feeder met, if any (`SignalGenerator.check_link`)."""
        if self.feed_error is not None:
            raise type(self.feed_error)(f"shaker watchdog feed failed: {self.feed_error}")

    def configure(self, output: Output, level: float, *, timeout: float = 1.0) -> None:
        """Send the waveform, ramp and level to the shaker (`SignalGenerator.configure`)."""
        self._require(DeviceState.NEW, DeviceState.CONFIGURED, DeviceState.STOPPED,
                      action="configure")
        check_output(output)
        level = self.check_level(level)
        waveform = _WAVEFORMS.get(type(output))
        if waveform is None:
            raise DriverConfigError(f"the serial shaker cannot play {type(output).__name__}; "
                                    f"it plays {', '.join(t.__name__ for t in _WAVEFORMS)}")
        cmds = waveform(output)
        cmds += [f"SOUR:RAMP {self.ramp_time:.6g}", f"SOUR:VOLT {level:.12g}"]
        for cmd in cmds:
            self._send(cmd, timeout)
        self._state = DeviceState.CONFIGURED

    def set_level(self, level: float, *, timeout: float = 1.0) -> None:
        """Change the drive level, V (`SignalGenerator.set_level`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.RUNNING, DeviceState.STOPPED,
                      action="set the level")
        self._send(f"SOUR:VOLT {self.check_level(level):.12g}", timeout)

    def set_frequency(self, freq: float, *, timeout: float = 1.0) -> None:
        """Change the sine frequency without stopping (phase-continuous)."""
        self._require(DeviceState.CONFIGURED, DeviceState.RUNNING, DeviceState.STOPPED,
                      action="set the frequency")
        check_output(SineOutput(freq))
        self._send(f"SOUR:FREQ {freq:.12g}", timeout)

    def start(self, *, timeout: float = 1.0) -> None:
        """Switch the output on (ramped; `SignalGenerator.start`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.STOPPED, action="start")
        self._send("OUTP ON", timeout)
        self._state = DeviceState.RUNNING

    def stop(self, *, timeout: float = 1.0) -> None:
        """Switch the output off (ramped); nothing if not running."""
        if self._state == DeviceState.RUNNING:
            self._send("OUTP OFF", timeout)
            self._state = DeviceState.STOPPED

    def emergency_stop(self, *, timeout: float = 0.1) -> None:
        """Abort the output at once (`SignalGenerator.emergency_stop`)."""
        self._send("ABOR", timeout)
        if self._state == DeviceState.RUNNING:
            self._state = DeviceState.STOPPED

    def close(self) -> None:
        """Stop the watchdog feeder, the output and close the port."""
        if self._state == DeviceState.CLOSED:
            return
        self._halt.set()
        if self._feeder is not None:
            self._feeder.join(1.0)
        try:
            self.stop(timeout=0.5)
            if self.watchdog and self.feed_error is None:
                self.link.command("SYST:WDOG 0", 0.5)
        except CommsError:
            pass
        finally:
            if self._beat is not None:      # after the disarm: it fed the controller so far
                self._beat.stop()
            self.link.close()
            self._state = DeviceState.CLOSED
