"""``can://INTERFACE/CHANNEL`` DAQ: sample frames decoded with cantools from ``nlid_daq.dbc``.

Works on any python-can interface (``virtual``, ``socketcan``, ``pcan``...). A 16-bit
per-sample counter in every frame detects lost, duplicated and out-of-order frames; a sample
row is delivered only when every channel group of it arrived.
"""

from __future__ import annotations

import time

import can
import numpy as np

from . import can_protocol as proto
from .base import (DeviceState, Acquirer, Block, Channel, STALL_MARGIN, check_stall_timeout,
                   default_stall_timeout, wait_for_data)
from .errors import DeviceError, Disconnected, DriverConfigError, DriverTimeout


class CanDaq(Acquirer):
    """DAQ on a python-can bus.

    Parameters
    ----------
    interface, channel : str
        python-can interface name and channel.
    stall_timeout : float, optional
        Seconds without a sample frame after which the stream counts as stalled; default: one
        sample interval (a frame carries one sample row) plus `drivers.base.STALL_MARGIN`.
    **bus_kwargs
        Passed to `can.Bus` (``bitrate``, ``fd``...).
    """

    def __init__(self, interface: str, channel: str, *, stall_timeout: float | None = None,
                 **bus_kwargs) -> None:
        super().__init__()
        self._stall_given = check_stall_timeout(stall_timeout)
        try:
            self.bus = can.Bus(interface=interface, channel=channel, **bus_kwargs)
        except (can.CanError, ImportError, OSError, ValueError, TypeError) as exc:
            raise DriverConfigError(f"cannot open CAN interface '{interface}' channel "
                                    f"'{channel}': {exc}") from None
        self.stall_timeout = self._stall_given or STALL_MARGIN  # set again by configure
        self.frame_size = 64
        self._db = proto.database()
        self._decode = {proto.SAMPLES_ID + g: self._db.get_message_by_frame_id(
            proto.SAMPLES_ID + g).decode for g in range(proto.MAX_GROUPS)}
        self._status = self._db.get_message_by_frame_id(proto.STATUS_ID)
        self._scale = np.ones(1)
        self._reset_stream()

    def _reset_stream(self) -> None:
        self._rows: list[np.ndarray] = []
        self._row_abs: list[int] = []
        self._cur_cnt: int | None = None
        self._cur_abs = 0
        self._cur = np.zeros(0)
        self._filled = np.zeros(0, bool)
        self._seen_next = 0       # absolute index after the last row started
        self._emit_next = 0       # absolute index after the last row delivered
        self._held: tuple[int, np.ndarray] | None = None
        self._last_end = 0        # absolute index after the last block returned

    def configure(self, fs: float, channels: list[Channel], *, frame_size: int = 64,
                  timeout: float = 1.0) -> None:
        """Set sample rate, channels and frame size on the CAN DAQ (`Acquirer.configure`)."""
        self._require(DeviceState.NEW, DeviceState.CONFIGURED, DeviceState.STOPPED,
                      action="configure")
        self.check_config(fs, channels, frame_size)
        if len(channels) > 2 * proto.MAX_GROUPS:
            raise DriverConfigError(f"the CAN DAQ carries at most {2 * proto.MAX_GROUPS} "
                                    f"channels, got {len(channels)}")
        self.fs, self.channels, self.frame_size = float(fs), tuple(channels), frame_size
        self.stall_timeout = self._stall_given or default_stall_timeout(1.0 / self.fs)
        self._groups = proto.n_groups(len(channels))
        self._scale = proto.volt_scale() / np.array([c.sensitivity for c in channels])
        self._state = DeviceState.CONFIGURED

    def _control(self, command: int, timeout: float) -> None:
        msg = self._db.get_message_by_frame_id(proto.CONTROL_ID)
        data = msg.encode({"Command": command, "NumChannels": len(self.channels),
                           "RateHz": self.fs})
        want = proto.STATE_STREAMING if command else proto.STATE_IDLE
        self._send(can.Message(arbitration_id=proto.CONTROL_ID, data=data,
                               is_extended_id=False))
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            reply = self._recv(left)
            if reply is None or reply.arbitration_id != proto.STATUS_ID:
                continue
            status = self._status.decode(reply.data, decode_choices=False)
            if status["State"] == proto.STATE_ERROR:
                raise DeviceError(f"CAN DAQ refused the configuration (error code "
                                  f"{status['ErrorCode']}: 1 = rate, 2 = channel count)")
            if status["State"] == want:
                return
        raise DriverTimeout(f"CAN DAQ did not confirm {'start' if command else 'stop'} "
                            f"within {timeout:g} s")

    def _send(self, msg: can.Message) -> None:
        try:
            self.bus.send(msg, timeout=0.1)
        except can.CanError as exc:
            raise Disconnected(f"CAN send failed: {exc}") from None

    def _recv(self, timeout: float) -> can.Message | None:
        try:
            return self.bus.recv(timeout)
        except (can.CanError, OSError, ValueError) as exc:
            raise Disconnected(f"CAN bus went away: {exc}") from None

    def start(self, *, timeout: float = 1.0) -> None:
        """Start streaming sample frames (`Acquirer.start`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.STOPPED, action="start")
        self._reset_stream()
        self._cur = np.zeros(2 * self._groups)
        self._filled = np.zeros(self._groups, bool)
        self._control(1, timeout)
        self._state = DeviceState.RUNNING

    def read(self, timeout: float = 1.0) -> Block:
        """The next block of samples from the bus, gaps counted (`Acquirer.read`)."""
        self._require(DeviceState.RUNNING, action="read")
        deadline = time.monotonic() + timeout
        if self._held is not None:
            self._deliver(*self._held)
            self._held = None
        while len(self._rows) < self.frame_size and self._held is None:
            left = deadline - time.monotonic()
            if left <= 0:
                raise DriverTimeout(f"no CAN sample block within {timeout:g} s")
            msg = wait_for_data(self._recv, min(left, self.stall_timeout))
            if msg is None:
                if left > self.stall_timeout:
                    raise DriverTimeout(f"CAN DAQ stream stalled: no frame for "
                                        f"{self.stall_timeout:g} s")
                continue
            if msg.arbitration_id == proto.STATUS_ID and not msg.is_extended_id:
                continue        # a status frame while streaming: a heartbeat, the DAQ is alive
            group = msg.arbitration_id - proto.SAMPLES_ID
            if not 0 <= group < self._groups or msg.is_extended_id:
                self.stats.garbage_bytes += len(msg.data)
                continue
            self._frame(group, msg.data)
        return self._block()

    def _frame(self, group: int, data: bytes) -> None:
        raw = self._decode[proto.SAMPLES_ID + group](data, scaling=False)
        cnt = raw["Counter"]
        if self._cur_cnt is None:
            delta = (cnt - self._seen_next) % proto.COUNTER_MOD
            if delta >= proto.COUNTER_MOD // 2:
                self.stats.duplicate_frames += 1
                return
            self._begin(self._seen_next + delta, cnt)
        elif cnt != self._cur_cnt:
            delta = (cnt - self._cur_cnt) % proto.COUNTER_MOD
            if delta >= proto.COUNTER_MOD // 2:
                self.stats.duplicate_frames += 1
                return
            self.stats.lost_frames += int(self._groups - self._filled.sum())  # partial row
            self._begin(self._cur_abs + delta, cnt)
        elif self._filled[group]:
            self.stats.duplicate_frames += 1
            return
        self.stats.frames += 1
        self._filled[group] = True
        self._cur[2 * group] = raw[f"Ch{2 * group}"]
        self._cur[2 * group + 1] = raw[f"Ch{2 * group + 1}"]
        if self._filled.all():
            row = self._cur[: len(self.channels)] * self._scale
            self._cur_cnt = None
            if self._rows and self._cur_abs != self._emit_next:
                self._held = (self._cur_abs, row)   # gap: close the current block first
            else:
                self._deliver(self._cur_abs, row)

    def _begin(self, abs_index: int, cnt: int) -> None:
        self.stats.lost_frames += (abs_index - self._seen_next) * self._groups
        self._seen_next = abs_index + 1
        self._cur_cnt, self._cur_abs = cnt, abs_index
        self._filled[:] = False

    def _deliver(self, abs_index: int, row: np.ndarray) -> None:
        self.stats.lost_samples += abs_index - self._emit_next
        self._emit_next = abs_index + 1
        self._rows.append(row)
        self._row_abs.append(abs_index)
        self.stats.samples += 1

    def _block(self) -> Block:
        first = self._row_abs[0]
        gap = first - self._last_end
        data = np.vstack(self._rows)
        self._last_end = self._row_abs[-1] + 1
        self._rows, self._row_abs = [], []
        return Block(first % proto.COUNTER_MOD, first, first / self.fs, data, gap)

    def stop(self, *, timeout: float = 1.0) -> None:
        """Stop streaming; nothing if not running (`Acquirer.stop`)."""
        if self._state != DeviceState.RUNNING:
            return
        self._state = DeviceState.STOPPED
        self._control(0, timeout)

    def _release(self) -> None:
        self.bus.shutdown()
