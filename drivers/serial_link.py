"""Line-oriented command link over pyserial, shared by the serial shaker and serial DAQ.

Every command is one ASCII line ending in ``\\n``; the device answers one line: ``OK``, a
value for a query, or ``ERR <code>,"<text>"``. pyserial exceptions become `Disconnected`.
Commands are serialised by a lock, so a background thread (the shaker's watchdog feeder) may
share the link with the caller.
"""

from __future__ import annotations

import select
import threading
import time

import serial

from .errors import DeviceError, Disconnected, DriverConfigError, DriverTimeout


class SerialLink:
    """An open serial port with timed line commands and raw reads."""

    def __init__(self, port: str, baud: int = 115200, *, what: str = "device") -> None:
        self.what = what
        self.port = port
        self._left = b""  # bytes read past a reply line, handed out by the next read
        self.lock = threading.Lock()
        self.last_command = 0.0  # monotonic time the last command was sent
        self._owed: list[float] = []    # send times of lines sent without waiting (`post`)
        self.owed_error: str | None = None  # an ERR reply one of them got
        try:
            self.ser = serial.serial_for_url(port, baudrate=baud, timeout=0.0)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DriverConfigError(f"cannot open {what} port {port}: {exc}; check the port "
                                    "name and that nothing else holds it") from None
        try:
            self._fd: int | None = self.ser.fileno()
        except (AttributeError, OSError, ValueError, serial.SerialException):
            self._fd = None

    def fileno(self) -> int | None:
        """The port's descriptor (None for a port without one)."""
        return self._fd

    def write(self, data: bytes) -> None:
        """Write and flush ``data``.

        Raises
        ------
        Disconnected
            The port went away.
        """
        try:
            self.ser.write(data)
            self.ser.flush()
        except (serial.SerialException, OSError) as exc:
            raise Disconnected(f"{self.what} on {self.port} went away while writing: "
                               f"{exc}") from None

    def read_some(self, timeout: float, size: int = 65536) -> bytes:
        """Return what arrives within ``timeout`` (b"" if nothing)."""
        if self._left:
            data, self._left = self._left, b""
            return data
        try:
            # Wait with select and read without blocking: pyserial's own timeout costs two
            # port reconfigurations (tcsetattr) per read, each a GIL hand-off that a thread
            # computing in Python makes wait up to 5 ms; the port stays at timeout 0.
            if self._fd is not None:
                waiting = self.ser.in_waiting
                if not waiting and timeout > 0:
                    if not select.select([self._fd], [], [], timeout)[0]:
                        return b""
                    waiting = self.ser.in_waiting
                    if not waiting:   # ready without data: pyserial raises "disconnected"
                        return self.ser.read(1)
                return self.ser.read(min(waiting, size)) if waiting else b""
            self.ser.timeout = max(timeout, 0.0)     # a port without a descriptor
            first = self.ser.read(1)
            if not first:
                return b""
            waiting = self.ser.in_waiting
            self.ser.timeout = 0
            return first + (self.ser.read(min(waiting, size)) if waiting else b"")
        except (serial.SerialException, OSError, ValueError) as exc:
            raise Disconnected(f"{self.what} on {self.port} went away: {exc}") from None

    def command(self, line: str, timeout: float) -> str:
        """Send one command line and return the reply line (``ERR`` raises)."""
        if not self.lock.acquire(timeout=max(timeout, 0.0)):
            raise DriverTimeout(f"{self.what} on {self.port} busy: could not send '{line}' "
                                f"within {timeout:g} s")
        try:
            return self._command(line, timeout)
        finally:
            self.lock.release()

    def post(self, line: str) -> None:
        """Send one command line without waiting for its reply (the caller holds `lock`): the
        reply is collected by `collect` or before the next `command`, replies coming in order.
        Not drained (``tcdrain`` would wait until the far end has read it)."""
        try:
            self.ser.write(line.encode("ascii") + b"\n")
        except (serial.SerialException, OSError) as exc:
            raise Disconnected(f"{self.what} on {self.port} went away while writing: "
                               f"{exc}") from None
        self.last_command = time.monotonic()
        self._owed.append(self.last_command)

    def collect(self, timeout: float = 0.0) -> float:
        """Read the replies owed to `post` that arrive within ``timeout`` (the caller holds
        `lock`); an ``ERR`` one is kept in ``owed_error``. Returns the age (s) of the oldest
        reply still owed, 0 if none."""
        if not timeout and not self._left and self._fd is not None and self._owed:
            try:
                if not self.ser.in_waiting:      # one ioctl: nothing came yet
                    return time.monotonic() - self._owed[0]
            except (serial.SerialException, OSError) as exc:
                raise Disconnected(f"{self.what} on {self.port} went away: {exc}") from None
        deadline = time.monotonic() + timeout
        buf, self._left = self._left, b""
        while self._owed:
            if b"\n" not in buf:
                data = self.read_some(max(deadline - time.monotonic(), 0.0), 256)
                if not data:
                    self._left = buf
                    return time.monotonic() - self._owed[0]
                buf += data
                continue
            raw, _, buf = buf.partition(b"\n")
            self._owed.pop(0)
            reply = raw.decode("ascii", "replace").strip()
            if reply.startswith("ERR") and self.owed_error is None:
                self.owed_error = reply[3:].strip()
        self._left = buf
        return 0.0

    def forget_owed(self) -> None:
        """Expect no more replies to posted lines (the link lost them; the caller holds
        `lock`)."""
        self._owed.clear()

    def _command(self, line: str, timeout: float) -> str:
        if not (self._owed and self.collect()):  # replies owed to posted lines all came:
            self._discard_input()  # a late reply to a timed-out command must not answer this
        self.write(line.encode("ascii") + b"\n")   # at once, even with replies owed (ABOR)
        self.last_command = time.monotonic()
        deadline = self.last_command + timeout
        if self._owed and self.collect(timeout):    # they come before this one's, in order
            raise DriverTimeout(f"{self.what} on {self.port} did not answer '{line}' "
                                f"within {timeout:g} s")
        buf = b""
        while b"\n" not in buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise DriverTimeout(f"{self.what} on {self.port} did not answer '{line}' "
                                    f"within {timeout:g} s")
            buf += self.read_some(min(left, 0.05), 256)
        raw, _, self._left = buf.partition(b"\n")
        reply = raw.decode("ascii", "replace").strip()
        if reply.startswith("ERR"):
            raise DeviceError(f"{self.what} rejected '{line}': {reply[3:].strip()}")
        return reply

    def _discard_input(self) -> None:
        self._left = b""
        try:
            self.ser.reset_input_buffer()
        except (serial.SerialException, OSError) as exc:
            raise Disconnected(f"{self.what} on {self.port} went away: {exc}") from None

    def drain_until(self, marker: bytes, timeout: float) -> None:
        """Discard input until it ends with ``marker`` (e.g. the reply after a stream)."""
        deadline = time.monotonic() + timeout
        tail = b""
        while not tail.endswith(marker):
            left = deadline - time.monotonic()
            if left <= 0:
                raise DriverTimeout(f"{self.what} on {self.port} did not confirm within "
                                    f"{timeout:g} s")
            tail = (tail + self.read_some(min(left, 0.05)))[-64:]

    def close(self) -> None:
        """Close the port (errors on closing are ignored)."""
        try:
            self.ser.close()
        except (serial.SerialException, OSError):
            pass
