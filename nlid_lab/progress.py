"""Progress bars for long commands (tqdm on stderr), and a campaign's progress per level.

Bars show when stderr is a terminal; ``NLID_PROGRESS=1`` forces them on, ``0`` off.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Iterable, TextIO, TypeVar

from tqdm.auto import tqdm

from .campaign import CampaignStart, LevelStatus, LevelSummary

T = TypeVar("T")


def enabled() -> bool | None:
    """tqdm's ``disable`` argument for the current environment."""
    setting = os.environ.get("NLID_PROGRESS", "")
    if setting in ("0", "1"):
        return setting == "0"
    return None  # tqdm: disabled when stderr is not a terminal


def progress(iterable: Iterable[T] | None = None, *, total: float | None = None,
             desc: str | None = None, unit: str = "it", leave: bool = True) -> tqdm:
    """A tqdm bar over ``iterable`` (or a manual bar with ``total``; call ``.update(n)``)."""
    return tqdm(iterable, total=total, desc=desc, unit=unit, leave=leave,
                disable=enabled(), dynamic_ncols=True)


class CampaignProgress:
    """Campaign observer for a terminal: one bar per level while it runs (blocks done/total,
    last block's force against the target, drive, control error, campaign time left) and one
    summary line per level when it ends. Without a terminal (logs) only the summary lines
    are printed."""

    def __init__(self, file: TextIO | None = None) -> None:
        self.file = file or sys.stderr
        self.bar: tqdm | None = None
        self.n_levels = 0
        self.remaining = 0
        self.stored_here = 0
        self.t0 = time.monotonic()

    def campaign_started(self, info: CampaignStart) -> None:
        """Count the blocks or steps still to store."""
        self.n_levels = len(info.levels)
        self.remaining = sum(max(info.planned - n, 0) for n in info.stored)
        self.unit = info.unit
        self.t0 = time.monotonic()

    def level_progress(self, s: LevelStatus) -> None:
        """Update the level's bar: blocks done, force against the target, drive, time left."""
        if self.bar is None:
            self.bar = tqdm(total=s.planned, initial=s.done, unit=self.unit, leave=False,
                            desc=f"level {s.level + 1}/{self.n_levels} ({s.target:g} N "
                                 f"{'amplitude' if self.unit == 'step' else 'rms'})",
                            disable=enabled(), dynamic_ncols=True, file=self.file,
                            bar_format="{desc}: {n_fmt}/{total_fmt} {unit}s{postfix} |{bar}|")
        if s.measured is None:
            self.bar.set_postfix_str("level control", refresh=True)
            return
        self.stored_here += 1
        self.remaining -= 1
        left = (time.monotonic() - self.t0) / self.stored_here * self.remaining
        self.bar.set_postfix_str(
            f"force {s.measured:.4g}/{s.target:g} N ({s.control_error:+.1%}), drive "
            f"{s.drive:.3g} V, ~{tqdm.format_interval(left)} left", refresh=False)
        self.bar.update(s.done - self.bar.n)

    def level_finished(self, summary: LevelSummary) -> None:
        """Close the bar and print the level's summary line."""
        self._close()
        print(summary.line(self.n_levels), file=self.file, flush=True)

    def campaign_finished(self, status: str) -> None:
        """Close the bar."""
        self._close()

    def _close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
