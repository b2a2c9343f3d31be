"""``serial://`` streaming DAQ: text commands, then binary frames (see `drivers.frame`)."""

from __future__ import annotations

import time
from collections import deque

import numpy as np

from .base import (DeviceState, Acquirer, Block, Channel, STALL_MARGIN, check_stall_timeout,
                   default_stall_timeout, wait_for_data)
from .errors import DriverTimeout, ProtocolError
from .frame import Frame, FrameParser
from .serial_link import SerialLink


class SerialDaq(Acquirer):
    """DAQ streaming binary frames on a serial port.

    Parameters
    ----------
    port : str
        Device path or pyserial URL.
    baud : int
        Baud rate (ignored by pseudo-terminals).
    stall_timeout : float, optional
        Seconds without any byte after which the stream counts as stalled (`DriverTimeout`),
        whatever the ``timeout`` given to `read`; default: one frame interval plus
        `drivers.base.STALL_MARGIN` (set at `configure`).
    """

    def __init__(self, port: str, baud: int = 115200, *,
                 stall_timeout: float | None = None) -> None:
        super().__init__()
        self._stall_given = check_stall_timeout(stall_timeout)
        self.link = SerialLink(port, baud, what="DAQ")
        self.stall_timeout = self._stall_given or STALL_MARGIN  # set again by configure
        self.frame_size = 64
        self._parser = FrameParser()
        self._pending: deque[Frame] = deque()
        self._next_seq = 0
        self._next_sample = 0
        self._scale = np.ones(1)
        self.idn = self.link.command("*IDN?", 1.0)

    def configure(self, fs: float, channels: list[Channel], *, frame_size: int = 64,
                  timeout: float = 1.0) -> None:
        """Send sample rate, channel count and frame size to the DAQ (`Acquirer.configure`)."""
        self._require(DeviceState.NEW, DeviceState.CONFIGURED, DeviceState.STOPPED,
                      action="configure")
        self.check_config(fs, channels, frame_size)
        for cmd in (f"CONF:RATE {fs:.12g}", f"CONF:CHAN:COUN {len(channels)}",
                    f"CONF:FRAM {frame_size}"):
            self.link.command(cmd, timeout)
        self.fs, self.channels, self.frame_size = float(fs), tuple(channels), frame_size
        self.stall_timeout = self._stall_given or default_stall_timeout(frame_size / self.fs)
        self._scale = 1.0 / np.array([c.sensitivity for c in channels])
        self._state = DeviceState.CONFIGURED

    def start(self, *, timeout: float = 1.0) -> None:
        """Start streaming frames (`Acquirer.start`)."""
        self._require(DeviceState.CONFIGURED, DeviceState.STOPPED, action="start")
        self.link.command("INIT", timeout)
        self._parser = FrameParser()
        self._pending.clear()
        self._next_seq, self._next_sample = 0, 0
        self._state = DeviceState.RUNNING

    def read(self, timeout: float = 1.0) -> Block:
        """The next block of samples, gaps counted (`Acquirer.read`)."""
        self._require(DeviceState.RUNNING, action="read")
        deadline = time.monotonic() + timeout
        while True:
            while self._pending:
                block = self._accept(self._pending.popleft())
                if block is not None:
                    return block
            left = deadline - time.monotonic()
            if left <= 0:
                raise DriverTimeout(f"no DAQ frame within {timeout:g} s")
            data = wait_for_data(self.link.read_some, min(left, self.stall_timeout))
            if not data:
                if left > self.stall_timeout:
                    raise DriverTimeout(f"DAQ stream stalled: no data for "
                                        f"{self.stall_timeout:g} s")
                continue
            self._pending.extend(self._parser.feed(data))
            self.stats.garbage_bytes = self._parser.garbage_bytes
            self.stats.bad_frames = self._parser.bad_frames

    def _accept(self, frame: Frame) -> Block | None:
        """Check sequence and size; count losses and duplicates; convert to units. A frame of
        no samples is a heartbeat: it kept the stream from counting as stalled, no more."""
        if not frame.volts.shape[0]:
            return None
        if frame.volts.shape[1] != len(self.channels):
            raise ProtocolError(f"DAQ sent {frame.volts.shape[1]} channels, configured "
                                f"{len(self.channels)}")
        ahead = (frame.seq - self._next_seq) & 0xFFFFFFFF
        if ahead >= 0x80000000 or frame.first_sample < self._next_sample:
            self.stats.duplicate_frames += 1
            return None
        gap = frame.first_sample - self._next_sample
        self.stats.lost_frames += ahead
        self.stats.lost_samples += gap
        n = frame.volts.shape[0]
        self.stats.frames += 1
        self.stats.samples += n
        self._next_seq = (frame.seq + 1) & 0xFFFFFFFF
        self._next_sample = frame.first_sample + n
        data = frame.volts.astype(float) * self._scale
        return Block(frame.seq, frame.first_sample, frame.first_sample / self.fs, data, gap)

    def stop(self, *, timeout: float = 1.0) -> None:
        """Stop streaming; nothing if not running (`Acquirer.stop`)."""
        if self._state != DeviceState.RUNNING:
            return
        self._state = DeviceState.STOPPED
        self.link.write(b"ABOR\n")
        self.link.drain_until(b"OK\n", timeout)

    def _release(self) -> None:
        self.link.close()
