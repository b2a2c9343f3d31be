"""Stepped-sine campaigns ([stepped]): per level and frequency, hold the force amplitude (or,
with ``control = "response"``, the response amplitude at ``control_dof``), wait until the
response harmonics stop changing, then record one block per step with its harmonics."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from analysis.documents import JsonObject, TomlTable
from analysis.recordings import Control, Excitation
from drivers import Channel
from drivers.outputs import SineOutput

from ...store import LevelWriter
from .._campaign_fields import (DIRECTIONS, CampaignError, _levels, _num, _opt, _table,
                                _unknown)
from .._observer import PlanInfo
from .._plans import LevelPlan, Runner, register_plan


class _LimitReached(Exception):
    """A response-controlled level needs more than the drive or force limit: the level
    ends at that step (its message says which limit and the fix)."""


def harmonics(block: np.ndarray, freq: float, fs: float, orders: int) -> np.ndarray:
    """Least-squares complex amplitudes ``c_h`` (x = Re sum c_h e^{i h w t}), h = 0..orders.

    Works on blocks that hold no whole number of cycles. Returns (orders + 1, n_channels);
    orders at or above fs/2 are zero.
    """
    n = len(block)
    t = np.arange(n) / fs
    usable = [h for h in range(1, orders + 1) if h * freq < fs / 2]
    cols = [np.ones(n)]
    for h in usable:
        w = 2 * np.pi * h * freq * t
        cols += [np.cos(w), np.sin(w)]
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), block, rcond=None)
    out = np.zeros((orders + 1, block.shape[1]), complex)
    out[0] = coef[0]
    for i, h in enumerate(usable):
        out[h] = coef[1 + 2 * i] - 1j * coef[2 + 2 * i]
    return out


@register_plan
@dataclass
class SteppedSpec(LevelPlan):
    """Stepped-sine plan ([stepped]): per level and frequency, hold the force (or response)
    amplitude until the response settles, then record one block with its harmonics."""

    levels: list[float]
    freqs: list[float]
    block_size: int
    harmonics: int = 7
    tolerance: float = 0.02
    settle_tolerance: float = 0.01
    max_settle_blocks: int = 20
    max_control_iterations: int = 8
    control: Control = Control.FORCE   # held per step: the force or the response amplitude
    control_dof: int | None = None     # response control: the held channel's DOF

    kind = excitation = Excitation.STEPPED_SINE
    table = "stepped"
    measure = "amplitude"

    @classmethod
    def from_table(cls, data: TomlTable, fs: float) -> "SteppedSpec":
        """The [stepped] table."""
        t = _table(data, "stepped")
        _unknown(t, {"levels", "freqs", "start", "stop", "step", "direction", "block_size",
                     "harmonics", "tolerance", "settle_tolerance", "max_settle_blocks",
                     "max_control_iterations", "control", "control_dof"}, "stepped")
        freqs = _freqs(t)
        if max(freqs) >= fs / 2:
            raise CampaignError(f"[stepped] frequencies must stay below fs/2 = {fs / 2:g} Hz")
        control = t.get("control", str(Control.FORCE))
        if control not in list(Control):
            raise CampaignError(f"[stepped] control must be one of {', '.join(Control)}, got "
                                f"{control!r}")
        if "control_dof" in t and control != Control.RESPONSE:
            raise CampaignError("[stepped] control_dof names the held response channel; give "
                                "it with control = \"response\" or leave it out")
        cdof = _num(t, "control_dof", "stepped", default=None, lo=0, integer=True, hi=10**6)
        return cls(_levels(t, "stepped"), freqs,
                   _num(t, "block_size", "stepped", lo=16, hi=2**22, integer=True),
                   _opt(t, "harmonics", "stepped", cls, lo=1, hi=50, integer=True),
                   _opt(t, "tolerance", "stepped", cls, lo=0, open_lo=True, hi=1),
                   _opt(t, "settle_tolerance", "stepped", cls, lo=0, open_lo=True, hi=1),
                   _opt(t, "max_settle_blocks", "stepped", cls, lo=2, integer=True, hi=10000),
                   _opt(t, "max_control_iterations", "stepped", cls, lo=1, integer=True,
                        hi=100), Control(control), cdof)

    @property
    def unit(self) -> str:
        """A step."""
        return "step"

    @property
    def per_level(self) -> int:
        """One step per frequency."""
        return len(self.freqs)

    def blocks_per_level(self, fs: float) -> tuple[int, int]:
        """Per step: skip, two to compare, the recorded one (at least); every settling
        allowance of every control try (at most)."""
        tries = self.max_control_iterations + 1 if self.control == Control.RESPONSE else 1
        return 4 * len(self.freqs), (tries * self.max_settle_blocks + 1) * len(self.freqs)

    def stored_bytes(self, n_channels: int, fs: float) -> int:
        """Each step's block and its harmonics (JSON text)."""
        text = len(self.freqs) * 48 * n_channels * (self.harmonics + 1)
        return len(self.freqs) * self.block_size * n_channels * 8 + text

    def check(self, channels: list[Channel]) -> None:
        """A response-controlled plan holds a response channel (default: the one at the
        force)."""
        dofs = sorted(c.dof for c in channels if c.quantity != "force")
        if self.control != Control.RESPONSE:
            return
        if self.control_dof is None:
            self.control_dof = next(c.dof for c in channels if c.quantity == "force")
        if self.control_dof not in dofs:
            raise CampaignError(f"[stepped] control_dof = {self.control_dof} has no response "
                                f"channel; use one of the response channels' dof {dofs}")

    def settings(self, channels: list[Channel]) -> JsonObject:
        """The plan, ``control_dof`` as the run's response channel index."""
        plan = dict(self.__dict__)
        if self.control_dof is not None:
            dofs = sorted(ch.dof for ch in channels if ch.quantity != "force")
            plan["control_dof"] = dofs.index(self.control_dof)   # the run's response channel
        return plan

    def start_info(self) -> PlanInfo:
        """The steps and the harmonic orders of a step's rows."""
        return PlanInfo(n_steps=len(self.freqs), harmonics=tuple(range(self.harmonics + 1)))

    def held(self, channels: list[Channel]) -> tuple[str, str]:
        """The force, or the held response channel and its unit."""
        if self.control != Control.RESPONSE:
            return ("force", "N")
        ch = next(ch for ch in channels if ch.quantity != "force" and ch.dof == self.control_dof)
        return (f"response ({ch.name})", ch.unit)

    def run(self, runner: Runner) -> None:
        """Per level and step: hold the force amplitude, or the response amplitude at
        ``control_dof`` (`_SteppedLoop`); a response-controlled level that would need more
        than the drive or force limit ends at that step (`_LimitReached`, a warning)."""
        loop = _SteppedLoop(runner, self)
        for i, amp in enumerate(self.levels):
            loop.level(i, amp)


class _SteppedLoop:
    """The stepped-sine level loop of one campaign, and what it learns on the way: the
    response control's gains per step (held amplitude and force per drive volt), carried
    from level to level, and the secant slope of the last correction."""

    def __init__(self, runner: Runner, plan: SteppedSpec) -> None:
        self.runner, self.plan = runner, plan
        c = runner.c
        self.held_col = runner.force_col if plan.control == Control.FORCE else next(
            i for i, ch in enumerate(c.channels)
            if ch.quantity != "force" and ch.dof == plan.control_dof)
        self.force_limit = c.limits.get(c.channels[runner.force_col].name)
        self.step_gain: dict[int, float] = {}   # response control, per step: held amplitude
        self.force_gain: dict[int, float] = {}  # and force amplitude per drive volt
        self._point: tuple[float, float] | None = None   # the step's last (drive, held)
        self._last_slope = 1.0
        self._level = 0

    def level(self, i: int, amp: float) -> None:
        """Level ``i``: every step not stored yet (step k is stored as seq k)."""
        runner, plan, n_steps = self.runner, self.plan, len(self.plan.freqs)
        self._level = i
        lw = runner.level_start(i, amp, n_steps)
        stored = lw.stored_seqs()
        todo = [k for k in range(n_steps) if k not in stored]
        if todo:
            drive, self._last_slope = self._first_drive(amp, todo[0]), 1.0
            runner.start(SineOutput(plan.freqs[todo[0]]), drive)
            try:
                for k in todo:
                    if k != todo[0]:
                        runner.bench.shaker.set_frequency(plan.freqs[k])
                    drive, held = self._step(lw, k, amp, drive)
                    runner.stored(lw, amp, n_steps, held, drive)
            except _LimitReached as exc:
                runner.warnings.append(str(exc))
            runner.stop()
        runner.level_end(lw, amp, n_steps)

    def _first_drive(self, amp: float, k: int) -> float:
        """A level's first drive: from the force gain (force control), from the response
        gain at step ``k`` of the previous level, else a 20th of ``max_drive`` (response
        control: the loop then ramps it up by at most 4x per change); kept below the force
        channel's safety limit where the previous level's force gain is known."""
        max_drive = self.runner.c.max_drive
        if self.plan.control == Control.FORCE:
            return min(amp / self.runner.gain, max_drive)
        drive = amp / self.step_gain[k] if k in self.step_gain else max_drive / 20
        if self.force_limit is not None and k in self.force_gain:
            drive = min(drive, 0.9 * self.force_limit / self.force_gain[k])
        return min(drive, max_drive)

    def _correct(self, k: int, h: np.ndarray, amp: float, drive: float) -> float | None:
        """The drive to apply after measuring fundamentals ``h`` at ``drive`` (None: the
        held amplitude is within tolerance). Response control raises `_LimitReached`
        when the drive it needs passes ``max_drive`` or its force the force limit."""
        held = abs(h[self.held_col])
        if held <= 0:
            return None
        gain = held / drive
        if self.plan.control == Control.FORCE:
            self.runner.gain = gain
        else:
            self.step_gain[k] = gain
            self.force_gain[k] = abs(h[self.runner.force_col]) / drive
        if abs(held / amp - 1) <= self.plan.tolerance:
            return None
        wanted = drive * (amp / held) ** (1 / self._slope(drive, held))
        if self.plan.control == Control.RESPONSE:
            self._check_limits(k, wanted, held, amp, drive)
        return self.runner.new_drive(drive, wanted)

    def _slope(self, drive: float, held: float) -> float:
        """``d ln(held) / d ln(drive)`` from this and the step's previous measurement (a
        secant: near a softening resonance the response grows faster than the drive and a
        proportional correction overshoots, back and forth); for a step's first correction
        the previous step's (1 at a level's first), and 1 where the secant is not a usable
        rise (noise, a jump)."""
        prev, self._point = self._point, (drive, held)
        if prev is None or prev[0] == drive or prev[1] <= 0:
            return self._last_slope
        slope = np.log(held / prev[1]) / np.log(drive / prev[0])
        self._last_slope = float(min(slope, 10.0)) if slope > 0.2 else 1.0
        return self._last_slope

    def _check_limits(self, k: int, wanted: float, held: float, amp: float,
                      drive: float) -> None:
        """Raise `_LimitReached` when holding ``amp`` needs a drive over ``max_drive``
        (applied already) or a force amplitude over the force channel's ``[safety]`` limit."""
        plan, max_drive, limit = self.plan, self.runner.c.max_drive, self.force_limit
        where = (f"level {self._level} step {k} ({plan.freqs[k]:g} Hz): response amplitude "
                 f"{held:.4g} of {amp:g} at DOF {plan.control_dof}")
        force = self.force_gain[k] * wanted
        if wanted > max_drive and drive >= max_drive:
            raise _LimitReached(f"{where} needs drive {wanted:.4g} V over max_drive "
                                f"{max_drive:g} V; level ended here (raise "
                                "[shaker] max_drive or lower the level)")
        if limit is not None and force > limit:
            raise _LimitReached(f"{where} needs force {force:.4g} N over its safety limit "
                                f"{limit:g} N; level ended here (raise the force channel's "
                                "[safety] limit or lower the level)")

    def _settle(self, k: int, amp: float, drive: float) -> tuple[float, bool, int, int]:
        """Correct and settle step ``k``: the drive, whether the response settled, the
        blocks taken and the drive changes.

        Per block after a change: the fundamentals, the responses' referenced to the
        force's phase (blocks need not hold whole cycles). Force control corrects the drive
        at once; response control waits for the response to settle first (its transient
        decays over the mode's time constant, the force's does not). At most
        ``max_settle_blocks`` blocks per step (response control: after the last change)."""
        runner, plan = self.runner, self.plan
        freq, fs = plan.freqs[k], runner.c.fs
        prev, settled, changes, blocks, since = None, False, 0, 0, 0
        self._point = None
        wait = plan.control == Control.RESPONSE
        skip = 1  # the block after a change holds the transient and data already in flight
        while since < plan.max_settle_blocks and not settled:
            data, _ = runner.take(plan.block_size)
            blocks, since = blocks + 1, since + 1
            if skip:
                skip -= 1
                continue
            h = harmonics(data, freq, fs, 1)[1]
            resp = h[runner.resp_cols] * np.exp(-1j * np.angle(h[runner.force_col]))
            steady = prev is not None and np.max(np.abs(resp - prev)) <= \
                plan.settle_tolerance * max(np.max(np.abs(resp)), 1e-300)
            prev = resp
            if wait and not steady:
                continue
            new = self._correct(k, h, amp, drive)
            if new is not None and changes < plan.max_control_iterations:
                drive = new
                runner.bench.shaker.set_level(drive)
                changes, prev, skip = changes + 1, None, 1
                since = 0 if wait else since
                continue
            settled = steady
        return drive, settled, blocks, changes

    def _step(self, lw: LevelWriter, k: int, amp: float, drive: float) -> tuple[float, float]:
        """Settle (`_settle`), record and store step ``k``; returns the drive and the held
        amplitude."""
        runner, plan = self.runner, self.plan
        freq, fs = plan.freqs[k], runner.c.fs
        drive, settled, blocks, changes = self._settle(k, amp, drive)
        if not settled:
            runner.warnings.append(f"level {self._level} step {k} ({freq:g} Hz): not settled "
                                   f"within {plan.max_settle_blocks} blocks; recorded anyway")
        data, t0 = runner.take(plan.block_size)
        hs = harmonics(data, freq, fs, plan.harmonics)
        force, resp = runner.split(data)
        held = float(abs(hs[1, self.held_col]))
        extra = {"harmonics": np.stack([hs.real, hs.imag], -1),
                 "channels": [ch.name for ch in runner.c.channels],
                 "control_error": held / amp - 1, "settle_blocks": blocks,
                 "settled": bool(settled), "drive": drive, "control_changes": changes}
        lw.append_step(freq, force, resp, amplitude=held, extra=extra, t=t0, seq=k)
        runner.observer.step(self._level, k, freq, force, resp, held / amp - 1,
                             hs[:, runner.resp_cols])
        return drive, held


def _freqs(t: dict) -> list[float]:
    if "freqs" in t:
        freqs = t["freqs"]
        if not isinstance(freqs, list) or not freqs or not all(
                isinstance(f, (int, float)) and not isinstance(f, bool)
                and math.isfinite(f) and f > 0 for f in freqs):
            raise CampaignError(f"[stepped] freqs must be a non-empty list of frequencies > 0 "
                                f"Hz, got {freqs!r}")
        base = [float(f) for f in freqs]
    else:
        start = _num(t, "start", "stepped", lo=0.0, open_lo=True)
        stop = _num(t, "stop", "stepped", lo=0.0, open_lo=True)
        step = _num(t, "step", "stepped", lo=0.0, open_lo=True)
        if stop < start:
            raise CampaignError("[stepped] stop must be >= start (use direction = \"down\" to "
                                "sweep downwards)")
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        if n > 100000:
            raise CampaignError(f"[stepped] start/stop/step give {n} steps; at most 100000")
        base = [start + i * step for i in range(n)]
    direction = t.get("direction", "up")
    if direction not in DIRECTIONS:
        raise CampaignError(f"[stepped] direction must be one of {', '.join(DIRECTIONS)}, "
                            f"got {direction!r}")
    up = sorted(base)
    if direction == "up":
        return up
    if direction == "down":
        return up[::-1]
    return up + up[::-1][1:]
