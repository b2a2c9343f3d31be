"""CAN DAQ emulator: serves the ``nlid_daq.dbc`` protocol on a python-can bus from a `SimRig`."""

from __future__ import annotations

import struct
import threading
import time
from collections import deque

import can
import numpy as np

from .. import can_protocol as proto
from ..base import Channel
from ..errors import DriverConfigError
from ..rig import SimRig
from ..faults import FaultSpec
from ._faults import FaultPlan

ROWS_PER_TICK = 16
#: s; a status frame (state streaming) goes out this often while streaming: the DAQ is alive
#: even while the emulator's plant falls behind on a busy CPU (well within the host's
#: `drivers.base.STALL_MARGIN`); none during an injected stall or after a disconnect
HEARTBEAT = 0.01


class CanDaqEmulator(threading.Thread):
    """CAN DAQ wired as ``channels`` to ``rig``, on ``can.Bus(interface, channel)``.

    ``pace`` is the speed relative to real time (must be > 0: a CAN bus has no flow control).
    Fault frame numbers count CAN frames; "garbage" sends frames with a foreign identifier.
    """

    def __init__(self, rig: SimRig, channels: list[Channel], interface: str = "virtual",
                 channel: str = "nlid-daq", *, pace: float = 1.0,
                 faults: FaultSpec | None = None, **bus_kwargs) -> None:
        super().__init__(name="can-daq-emulator", daemon=True)
        if not pace > 0:
            raise DriverConfigError("the CAN emulator needs pace > 0 (1.0 = real time)")
        if len(channels) > 2 * proto.MAX_GROUPS:
            raise DriverConfigError(f"the CAN DAQ carries at most {2 * proto.MAX_GROUPS} "
                                    "channels")
        self.rig, self.wiring, self.pace = rig, list(channels), pace
        self.faults = FaultPlan.of(faults)
        self.bus = can.Bus(interface=interface, channel=channel, **bus_kwargs)
        db = proto.database()
        self._control = db.get_message_by_frame_id(proto.CONTROL_ID)
        self._status = db.get_message_by_frame_id(proto.STATUS_ID)
        self._groups = proto.n_groups(len(channels))
        self._counts_per_volt = 1.0 / proto.volt_scale()
        self._full = proto.full_scale_counts()
        self.streaming = False
        self.connected = True
        self.error: BaseException | None = None
        self.frames_sent = 0
        self.clipped = 0
        self._k = 0
        self._row = 0
        self._t0 = 0.0
        self._halt = threading.Event()
        self.sent: deque[tuple[int, int, float, np.ndarray]] = deque(maxlen=200000)

    def run(self) -> None:
        """Thread body: answer control messages and stream samples until closed or disconnected."""
        beat = threading.Thread(target=self._beat, name="can-daq-heartbeat", daemon=True)
        try:
            beat.start()
            while not self._halt.is_set() and self.connected:
                msg = self.bus.recv(0.0 if self.streaming else 0.01)
                if msg is not None and msg.arbitration_id == proto.CONTROL_ID:
                    self._on_control(msg)
                if self.streaming:
                    wait = self._tick()
                    if wait > 0:
                        time.sleep(min(wait, 0.002))
        except BaseException as exc:  # noqa: BLE001 - reported to the test via .error
            self.error = exc
        finally:
            self.connected = False
            beat.join()          # it sends on the bus: stopped before the bus is
            self.bus.shutdown()

    def _beat(self) -> None:
        """Heartbeat thread: a status frame every `HEARTBEAT` s while streaming (a thread of
        its own, so it keeps coming while `_tick` computes or waits for the CPU)."""
        data = self._status.encode({"State": proto.STATE_STREAMING, "ErrorCode": 0})
        while not self._halt.wait(HEARTBEAT) and self.connected:
            f = self.faults
            if self.streaming and not any(at and self._k >= at
                                          for at in (f.stall_at, f.disconnect_at)):
                self.bus.send(can.Message(arbitration_id=proto.STATUS_ID, data=data,
                                          is_extended_id=False))

    def _on_control(self, msg: can.Message) -> None:
        cmd = self._control.decode(msg.data, decode_choices=False)
        error = 0
        if cmd["Command"] == 1:
            if abs(cmd["RateHz"] - self.rig.fs) > 0.01:
                error = 1
            elif cmd["NumChannels"] != len(self.wiring):
                error = 2
            else:
                self.streaming, self._row, self._t0 = True, 0, time.monotonic()
        else:
            self.streaming = False
        state = proto.STATE_ERROR if error else (
            proto.STATE_STREAMING if self.streaming else proto.STATE_IDLE)
        data = self._status.encode({"State": state, "ErrorCode": error})
        self.bus.send(can.Message(arbitration_id=proto.STATUS_ID, data=data,
                                  is_extended_id=False))

    def _tick(self) -> float:
        now = time.monotonic()
        due = self._t0 + self._row / (self.rig.fs * self.pace)
        if now < due:
            return due - now
        samples = self.rig.advance(ROWS_PER_TICK)
        volts = samples.volts(self.wiring, self.rig.force_dofs)
        self.sent.append((self._row, self._row, now, np.abs(volts).max(axis=0)))
        counts = np.rint(volts * self._counts_per_volt)
        self.clipped += int(np.count_nonzero(np.abs(counts) > self._full))
        counts = np.clip(counts, -self._full, self._full).astype(np.int64)
        if counts.shape[1] % 2:
            counts = np.column_stack([counts, np.zeros(len(counts), np.int64)])
        for i in range(ROWS_PER_TICK):
            cnt = (self._row + i) % proto.COUNTER_MOD  # counts from stream start
            for g in range(self._groups):
                if not self._send_sample(cnt, g, counts[i, 2 * g], counts[i, 2 * g + 1]):
                    return 0.0
        self._row += ROWS_PER_TICK
        return 0.0

    def _send_sample(self, cnt: int, group: int, a: int, b: int) -> bool:
        """Send one sample frame through the fault plan; False once disconnected/stalled."""
        k = self._k
        self._k += 1
        stall = self.faults.stalled(k)
        if stall:
            self._halt.wait(min(stall, 3600.0))
            self._t0 += stall if stall != float("inf") else 0.0
        if self.faults.disconnect(k):
            self.connected = False
            return False
        # Hand-packed (little-endian 16 + 24 + 24 bits) for speed: this is the DBC layout
        # that `tests/drivers/test_drivers_can.py` checks against cantools' own encoder.
        data = struct.pack("<HI", cnt, (a & 0xFFFFFF) | ((b & 0xFF) << 24)) + \
            struct.pack("<H", (b >> 8) & 0xFFFF)
        msg = can.Message(arbitration_id=proto.SAMPLES_ID + group, data=data,
                          is_extended_id=False)
        junk = self.faults.garbage(k)
        if junk:
            self.bus.send(can.Message(arbitration_id=0x7FF, data=junk[:8], is_extended_id=False))
        if not self.faults.drop(k):
            self.bus.send(msg)
            self.frames_sent += 1
            if self.faults.duplicate(k):
                self.bus.send(msg)
        return True

    def close(self, timeout: float = 2.0) -> None:
        """Stop the thread (waiting up to ``timeout`` seconds) and release the bus."""
        self._halt.set()
        if self.is_alive():
            self.join(timeout)
        else:
            self.bus.shutdown()
