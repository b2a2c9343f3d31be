"""A line-command server on a real pseudo-terminal, run in a thread.

Hand-written on `os.openpty` + `select` because the emulators must sit on the *master* end of
a real pty (the production driver opens the slave path with pyserial); no library serves that.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty

OUT_CAP = 1 << 16  # bytes queued before the producer waits (keeps latency bounded)


def short_form(header: str) -> str:
    """SCPI short form of a command header: ``SOURce:FREQuency?`` -> ``SOUR:FREQ?``."""
    query = header.endswith("?")
    nodes = []
    for node in header.rstrip("?").upper().split(":"):
        if len(node) > 4:
            node = node[:3] if node[3] in "AEIOU" else node[:4]
        nodes.append(node)
    return ":".join(nodes) + ("?" if query else "")


class PtyServer(threading.Thread):
    """Serves ``handle(line) -> reply`` on a pty; subclasses may stream from `tick`."""

    def __init__(self, name: str) -> None:
        super().__init__(name=name, daemon=True)
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        os.set_blocking(self.master, False)
        self._inbuf = bytearray()
        self.out = bytearray()
        self._write_lock = threading.Lock()   # the loop and a heartbeat thread both write
        self.written_at = time.monotonic()    # when bytes last went out
        self._halt = threading.Event()
        self.connected = True
        self.error: BaseException | None = None

    # --- for subclasses ----------------------------------------------------------------
    def handle(self, line: str) -> str | None:
        """Answer one command line; None: no answer (subclasses implement it).

        Parameters
        ----------
        line : str
            The line received, without its terminator.

        Returns
        -------
        str or None
        """
        raise NotImplementedError

    def tick(self) -> float:
        """Produce a little output (a few ms of work); return the seconds until more is due
        (0: call again at once, inf: idle)."""
        return float("inf")

    #: s between heartbeats when nothing else went out (0: none; see `heartbeat`)
    HEARTBEAT = 0.0

    def heartbeat(self) -> bytes:
        """What to send when nothing went out for `HEARTBEAT` s (b"": nothing now). Sent by
        a thread of its own, so it keeps coming while `tick` computes or waits for the CPU,
        and stops when the device stalls or disconnects."""
        return b""

    # --- loop --------------------------------------------------------------------------
    def run(self) -> None:
        """Thread body: read lines, answer them (`handle`) and send output (`tick`) until closed."""
        beat = threading.Thread(target=self._beat, name=f"{self.name}-heartbeat",
                                daemon=True) if self.HEARTBEAT else None
        try:
            if beat is not None:
                beat.start()
            wait = 0.0
            while not self._halt.is_set() and self.connected:
                wlist = [self.master] if self.out else []
                r, w, _ = select.select([self.master], wlist, [], min(max(wait, 0.0), 0.02))
                if w:
                    self._write()
                if r:
                    self._read()
                wait = self.tick()
        except BaseException as exc:  # noqa: BLE001 - reported to the test via .error
            self.error = exc
        finally:
            self.connected = False
            if beat is not None:
                beat.join()      # never write to a closed (maybe reused) descriptor
            self._close_fds()

    def _beat(self) -> None:
        """Heartbeat thread: `heartbeat` bytes whenever nothing went out for `HEARTBEAT` s,
        at frame boundaries only (never inside output the loop queued)."""
        while not self._halt.is_set() and self.connected:
            due = self.written_at + self.HEARTBEAT - time.monotonic()
            if due > 0:
                self._halt.wait(due)
                continue
            with self._write_lock:  # decided and queued at once: never after a last reply
                data = self.heartbeat()
                if data and not self.out:
                    self.out += data
            if self.out:
                try:
                    self._write()
                except OSError:      # the line went down: the loop ends the server
                    return
            if time.monotonic() - self.written_at >= self.HEARTBEAT:  # idle, or line full
                self._halt.wait(self.HEARTBEAT if not data else self.HEARTBEAT / 4)

    def _read(self) -> None:
        try:
            data = os.read(self.master, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # EIO: no process has the slave open any more
            time.sleep(0.005)
            return
        self._inbuf += data
        while b"\n" in self._inbuf:
            raw, _, rest = self._inbuf.partition(b"\n")
            self._inbuf = bytearray(rest)
            line = raw.decode("ascii", "replace").strip()
            if line:
                reply = self.handle(line)
                if reply is not None:
                    self.out += reply.encode("ascii") + b"\n"

    def _write(self) -> None:
        with self._write_lock:     # a copy: `out` may grow in another thread meanwhile
            try:
                n = os.write(self.master, bytes(self.out))
            except (BlockingIOError, InterruptedError):
                return
            del self.out[:n]
            self.written_at = time.monotonic()

    def flush_out(self, timeout: float = 1.0) -> None:
        """Write everything queued (used before a deliberate disconnect)."""
        deadline = time.monotonic() + timeout
        while self.out and time.monotonic() < deadline:
            select.select([], [self.master], [], 0.01)
            self._write()

    def disconnect(self) -> None:
        """Drop the line, as if the cable were pulled."""
        self.connected = False

    def _close_fds(self) -> None:
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass

    def close(self, timeout: float = 2.0) -> None:
        """Stop the thread (waiting up to ``timeout`` seconds) and close the pseudo-terminal."""
        self._halt.set()
        if self.is_alive():
            self.join(timeout)
        else:
            self._close_fds()
