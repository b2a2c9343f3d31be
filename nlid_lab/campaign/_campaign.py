"""Test campaigns: drive the shaker, stream the DAQ, write every block to a run file.

The runner offers a kind's level loop (`LevelPlan.run`, in ``_kinds``: random, periodic
random, stepped sine, swept sine) its primitives (`Runner`): contiguous samples, the level
control, a level's start and end, the output on the shaker and its stop. Every chunk from the
DAQ is checked against the safety limits; an over-limit or a communication failure ramps the
drive to zero at once and the run is marked aborted (data kept). Lost samples never leave a
silent gap: the block being assembled is discarded and the loss counted in the run.
``resume`` continues at the first incomplete block or step.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from drivers.base import DATA_TIMEOUT, Block
from drivers.errors import CommsError
from drivers.outputs import Output

from ._campaign_bench import Bench, open_bench
from ._campaign_config import Campaign
from ._run_header import run_channels, run_excitation
from ._observer import CampaignObserver, CampaignStart, LevelStatus, LevelSummary, Watchers
from ..store import DiskFullError, LevelWriter, RunWriter, left_out_text, require_room


MAX_RESTARTS = 10  # consecutive blocks broken by DAQ losses before the campaign gives up


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


class _Runner:
    """One campaign's run: the primitives a kind's level loop uses (`Runner`), the level
    control's gain, what the watchers and the run's log are told."""

    def __init__(self, c: Campaign, bench: Bench, writer: RunWriter,
                 observer: Watchers, stop: threading.Event | None = None) -> None:
        self.c, self.bench, self.writer, self.observer = c, bench, writer, observer
        self.stop_event = stop
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

    # --- streaming -----------------------------------------------------------------------
    def _chunk(self) -> Block:
        """Next DAQ chunk, safety-checked; losses counted in the run."""
        daq = self.bench.daq
        if self.stop_event is not None and self.stop_event.is_set():
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
        """The force and response columns of ``data``."""
        return data[:, [self.force_col]], data[:, self.resp_cols]

    def start(self, output: Output, drive: float) -> None:
        """Configure the shaker with ``output`` at ``drive`` V, start the DAQ and the shaker."""
        self.bench.shaker.configure(output, drive)
        self.bench.daq.start()
        self.bench.shaker.start()
        self._carry = None

    def stop(self) -> None:
        """Stop the shaker and the DAQ."""
        self.bench.shaker.stop()
        self.bench.daq.stop()

    def new_drive(self, drive: float, wanted: float) -> float:
        """Control step, limited to a factor of 4 per step and to the shaker's max_drive."""
        return float(min(max(wanted, drive / 4), drive * 4, self.c.max_drive))

    def control(self, target: float, drive: float, measure: Callable[[np.ndarray], float],
                what: str, block_size: int, settle_blocks: int, tolerance: float,
                max_iterations: int, where: str = "") -> tuple[float, np.ndarray | None, float]:
        """The level control: per try, discard ``settle_blocks`` blocks, measure one with
        ``measure`` (block -> force rms or amplitude) and correct the drive (`new_drive`)
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
            drive = self.new_drive(drive, target / self.gain)
            self.bench.shaker.set_level(drive)
            data = None
        else:
            self.warnings.append(f"level {self.level}: {what} not within {tolerance:.0%} of "
                                 f"{target} N{where} after {max_iterations} tries")
        return drive, data, t0

    # --- what the watchers are told ------------------------------------------------------
    @property
    def _skip(self) -> int:
        """Samples of a stored block before its steady part (transient periods)."""
        return self.c.plan.skip

    def level_start(self, i: int, target: float, planned: int) -> LevelWriter:
        """Open level ``i`` (its writer) and tell the watchers it starts."""
        self.level = i
        lw = self.writer.level(i, target)
        self._level_t0, self._drive = time.monotonic(), None
        self.observer.level_progress(LevelStatus(i, target, lw.n_segments, planned, None,
                                                 None, None))
        return lw

    def stored(self, lw: LevelWriter, target: float, planned: int, measured: float,
               drive: float) -> None:
        """Tell the watchers where the level stands after a stored segment."""
        self._drive = drive
        self.observer.level_progress(LevelStatus(lw.index, target, lw.n_segments, planned,
                                                 measured, drive, measured / target - 1))

    def level_end(self, lw: LevelWriter, target: float, planned: int) -> None:
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
        """Tell the watchers the campaign starts, run the plan's level loop; the drive ramped
        to zero on any failure (`_safe_stop`)."""
        c, kind = self.c, self.c.plan.start_info()
        info = CampaignStart(
            fs=c.fs, excitation=c.plan.excitation, force_dofs=(c.force_dof,), n_dof=c.n_dof,
            response_kind=c.response_kind, sensors=c.sensors,
            channels=tuple((ch.name, ch.unit) for ch in c.channels), levels=tuple(c.levels),
            block_len=c.plan.block_len, planned=c.plan.per_level, unit=c.plan.unit,
            stored=tuple(self.writer.level(i, x).n_segments for i, x in enumerate(c.levels)),
            averages=kind.averages, period=kind.period, transient_periods=kind.transient_periods,
            n_steps=kind.n_steps, harmonics=kind.harmonics)
        self.observer.campaign_started(info)
        try:
            c.plan.run(self)
        except BaseException:
            self._safe_stop()
            raise

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
        excitation = run_excitation(c)
        with RunWriter(out, fs=c.fs, excitation=excitation.to_json(), force_dofs=[c.force_dof],
                       n_dof=c.n_dof, response_kind=c.response_kind,
                       channels=[ch.to_json() for ch in run_channels(c)], settings=settings,
                       planned_blocks=excitation.planned_blocks, force_hold=hold,
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
