"""Test campaigns: drive the shaker, stream the DAQ, write every block to a run file.

Random campaigns hold each force-rms level by closed-loop control of the drive, discard the
transient, then record ``averages`` blocks. Stepped-sine campaigns hold the force amplitude
(or, with ``control = "response"``, the response amplitude at ``control_dof``) at each
frequency, wait until the response harmonics stop changing, then record one block per step
with its harmonics. Every chunk from the DAQ is checked against the safety limits; an
over-limit or a communication failure ramps the drive to zero at once and the run is marked
aborted (data kept). Lost samples never leave a silent gap: the block being assembled is
discarded and the loss counted in the run. ``resume`` continues at the first incomplete block
or step.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from analysis.recordings import Control
from drivers.base import DATA_TIMEOUT, Block
from drivers.errors import CommsError
from drivers.outputs import MultisineOutput, Output, RandomOutput, SineOutput

from ._campaign_bench import Bench, open_bench
from ._campaign_config import Campaign, RandomSpec, SteppedSpec, SweepSpec
from ._campaign_sweep import run_sweeps
from ._observer import CampaignObserver, CampaignStart, LevelStatus, LevelSummary, Watchers
from ..store import DiskFullError, LevelWriter, RunWriter, left_out_text, require_room


MAX_RESTARTS = 10  # consecutive blocks broken by DAQ losses before the campaign gives up


class _LimitReached(Exception):
    """A response-controlled level needs more than the drive or force limit: the level
    ends at that step (its message says which limit and the fix)."""


class CampaignAborted(RuntimeError):
    """A safety limit or persistent data loss stopped the campaign (drive ramped to zero,
    data kept)."""


SCHEMA_VERSION = 1
"""Version of the ``campaign run --json`` layout (`CampaignResult.to_json`)."""


@dataclass(frozen=True)
class CampaignResult:
    """What a finished campaign did."""

    out: Path
    status: str
    segments: Mapping[int, int]
    lost_frames: int = 0
    lost_samples: int = 0
    daq_stats: Mapping[str, int] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    levels: tuple[LevelSummary, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The JSON ``campaign run`` writes (``--json``), ``schema_version`` first."""
        return {"schema_version": SCHEMA_VERSION, "out": str(self.out), "status": self.status,
                "segments": {str(k): v for k, v in self.segments.items()},
                "lost_frames": self.lost_frames, "lost_samples": self.lost_samples,
                "daq_stats": dict(self.daq_stats), "warnings": list(self.warnings),
                "levels": [lv.to_json() for lv in self.levels]}


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


class _Runner:
    def __init__(self, c: Campaign, bench: Bench, writer: RunWriter,
                 observer: Watchers, stop: threading.Event | None = None) -> None:
        self.c, self.bench, self.writer, self.observer = c, bench, writer, observer
        self.stop = stop
        names = [ch.name for ch in c.channels]
        self.force_col = next(i for i, ch in enumerate(c.channels) if ch.quantity == "force")
        resp = sorted((ch.dof, i) for i, ch in enumerate(c.channels) if ch.quantity != "force")
        self.resp_cols = [i for _, i in resp]
        self.limits = [(names.index(k), k, v) for k, v in c.limits.items()]
        self.gain = c.gain_guess
        self.level = 0
        self._carry: Block | None = None
        self._lost_frames_seen = 0
        self.warnings: list[str] = []
        self.summaries: list[LevelSummary] = []
        self._level_t0 = 0.0
        self._drive: float | None = None
        self.step_gain: dict[int, float] = {}   # response control, per step: held amplitude
        self.force_gain: dict[int, float] = {}  # and force amplitude per drive volt
        self._point: tuple[float, float] | None = None   # the step's last (drive, held)
        self._last_slope = 1.0

    # --- streaming -----------------------------------------------------------------------
    def _chunk(self) -> Block:
        """Next DAQ chunk, safety-checked; losses counted in the run."""
        daq = self.bench.daq
        if self.stop is not None and self.stop.is_set():
            raise KeyboardInterrupt("campaign stopped by the user")
        self.bench.shaker.check_link()
        block = daq.read(timeout=max(daq.stall_timeout, 4 * self.c.frame_size / self.c.fs,
                                     DATA_TIMEOUT))
        for col, name, limit in self.limits:
            peak = float(np.max(np.abs(block.data[:, col])))
            if peak > limit:
                self.bench.shaker.emergency_stop()
                raise CampaignAborted(f"channel {name} reached {peak:.4g}, over its safety "
                                      f"limit {limit:.4g}; drive ramped to zero, data kept")
        if block.gap:
            frames = daq.stats.lost_frames - self._lost_frames_seen
            self._lost_frames_seen = daq.stats.lost_frames
            self.writer.count_loss(frames, block.gap, f"DAQ stream gap at sample "
                                   f"{block.first_sample}; partial block discarded",
                                   self.level)
        return block

    def take(self, n: int) -> tuple[np.ndarray, float]:
        """``n`` contiguous samples (restarting after any gap) and the first one's time."""
        parts: list[np.ndarray] = []
        have, t0, restarts = 0, 0.0, 0
        while have < n:
            block = self._carry if self._carry is not None else self._chunk()
            self._carry = None
            if block.gap and parts:
                parts, have, restarts = [], 0, restarts + 1
                if restarts > MAX_RESTARTS:
                    self.bench.shaker.emergency_stop()
                    raise CampaignAborted(f"the DAQ lost samples in {restarts} attempts at a "
                                          f"{n}-sample block; fix the link or use shorter "
                                          "blocks")
            if not parts:
                t0 = block.t0
            need = n - have
            if len(block.data) > need:
                rest = block.data[need:]
                self._carry = Block(block.seq, block.first_sample + need,
                                    block.t0 + need / self.c.fs, rest, 0)
            parts.append(block.data[:need])
            have += len(parts[-1])
        return np.vstack(parts), t0

    def split(self, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return data[:, [self.force_col]], data[:, self.resp_cols]

    def _start(self, output: Output, drive: float) -> None:
        self.bench.shaker.configure(output, drive)
        self.bench.daq.start()
        self.bench.shaker.start()
        self._carry = None

    def _stop(self) -> None:
        self.bench.shaker.stop()
        self.bench.daq.stop()

    def _new_drive(self, drive: float, wanted: float) -> float:
        """Control step, limited to a factor of 4 per step and to the shaker's max_drive."""
        return float(min(max(wanted, drive / 4), drive * 4, self.c.max_drive))

    # --- random --------------------------------------------------------------------------
    def random(self, plan: RandomSpec) -> None:
        if plan.periodic:
            self.periodic_random(plan)
            return
        for i, level in enumerate(plan.levels):
            self.level = i
            lw = self._level_start(i, level, plan.averages)
            if lw.n_segments >= plan.averages:
                self._level_end(lw, level, plan.averages)
                continue
            drive = min(level / self.gain, self.c.max_drive)
            seed = (self.c.plant.seed if self.c.plant else 0) * 1000 + 100 * i + lw.next_seq
            self._start(RandomOutput(plan.band, seed), drive)
            drive, data, t0 = self._control_rms(plan, level, drive)
            while lw.n_segments < plan.averages:
                if data is None:
                    data, t0 = self.take(plan.block_size)
                force, resp = self.split(data)
                seq = lw.append_block(force, resp, t=t0)
                self.observer.block(i, seq, force, resp)
                self._stored(lw, level, plan.averages, float(np.std(force)), drive)
                data = None
            self._stop()
            self._level_end(lw, level, plan.averages)

    def periodic_random(self, plan: RandomSpec) -> None:
        """Per level ``averages`` realizations, each a multisine with its own phases held for
        transient + steady periods and stored as one block; the drive is ramped down and up
        between realizations (the transient periods absorb it)."""
        n = (plan.transient_periods + plan.periods) * plan.block_size
        for i, level in enumerate(plan.levels):
            self.level = i
            lw = self._level_start(i, level, plan.averages)
            drive = min(level / self.gain, self.c.max_drive)
            base = (self.c.plant.seed if self.c.plant else 0) * 1000 + 100 * i
            controlled = False
            while lw.n_segments < plan.averages:
                self._start(MultisineOutput(plan.band, plan.block_size, base + lw.next_seq),
                            drive)
                if not controlled:   # on whole periods: a period's rms is the level's
                    drive = self._control_rms(plan, level, drive)[0]
                    controlled = True
                data, t0 = self.take(n)
                force, resp = self.split(data)
                seq = lw.append_block(force, resp, t=t0)
                self.observer.block(i, seq, force, resp)
                self._stored(lw, level, plan.averages, float(np.std(force[self._skip:])),
                             drive)
                self._stop()
            self._level_end(lw, level, plan.averages)

    def _control_rms(self, plan: RandomSpec, level: float, drive: float
                     ) -> tuple[float, np.ndarray | None, float]:
        """Bring the force rms within tolerance of ``level`` (`control`)."""
        return self.control(level, drive, lambda data: float(np.std(data[:, self.force_col])),
                            "force rms", plan.block_size, plan.settle_blocks, plan.tolerance,
                            plan.max_control_iterations)

    def control(self, target: float, drive: float, measure: Callable[[np.ndarray], float],
                what: str, block_size: int, settle_blocks: int, tolerance: float,
                max_iterations: int, where: str = "") -> tuple[float, np.ndarray | None, float]:
        """The level control: per try, discard ``settle_blocks`` blocks, measure one with
        ``measure`` (block -> force rms or amplitude) and correct the drive (`_new_drive`)
        until the measure is within ``tolerance`` of ``target``; a warning after
        ``max_iterations`` tries (``what`` and ``where`` name the measure in it). Returns the
        drive and the last block measured at it (None if the drive changed after it) with
        its time."""
        data, t0 = None, 0.0
        for _ in range(max_iterations):
            for _ in range(settle_blocks):
                self.take(block_size)
            data, t0 = self.take(block_size)
            value = measure(data)
            if value <= 0:
                break
            self.gain = value / drive
            if abs(value / target - 1) <= tolerance:
                break
            drive = self._new_drive(drive, target / self.gain)
            self.bench.shaker.set_level(drive)
            data = None
        else:
            self.warnings.append(f"level {self.level}: {what} not within {tolerance:.0%} of "
                                 f"{target} N{where} after {max_iterations} tries")
        return drive, data, t0

    # --- stepped sine ----------------------------------------------------------------------
    def stepped(self, plan: SteppedSpec) -> None:
        """Per level and step: hold the force amplitude, or the response amplitude at
        ``control_dof`` (`_step`); a response-controlled level that would need more than the
        drive or force limit ends at that step (`_LimitReached`, a warning)."""
        n_steps = len(plan.freqs)
        for i, amp in enumerate(plan.levels):
            self.level = i
            lw = self._level_start(i, amp, n_steps)
            stored = lw.stored_seqs()     # step k is stored as seq k: resume records the rest
            todo = [k for k in range(n_steps) if k not in stored]
            if todo:
                drive, self._last_slope = self._first_drive(plan, amp, todo[0]), 1.0
                self._start(SineOutput(plan.freqs[todo[0]]), drive)
                try:
                    for k in todo:
                        if k != todo[0]:
                            self.bench.shaker.set_frequency(plan.freqs[k])
                        drive, held = self._step(lw, i, k, plan, amp, drive)
                        self._stored(lw, amp, n_steps, held, drive)
                except _LimitReached as exc:
                    self.warnings.append(str(exc))
                self._stop()
            self._level_end(lw, amp, n_steps)

    def _first_drive(self, plan: SteppedSpec, amp: float, k: int) -> float:
        """A level's first drive: from the force gain (force control), from the response
        gain at step ``k`` of the previous level, else a 20th of ``max_drive`` (response
        control: the loop then ramps it up by at most 4x per change); kept below the force
        channel's safety limit where the previous level's force gain is known."""
        if plan.control == Control.FORCE:
            return min(amp / self.gain, self.c.max_drive)
        drive = amp / self.step_gain[k] if k in self.step_gain else self.c.max_drive / 20
        limit = self.c.limits.get(self.c.channels[self.force_col].name)
        if limit is not None and k in self.force_gain:
            drive = min(drive, 0.9 * limit / self.force_gain[k])
        return min(drive, self.c.max_drive)

    def _held_col(self, plan: SteppedSpec) -> int:
        """DAQ column of the held quantity."""
        if plan.control == Control.FORCE:
            return self.force_col
        return next(i for i, ch in enumerate(self.c.channels)
                    if ch.quantity != "force" and ch.dof == plan.control_dof)

    def _correct(self, plan: SteppedSpec, k: int, h: np.ndarray, amp: float,
                 drive: float) -> float | None:
        """The drive to apply after measuring fundamentals ``h`` at ``drive`` (None: the
        held amplitude is within tolerance). Response control raises `_LimitReached`
        when the drive it needs passes ``max_drive`` or its force the force limit."""
        held = abs(h[self._held_col(plan)])
        if held <= 0:
            return None
        gain = held / drive
        if plan.control == Control.FORCE:
            self.gain = gain
        else:
            self.step_gain[k] = gain
            self.force_gain[k] = abs(h[self.force_col]) / drive
        if abs(held / amp - 1) <= plan.tolerance:
            return None
        wanted = drive * (amp / held) ** (1 / self._slope(drive, held))
        if plan.control == Control.RESPONSE:
            self._check_limits(plan, k, wanted, held, amp, drive)
        return self._new_drive(drive, wanted)

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

    def _check_limits(self, plan: SteppedSpec, k: int, wanted: float, held: float,
                      amp: float, drive: float) -> None:
        """Raise `_LimitReached` when holding ``amp`` needs a drive over ``max_drive``
        (applied already) or a force amplitude over the force channel's ``[safety]`` limit."""
        where = (f"level {self.level} step {k} ({plan.freqs[k]:g} Hz): response amplitude "
                 f"{held:.4g} of {amp:g} at DOF {plan.control_dof}")
        limit = self.c.limits.get(self.c.channels[self.force_col].name)
        force = self.force_gain[k] * wanted
        if wanted > self.c.max_drive and drive >= self.c.max_drive:
            raise _LimitReached(f"{where} needs drive {wanted:.4g} V over max_drive "
                                f"{self.c.max_drive:g} V; level ended here (raise "
                                "[shaker] max_drive or lower the level)")
        if limit is not None and force > limit:
            raise _LimitReached(f"{where} needs force {force:.4g} N over its safety limit "
                                f"{limit:g} N; level ended here (raise the force channel's "
                                "[safety] limit or lower the level)")

    def _step(self, lw, level: int, k: int, plan: SteppedSpec, amp: float,
              drive: float) -> tuple[float, float]:
        """Settle, record and store step ``k``; returns the drive and the held amplitude.

        Per block after a change: the fundamentals, the responses' referenced to the
        force's phase (blocks need not hold whole cycles). Force control corrects the drive
        at once; response control waits for the response to settle first (its transient
        decays over the mode's time constant, the force's does not). At most
        ``max_settle_blocks`` blocks per step (response control: after the last change)."""
        freq, fs = plan.freqs[k], self.c.fs
        prev, settled, changes, blocks, since = None, False, 0, 0, 0
        self._point = None
        wait = plan.control == Control.RESPONSE
        skip = 1  # the block after a change holds the transient and data already in flight
        while since < plan.max_settle_blocks and not settled:
            data, _ = self.take(plan.block_size)
            blocks, since = blocks + 1, since + 1
            if skip:
                skip -= 1
                continue
            h = harmonics(data, freq, fs, 1)[1]
            resp = h[self.resp_cols] * np.exp(-1j * np.angle(h[self.force_col]))
            steady = prev is not None and np.max(np.abs(resp - prev)) <= \
                plan.settle_tolerance * max(np.max(np.abs(resp)), 1e-300)
            prev = resp
            if wait and not steady:
                continue
            new = self._correct(plan, k, h, amp, drive)
            if new is not None and changes < plan.max_control_iterations:
                drive = new
                self.bench.shaker.set_level(drive)
                changes, prev, skip = changes + 1, None, 1
                since = 0 if wait else since
                continue
            settled = steady
        if not settled:
            self.warnings.append(f"level {level} step {k} ({freq:g} Hz): not settled within "
                                 f"{plan.max_settle_blocks} blocks; recorded anyway")
        data, t0 = self.take(plan.block_size)
        hs = harmonics(data, freq, fs, plan.harmonics)
        force, resp = self.split(data)
        held = float(abs(hs[1, self._held_col(plan)]))
        extra = {"harmonics": np.stack([hs.real, hs.imag], -1),
                 "channels": [ch.name for ch in self.c.channels],
                 "control_error": held / amp - 1, "settle_blocks": blocks,
                 "settled": bool(settled), "drive": drive, "control_changes": changes}
        lw.append_step(freq, force, resp, amplitude=held, extra=extra, t=t0, seq=k)
        self.observer.step(level, k, freq, force, resp, held / amp - 1,
                           hs[:, self.resp_cols])
        return drive, held

    # --- what the watchers are told ------------------------------------------------------
    @property
    def _skip(self) -> int:
        """Samples of a stored block before its steady part (transient periods)."""
        return self.c.plan.skip

    def _level_start(self, i: int, target: float, planned: int) -> LevelWriter:
        lw = self.writer.level(i, target)
        self._level_t0, self._drive = time.monotonic(), None
        self.observer.level_progress(LevelStatus(i, target, lw.n_segments, planned, None,
                                                 None, None))
        return lw

    def _stored(self, lw: LevelWriter, target: float, planned: int, measured: float,
                drive: float) -> None:
        self._drive = drive
        self.observer.level_progress(LevelStatus(lw.index, target, lw.n_segments, planned,
                                                 measured, drive, measured / target - 1))

    def _level_end(self, lw: LevelWriter, target: float, planned: int) -> None:
        """Mark the level complete and tell its summary, built from the stored data."""
        lw.complete()
        n, total, squares, amplitudes = 0, 0.0, 0.0, []
        for block, amplitude in lw.stored_force():      # a block at a time: any level size
            x = block[self._skip:, 0]
            n, total, squares = n + x.size, total + x.sum(), squares + x @ x
            amplitudes.append(amplitude)
        plan = self.c.plan
        stepped = plan.measure == "amplitude"
        force = error = None
        if amplitudes and stepped:
            force = float(np.mean(amplitudes))
            errors = np.array(amplitudes) / target - 1
            error = float(errors[np.argmax(np.abs(errors))])
        elif amplitudes:
            force = float(np.sqrt(max(squares / n - (total / n) ** 2, 0.0)))
            error = force / target - 1
        summary = LevelSummary(lw.index, target, plan.measure, plan.unit,
                               lw.n_segments, planned, force, error, self._drive,
                               time.monotonic() - self._level_t0, *plan.held(self.c.channels))
        self.summaries.append(summary)
        self.observer.level_finished(summary)

    def run(self) -> None:
        c = self.c
        info = CampaignStart(
            fs=c.fs, excitation=c.plan.excitation, force_dofs=(c.force_dof,), n_dof=c.n_dof,
            response_kind=c.response_kind, sensors=c.sensors,
            channels=tuple((ch.name, ch.unit) for ch in c.channels), levels=tuple(c.levels),
            block_len=c.plan.block_len, planned=c.plan.per_level, unit=c.plan.unit,
            stored=tuple(self.writer.level(i, x).n_segments for i, x in enumerate(c.levels)),
            **c.plan.start_info())
        self.observer.campaign_started(info)
        try:
            c.plan.run(self)
        except BaseException:
            self._safe_stop()
            raise

    def swept(self, plan: SweepSpec) -> None:
        """Per level: hold the force amplitude on a sine, then play the sweep once."""
        run_sweeps(self, plan)

    def _safe_stop(self) -> None:
        """Ramp the drive to zero whatever failed; a dead shaker link is reported, not
        raised over the original error."""
        try:
            self.bench.shaker.emergency_stop()
        except CommsError as exc:
            self.warnings.append(f"emergency stop could not be confirmed: {exc}")
            try:
                self.writer.log("estop-failed", {"error": str(exc)})
            except Exception:  # noqa: BLE001 - the original error matters more
                pass


def _channels_json(c: Campaign) -> list[dict[str, Any]]:
    """The run's channel attributes (stored as JSON): forces first, then responses by DOF."""
    return [{"name": ch.name, "unit": ch.unit, "dof": ch.dof, "sensitivity": ch.sensitivity,
             "kind": "force" if ch.quantity == "force" else "response"}
            for ch in sorted(c.channels, key=lambda ch: (ch.quantity != "force", ch.dof))]


def _excitation_json(c: Campaign) -> dict[str, Any]:
    """The run's ``excitation_settings`` attribute (stored as JSON): the kind and its plan."""
    return {"kind": c.plan.excitation, **c.plan.settings(c.channels)}


def run_campaign(c: Campaign, out: str | Path, *, resume: bool = False,
                 overwrite: bool = False,
                 observer: CampaignObserver | Sequence[CampaignObserver] | None = None,
                 on_bench=None, stop: threading.Event | None = None) -> CampaignResult:
    """Run campaign ``c`` into the run file ``out``.

    ``observer`` (one or several) is told of every block, step and level as it is stored.
    ``on_bench(bench)`` is called once the devices are open (tests use it to reach the
    emulators). Setting ``stop`` (from another thread) ends the campaign at the next DAQ
    chunk like Ctrl-C: drive ramped to zero, run marked interrupted (resumable),
    `KeyboardInterrupt` raised. The disk must hold the plan's data before the devices are
    opened, and each block before it is written: otherwise (or when a write fails on a full
    disk) `nlid_lab.store.DiskFullError` is raised, the drive ramped to zero and the run
    marked interrupted with every stored block intact (resumable). Raises `CampaignAborted`
    on a safety limit and `drivers.errors.CommsError` on communication failure; the run file
    is marked aborted and keeps its data either way. An existing ``out`` is refused unless
    ``resume`` (continue it) or ``overwrite`` (replace it).
    """
    out = Path(out)
    observer = Watchers(*observer) if isinstance(observer, Sequence) else Watchers(observer)
    status = "aborted"
    stored = out.stat().st_size if resume and out.is_file() else 0
    require_room(out, max(c.stored_bytes() - stored, 0),
                 "the rest of the plan" if stored else "the plan")
    with open_bench(c) as bench:
        if on_bench is not None:
            on_bench(bench)
        bench.daq.configure(c.fs, bench.channels, frame_size=c.frame_size)
        settings = {"campaign": c.raw, "shaker_url": c.shaker_url, "daq_url": c.daq_url,
                    "source_file": str(c.source) if c.source else None}
        # the simulated rig holds the drive linearly between samples (analysis.plant)
        hold = "linear" if bench.rig is not None else "none"
        with RunWriter(out, fs=c.fs, excitation=_excitation_json(c), force_dofs=[c.force_dof],
                       n_dof=c.n_dof, response_kind=c.response_kind,
                       channels=_channels_json(c), settings=settings, force_hold=hold,
                       layout=c.plan.layout(), sensors=c.sensors,
                       model_toml=bench.model_toml, source=bench.source,
                       mode="resume" if resume else "overwrite" if overwrite else "create"
                       ) as writer:
            runner = _Runner(c, bench, writer, observer, stop)
            if writer.dropped:
                runner.warnings.append(f"resume: {len(writer.dropped)} damaged block(s) "
                                       f"dropped and recorded again "
                                       f"({left_out_text(writer.dropped)})")
            try:
                runner.run()
                status = "complete"
            except (KeyboardInterrupt, DiskFullError):
                status = "interrupted"
                raise
            finally:
                stats = bench.daq.stats.as_dict()
                writer.log("daq-stats", stats)
                for w in runner.warnings:
                    writer.log("warning", {"text": w})
                observer.campaign_finished(status)
            segments = {lv.index: lv.n_segments for lv in
                        [writer.level(i, n) for i, n in enumerate(c.levels)]}
    return CampaignResult(out, status, segments, stats["lost_frames"], stats["lost_samples"],
                          stats, tuple(runner.warnings), tuple(runner.summaries))
