"""Swept-sine levels of a campaign: hold the force amplitude with a sine at the sweep's start
frequency, then play the sweep once and store it as one block with its sweep keys.

The level control runs on a steady sine (a sweep never settles); the drive it finds is held
through the sweep, so the force amplitude varies where the structure loads the shaker, as a
real open-loop sweep does. The record starts `SweepSpec.lead_s` before the output turns on;
the samples before the sweep's first one are dropped, so the stored record starts with the
sweep (its law, as generated, is stored with it).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from analysis.spectral import sine_fit
from analysis.recordings import Sweep
from drivers.outputs import SineOutput, SweepOutput

from ._campaign_config import SweepSpec

#: the sweep starts where the force first exceeds this fraction of its peak
ONSET_FRACTION = 0.01


def run_sweeps(runner: Any, plan: SweepSpec) -> None:
    """Measure every (amplitude, direction) level of ``plan`` not stored yet (``runner``: the
    campaign's `nlid_lab.campaign._campaign._Runner`)."""
    fs = runner.c.fs
    for i, (amp, law) in enumerate(zip(plan.levels, plan.laws)):
        runner.level = i
        lw = runner._level_start(i, amp, 1)
        if lw.n_segments:
            runner._level_end(lw, amp, 1)
            continue
        drive = min(amp / runner.gain, runner.c.max_drive)
        runner._start(SineOutput(law.start_hz), drive)
        drive = runner.control(             # one discarded block: the transient after a change
            amp, drive, lambda data: float(abs(sine_fit(data[:, [runner.force_col]], fs,
                                                        law.start_hz)[0][0])),
            "force amplitude", plan.block_size, 1, plan.tolerance,
            plan.max_control_iterations, f" at {law.start_hz:g} Hz")[0]
        runner._stop()
        runner._start(SweepOutput(law.start_hz, law.stop_hz, law.law, law.rate), drive)
        n = int(round(law.duration * fs))
        data, t0 = runner.take(n + int(round(2 * plan.lead_s * fs)))
        runner._stop()
        force, resp = runner.split(data)
        a = sweep_onset(force[:, 0])
        force, resp = force[a:a + n], resp[a:a + n]
        measured = float(np.median(np.abs(force)) * np.sqrt(2))   # sine: median |x| = A/sqrt2
        seq = lw.append_block(force, resp, t=t0 + a / fs, extra=Sweep(law).keys(),
                              amplitude=measured)
        runner.observer.block(i, seq, force, resp)
        runner._stored(lw, amp, 1, measured, drive)
        runner._level_end(lw, amp, 1)


def sweep_onset(force: np.ndarray) -> int:
    """First sample of a sweep that starts from rest: where the force first exceeds
    `ONSET_FRACTION` of its peak, walked back to the zero crossing before it."""
    f = np.asarray(force, dtype=float)
    i = int(np.flatnonzero(np.abs(f) > ONSET_FRACTION * np.max(np.abs(f)))[0])
    while i > 0 and f[i - 1] * f[i] > 0 and abs(f[i - 1]) < abs(f[i]):
        i -= 1
    return i
