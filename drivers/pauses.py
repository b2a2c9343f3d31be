"""How long this process was paused within a time window (its threads not running), so that
a stall check does not blame a device for silence this process caused: the emulators run in
it, and on an oversubscribed machine the kernel preempts the thread holding the interpreter
lock, stopping every thread for tens of milliseconds (docs/reliability-inputs.md).

A daemon thread ticks every `TICK` s; a tick later than `3 TICK` is a pause. Hand-written:
no library measures a process's own scheduling pauses.
"""

from __future__ import annotations

import threading
import time
from collections import deque

TICK = 0.005
_pauses: deque[tuple[float, float]] = deque(maxlen=1024)   # (last tick, late tick)
_last = [time.monotonic()]
_lock = threading.Lock()
_thread: list[threading.Thread] = []


def _ticker() -> None:
    while True:
        time.sleep(TICK)
        now = time.monotonic()
        if now - _last[0] > 3 * TICK:
            _pauses.append((_last[0], now))
        _last[0] = now


def start() -> None:
    """Start the ticker (once per process)."""
    with _lock:
        if not _thread:
            _last[0] = time.monotonic()
            _thread.append(threading.Thread(target=_ticker, name="pause-meter", daemon=True))
            _thread[0].start()


def paused(t0: float, t1: float) -> float:
    """Seconds of [``t0``, ``t1``] (monotonic) this process was paused, as its ticker saw:
    the pauses it recorded, and the one it is in if it has not ticked for `3 TICK`."""
    spans = list(_pauses)
    last = _last[0]
    if t1 - last > 3 * TICK:
        spans.append((last, t1))
    return sum(max(min(b, t1) - max(a + TICK, t0), 0.0) for a, b in spans)
