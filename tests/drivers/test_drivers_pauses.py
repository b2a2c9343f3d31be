"""A stall check does not blame the device for this process's own pauses (issue 26): the
pause meter's arithmetic, and `wait_for_data` looking once more (docs/drivers.md)."""

from __future__ import annotations

import time

from drivers import pauses
from drivers.base import LATE_GRACE, wait_for_data


def test_paused_counts_the_part_of_each_pause_inside_the_window(monkeypatch):
    now = time.monotonic()
    monkeypatch.setattr(pauses, "_pauses", [(now - 1.0, now - 0.9), (now - 0.5, now - 0.3)])
    monkeypatch.setattr(pauses, "_last", [now])
    tick = pauses.TICK
    assert abs(pauses.paused(now - 2, now) - (0.1 - tick + 0.2 - tick)) < 1e-9
    assert abs(pauses.paused(now - 0.4, now) - 0.1) < 1e-9       # the second, in part
    assert pauses.paused(now - 0.2, now) == 0.0
    # the ticker silent for 50 ms up to now: a pause it is in
    monkeypatch.setattr(pauses, "_last", [now - 0.05])
    assert abs(pauses.paused(now - 0.2, now) - (0.05 - tick)) < 1e-9


def test_wait_for_data_looks_once_more_and_waits_out_its_own_lateness():
    asked = []

    def wait(seconds):
        asked.append(seconds)
        if len(asked) == 1:
            time.sleep(seconds + 0.05)   # this thread comes back 50 ms late
            return b""
        return b"late data"

    assert wait_for_data(wait, 0.01) == b"late data"
    assert asked[0] == 0.01 and asked[1] == LATE_GRACE   # 50 ms late: the grace, capped


def test_wait_for_data_returns_what_the_first_wait_got():
    assert wait_for_data(lambda s: b"x", 0.01) == b"x"
