"""Swept-sine campaigns ([sweep]): one level per (force amplitude, direction). Per level, hold
the force amplitude with a sine at the sweep's start frequency, then play the sweep once and
store it as one block with its sweep keys.

The level control runs on a steady sine (a sweep never settles); the drive it finds is held
through the sweep, so the force amplitude varies where the structure loads the shaker, as a
real open-loop sweep does. The record starts `SweepSpec.lead_s` before the output turns on;
the samples before the sweep's first one are dropped, so the stored record starts with the
sweep (its law, as generated, is stored with it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from analysis.documents import JsonObject, TomlTable
from analysis.errors import RecordingError
from analysis.recordings import Excitation, Sweep, SweepLaw
from analysis.spectral import sine_fit
from drivers import Channel
from drivers.outputs import SineOutput, SweepOutput

from .._campaign_fields import DIRECTIONS, CampaignError, _levels, _num, _opt, _table, _unknown
from .._observer import PlanInfo
from .._plans import LevelPlan, Runner, register_plan

#: the sweep starts where the force first exceeds this fraction of its peak
ONSET_FRACTION = 0.01


@register_plan
@dataclass
class SweepSpec(LevelPlan):
    """Swept-sine plan: one level per (force amplitude, direction), amplitudes in order."""

    levels: list[float]           # force amplitude of each level, N
    laws: list                    # analysis.sweep_law.SweepLaw of each level
    block_size: int = 1024        # samples per level-control block (a sine at the start)
    tolerance: float = 0.02
    max_control_iterations: int = 8
    lead_s: float = 0.5           # recorded before the sweep starts (trimmed when stored)

    kind = excitation = Excitation.SWEPT_SINE
    table = "sweep"
    measure = "amplitude"

    @classmethod
    def from_table(cls, data: TomlTable, fs: float) -> "SweepSpec":
        """The [sweep] table: levels (force amplitudes), start, stop, law, rate, direction."""
        t = _table(data, "sweep")
        _unknown(t, {"levels", "start", "stop", "law", "rate", "direction", "block_size",
                     "tolerance", "max_control_iterations", "lead"}, "sweep")
        start = _num(t, "start", "sweep", lo=0.0, open_lo=True)
        stop = _num(t, "stop", "sweep", lo=0.0, open_lo=True)
        if not start < stop < fs / 2:
            raise CampaignError(f"[sweep] need 0 < start < stop < fs/2 = {fs / 2:g} Hz "
                                f"(direction says which way), got {start:g}, {stop:g}")
        law = t.get("law", "linear")
        direction = t.get("direction", "up")
        if direction not in DIRECTIONS:
            raise CampaignError(f"[sweep] direction must be one of {', '.join(DIRECTIONS)}, "
                                f"got {direction!r}")
        try:
            up = SweepLaw(start, stop, law, _num(t, "rate", "sweep", lo=0.0, open_lo=True))
        except RecordingError as exc:
            raise CampaignError(f"[sweep] {exc}") from None
        down = SweepLaw(stop, start, up.law, up.rate)
        ways = {"up": [up], "down": [down], "up-down": [up, down]}[direction]
        amps = _levels(t, "sweep")
        return cls([a for a in amps for _ in ways], [w for _ in amps for w in ways],
                   _opt(t, "block_size", "sweep", cls, lo=16, hi=2**22, integer=True),
                   _opt(t, "tolerance", "sweep", cls, lo=0, open_lo=True, hi=1),
                   _opt(t, "max_control_iterations", "sweep", cls, lo=1, integer=True,
                        hi=100),
                   _opt(t, "lead", "sweep", cls, "lead_s", lo=0.0, hi=60))

    @property
    def unit(self) -> str:
        """A sweep."""
        return "sweep"

    @property
    def per_level(self) -> int:
        """One sweep."""
        return 1

    def blocks_per_level(self, fs: float) -> tuple[int, int]:
        """Control: skip + measure per try; the sweep itself with its lead."""
        sweep = math.ceil((max(lw.duration for lw in self.laws) + 2 * self.lead_s) * fs
                          / self.block_size)
        return 2 + sweep, 2 * self.max_control_iterations + sweep

    def stored_bytes(self, n_channels: int, fs: float) -> int:
        """The sweep's samples (its lead trimmed) on every channel."""
        return (self.blocks_per_level(fs)[0] - 2) * self.block_size * n_channels * 8

    def settings(self, channels: list[Channel]) -> JsonObject:
        """The plan, each sweep law as its fields."""
        plan = dict(self.__dict__)
        plan["laws"] = [dict(law.__dict__) for law in self.laws]
        return plan

    def start_info(self) -> PlanInfo:
        """One average: the sweep's H1 live."""
        return PlanInfo(averages=1)   # sweep: H1 live

    def run(self, runner: Runner) -> None:
        """Measure every (amplitude, direction) level not stored yet."""
        fs = runner.c.fs
        for i, (amp, law) in enumerate(zip(self.levels, self.laws)):
            lw = runner.level_start(i, amp, 1)
            if lw.n_segments:
                runner.level_end(lw, amp, 1)
                continue
            drive = min(amp / runner.gain, runner.c.max_drive)
            runner.start(SineOutput(law.start_hz), drive)
            col = runner.force_col
            drive = runner.control(         # one discarded block: the transient after a change
                amp, drive, lambda data: float(abs(sine_fit(data[:, [col]], fs,
                                                            law.start_hz)[0][0])),
                "force amplitude", self.block_size, 1, self.tolerance,
                self.max_control_iterations, f" at {law.start_hz:g} Hz")[0]
            runner.stop()
            runner.start(SweepOutput(law.start_hz, law.stop_hz, law.law, law.rate), drive)
            n = int(round(law.duration * fs))
            data, t0 = runner.take(n + int(round(2 * self.lead_s * fs)))
            runner.stop()
            force, resp = runner.split(data)
            a = sweep_onset(force[:, 0])
            force, resp = force[a:a + n], resp[a:a + n]
            measured = float(np.median(np.abs(force)) * np.sqrt(2))  # sine: median |x| = A/sqrt2
            seq = lw.append_block(force, resp, t=t0 + a / fs, extra=Sweep(law).keys(),
                                  amplitude=measured)
            runner.observer.block(i, seq, force, resp)
            runner.stored(lw, amp, 1, measured, drive)
            runner.level_end(lw, amp, 1)


def sweep_onset(force: np.ndarray) -> int:
    """First sample of a sweep that starts from rest: where the force first exceeds
    `ONSET_FRACTION` of its peak, walked back to the zero crossing before it."""
    f = np.asarray(force, dtype=float)
    i = int(np.flatnonzero(np.abs(f) > ONSET_FRACTION * np.max(np.abs(f)))[0])
    while i > 0 and f[i - 1] * f[i] > 0 and abs(f[i - 1]) < abs(f[i]):
        i -= 1
    return i
