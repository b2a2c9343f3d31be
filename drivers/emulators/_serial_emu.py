"""Serial shaker controller and serial streaming DAQ emulators on pseudo-terminals.

Both serve the command sets of docs/drivers.md on the master end of a pty and act on one
shared `SimRig`; the DAQ streams `drivers.frame` frames and injects faults from a `FaultPlan`.
"""

from __future__ import annotations

import select
import time
from collections import deque

import numpy as np

from ..base import Channel
from ..outputs import MultisineOutput, RandomOutput, SineOutput, SweepOutput
from ..errors import DriverConfigError
from ..frame import MAX_SAMPLES, encode_frame
from ..rig import SimRig
from ..faults import FaultSpec
from ._faults import FaultPlan
from ._pty_server import OUT_CAP, PtyServer, short_form

BAD_HEADER = 'ERR -113,"Undefined header"'
BAD_DATA = 'ERR -222,"Data out of range"'
CONFLICT = 'ERR -221,"Settings conflict"'
EXPIRED = 'ERR -300,"Watchdog expired: drive zeroed, output off"'
ESTOP_RAMP = 0.01  # s, longest ramp of ABOR and of a watchdog trip
FRAMES_PER_TICK = 4


def _split(line: str) -> tuple[str, str]:
    header, _, arg = line.partition(" ")
    return short_form(header), arg.strip()


def _band(arg: str) -> tuple[float, float]:
    lo, hi = (float(x) for x in arg.split(","))
    return lo, hi


#: Waveform settings of the shaker: header -> (attribute, parser, waveform it belongs to;
#: sweep settings, "", take effect together at ``SOUR:FUNC SWE``).
_WAVE_SETTINGS = {"SOUR:FREQ": ("_freq", float, "SIN"),
                  "SOUR:RAND:BAND": ("_band", _band, "RAND"),
                  "SOUR:RAND:SEED": ("_seed", int, "RAND"),
                  "SOUR:MSIN:BAND": ("_ms_band", _band, "MSIN"),
                  "SOUR:MSIN:SEED": ("_ms_seed", int, "MSIN"),
                  "SOUR:MSIN:PER": ("_ms_period", int, "MSIN"),
                  "SOUR:SWE:STAR": ("_sw_start", float, ""),
                  "SOUR:SWE:STOP": ("_sw_stop", float, ""),
                  "SOUR:SWE:LAW": ("_sw_law", str.lower, ""),
                  "SOUR:SWE:RATE": ("_sw_rate", float, "")}


class SerialShakerEmulator(PtyServer):
    """SCPI-style shaker controller acting on ``rig``.

    ``stall`` (set it True) makes the controller stop answering, as a hung device would;
    ``unplugged`` loses every byte from the host, as a pulled cable would. Neither stops the
    link watchdog: armed by ``SYST:WDOG <s>`` and fed by every line received, it ramps the
    drive to zero (within `ESTOP_RAMP`) when nothing arrived for ``<s>`` seconds and logs
    ``(deadline, tripped_at)`` in ``trips``.
    """

    IDN = "NLID-LAB,SHAKER-EMU,0,1.0"

    def __init__(self, rig: SimRig) -> None:
        super().__init__("shaker-emulator")
        self.rig = rig
        self.stall = False
        self.unplugged = False
        self.watchdog = 0.0
        self.fed_at = time.monotonic()
        self.tripped = False
        self.trips: list[tuple[float, float]] = []
        self._func = "SIN"
        self._freq = 10.0
        self._band = (0.0, rig.fs / 2)
        self._seed: int | None = None
        self._ms_band = (0.0, rig.fs / 2)
        self._ms_seed: int | None = None
        self._ms_period = 1024
        self._sw_start, self._sw_stop, self._sw_law, self._sw_rate = 10.0, 20.0, "linear", 1.0
        self._ramp = 0.05
        self.log: deque[tuple[float, str]] = deque(maxlen=10000)

    def handle(self, line: str) -> str | None:
        """Answer one SCPI command of the shaker (`PtyServer.handle`); None while unplugged."""
        if self.unplugged:
            return None
        now = time.monotonic()
        self.log.append((now, line))
        if self.stall:
            return None
        self.fed_at = now
        head, arg = _split(line)
        try:
            return self._dispatch(head, arg)
        except (ValueError, DriverConfigError):
            return BAD_DATA

    def tick(self) -> float:
        """Trip the watchdog when its deadline has passed."""
        if not self.watchdog or self.tripped:
            return float("inf")
        deadline = self.fed_at + self.watchdog
        now = time.monotonic()
        if now < deadline:
            return deadline - now
        # A line that reached the port before this look feeds it: this thread may look late
        # (it shares the host's interpreter lock), after a `select` that timed out while
        # the line was on its way; a controller's own clock would have seen it.
        if select.select([self.master], [], [], 0)[0]:
            self._read()
            if self.fed_at + self.watchdog > now:
                return 0.0
        self.rig.set_on(False, min(self._ramp, ESTOP_RAMP))
        self.tripped = True
        self.trips.append((deadline, now))
        return float("inf")

    def _dispatch(self, head: str, arg: str) -> str | None:
        rig = self.rig
        if head == "*IDN?":
            return self.IDN
        if head == "SYST:WDOG":
            period = float(arg)
            if not 0 <= period <= 3600:
                return BAD_DATA
            self.watchdog, self.tripped = period, False
            return "OK"
        if head == "SYST:WDOG?":
            return f"{self.watchdog:.6g}"
        if head == "SYST:WDOG:FEED":
            return EXPIRED if self.tripped else "OK"
        if head == "SYST:WDOG:BEAT":       # a heartbeat: feeds it, no reply
            return None
        if head == "SYST:WDOG:BEAT?":
            return "1"
        if head == "*RST":
            rig.set_on(False, self._ramp)
            return "OK"
        if head == "SOUR:FUNC":
            funcs = {"RAN": "RAND", "SIN": "SIN", "MSI": "MSIN", "SWE": "SWE"}
            if arg.upper()[:3] not in funcs:
                return BAD_DATA
            self._func = funcs[arg.upper()[:3]]
            self._apply()
            return "OK"
        if head in _WAVE_SETTINGS:     # a waveform setting: applied if that waveform is on
            name, parse, func = _WAVE_SETTINGS[head]
            setattr(self, name, parse(arg))
            if self._func == func:
                self._apply()
            return "OK"
        if head == "SOUR:RAMP":
            self._ramp = float(arg)
            if not 0 <= self._ramp <= 10:
                return BAD_DATA
            return "OK"
        if head == "SOUR:VOLT":
            level = float(arg)
            if not 0 <= level <= 10:
                return BAD_DATA
            rig.set_level(level)
            return "OK"
        if head == "SOUR:VOLT?":
            return f"{rig.level:.12g}"
        if head == "SOUR:FREQ?":
            return f"{self._freq:.12g}"
        if head == "OUTP":
            on = arg.upper() in ("ON", "1")
            if not on and arg.upper() not in ("OFF", "0"):
                return BAD_DATA
            rig.set_on(on, self._ramp)
            self.tripped = self.tripped and not on
            return "OK"
        if head == "OUTP?":
            return "0" if rig.drive_is_zero else "1"
        if head == "ABOR":
            rig.set_on(False, min(self._ramp, ESTOP_RAMP))
            return "OK"
        if head == "SYST:ERR?":
            return '-300,"Watchdog expired"' if self.tripped else '0,"No error"'
        return BAD_HEADER

    def _apply(self) -> None:
        if self._func == "SIN":
            self.rig.set_output(SineOutput(self._freq))
        elif self._func == "MSIN":
            self.rig.set_output(MultisineOutput(self._ms_band, self._ms_period, self._ms_seed))
        elif self._func == "SWE":
            self.rig.set_output(SweepOutput(self._sw_start, self._sw_stop, self._sw_law,
                                            self._sw_rate))
        else:
            self.rig.set_output(RandomOutput(self._band, self._seed))


class SerialDaqEmulator(PtyServer):
    """Streaming DAQ on a pty: sensors wired as ``channels`` to ``rig``.

    Parameters
    ----------
    rig : SimRig
    channels : list of Channel
        What each input measures (quantity, DOF) and its sensitivity (V/unit).
    pace : float
        1.0 streams in real time, 2.0 twice as fast; 0 as fast as the reader takes it.
    faults : FaultSpec, optional
    """

    IDN = "NLID-LAB,DAQ-EMU,0,1.0"

    def __init__(self, rig: SimRig, channels: list[Channel], *, pace: float = 1.0,
                 faults: FaultSpec | None = None) -> None:
        super().__init__("daq-emulator")
        self.rig = rig
        self.wiring = list(channels)
        self.pace = pace
        self.faults = FaultPlan.of(faults)
        self.frame_size = 64
        self.streaming = False
        self._k = 0
        self._t0 = 0.0
        self._stall_until = 0.0
        self._origin = 0
        self.sent: deque[tuple[int, int, float, np.ndarray]] = deque(maxlen=200000)

    def handle(self, line: str) -> str | None:
        """Answer one SCPI command of the DAQ (`PtyServer.handle`)."""
        head, arg = _split(line)
        try:
            if head == "*IDN?":
                return self.IDN
            if head == "CONF:RATE":
                return "OK" if abs(float(arg) - self.rig.fs) <= 1e-9 * self.rig.fs \
                    else BAD_DATA
            if head == "CONF:CHAN:COUN":
                return "OK" if int(arg) == len(self.wiring) else CONFLICT
            if head == "CONF:FRAM":
                n = int(arg)
                if not 1 <= n <= MAX_SAMPLES:
                    return BAD_DATA
                self.frame_size = n
                return "OK"
            if head == "INIT":
                self.streaming, self._k, self._t0 = True, 0, time.monotonic()
                self._origin = self.rig.sample_index
                return "OK"
            if head == "ABOR":
                self.streaming = False
                return "OK"
            if head == "SYST:ERR?":
                return '0,"No error"'
        except ValueError:
            return BAD_DATA
        return BAD_HEADER

    #: s; a heartbeat (a frame of no samples) goes out when no frame did for this long,
    #: well within the host's `drivers.base.STALL_MARGIN`
    HEARTBEAT = 0.01

    def heartbeat(self) -> bytes:
        """While streaming, a frame of no samples carrying the next frame's sequence number
        and first sample: the DAQ is alive, samples follow (a real DAQ's acquisition never
        lags, the emulator's may, computing the plant on a busy CPU); none during an
        injected stall or after a disconnect (`PtyServer.heartbeat`)."""
        f, k = self.faults, self._k
        if not self.streaming or time.monotonic() < self._stall_until or any(
                at and k >= at for at in (f.stall_at, f.disconnect_at)):
            return b""
        first = max(self.rig.sample_index - self._origin, 0)
        return encode_frame(k, first, np.zeros((0, len(self.wiring)), np.float32))

    def tick(self) -> float:
        """Send the frames that are due while streaming (`PtyServer.tick`)."""
        if not self.streaming:
            return float("inf")
        now = time.monotonic()
        if now < self._stall_until:
            return self._stall_until - now
        for _ in range(FRAMES_PER_TICK):
            if len(self.out) >= OUT_CAP:
                return 0.001
            k = self._k
            if self.pace > 0:
                due = self._t0 + k * self.frame_size / (self.rig.fs * self.pace)
                if now < due:
                    return due - now
            stall = self.faults.stalled(k)
            if stall:
                self._stall_until = now + stall
                self.faults.stall_at = 0
                return min(stall, 0.02)
            if self.faults.disconnect(k):
                self.flush_out()
                self.disconnect()
                return 0.0
            self._emit(k, now)
            if not self.streaming:
                break
        return 0.0

    def _emit(self, k: int, now: float) -> None:
        samples = self.rig.advance(self.frame_size)
        volts = samples.volts(self.wiring, self.rig.force_dofs)
        first = samples.first_sample - self._origin  # samples count from stream start
        frame = encode_frame(k, first, volts)
        self._k = k + 1
        self.sent.append((k, first, now, np.abs(volts).max(axis=0)))
        self.out += self.faults.garbage(k)
        if self.faults.drop(k):
            return
        if self.faults.corrupt(k):
            frame = bytearray(frame)
            frame[len(frame) // 2] ^= 0xFF
            frame = bytes(frame)
        self.out += frame
        if self.faults.duplicate(k):
            self.out += frame
