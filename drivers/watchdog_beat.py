"""The shaker link watchdog's heartbeat, sent by a small process of its own.

Threads of the host process share its interpreter lock: on a loaded machine a thread
computing (an emulated plant, analysis, a live view) is preempted by the kernel while it
holds that lock, and every other thread of the process waits with it, 50-120 ms at a time
(measured on 2 cores at load 13; docs/reliability-inputs.md). A feeder thread there left
gaps over the 80 ms watchdog period: false trips. This process only sleeps and writes one
line (``SYST:WDOG:BEAT``, which the controller takes without a reply, so it never mixes with
the host's replies); a sleeper woken by the kernel runs within milliseconds even on a busy
machine. It writes on the host's own open port (an inherited descriptor) and stops when the
host closes its pipe or dies (even by SIGKILL: the pipe closes with it), so the controller
then zeroes the drive as before.
"""

from __future__ import annotations

import select
import subprocess
import sys

from .errors import DriverTimeout

BEAT = b"SYST:WDOG:BEAT\n"

#: run by ``python -I -S -c``: nothing imported but the standard library's built-ins
_CHILD = """
import os, select, sys
fd, period = int(sys.argv[1]), float(sys.argv[2])
os.write(1, b"up")                                 # the host waits for this
line = rest = %r
while not select.select([0], [], [], period)[0]:   # the host's pipe: EOF or a byte = stop
    try:
        rest = rest[os.write(fd, rest):] or line    # a line cut short is finished first
    except BlockingIOError:      # the line is full (the port is non-blocking): next period
        pass
    except OSError:                               # the port went away
        break
""" % BEAT


class BeatProcess:
    """A child process writing `BEAT` on descriptor ``fd`` every ``period`` seconds until
    `stop` (or the host's death)."""

    def __init__(self, fd: int, period: float, timeout: float = 10.0) -> None:
        self.proc = subprocess.Popen([sys.executable, "-I", "-S", "-c", _CHILD, str(fd),
                                      f"{period:.6g}"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, pass_fds=(fd,), close_fds=True)
        # beating once it returns (an interpreter starts in 30-100 ms on a loaded machine:
        # the watchdog is armed after this)
        ready = select.select([self.proc.stdout], [], [], timeout)[0]
        up = ready and self.proc.stdout.read(2) == b"up"
        self.proc.stdout.close()
        if not up:
            self.stop()
            raise DriverTimeout(f"the shaker watchdog's beat process did not start within "
                                f"{timeout:g} s")

    def alive(self) -> bool:
        """Whether it still beats."""
        return self.proc.poll() is None

    def stop(self, timeout: float = 1.0) -> None:
        """Stop it (closing its pipe) and wait for it."""
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
