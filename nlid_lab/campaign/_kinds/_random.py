"""Random campaigns ([random]): per level, hold the force rms by closed-loop control of the
drive, discard the transient, then record ``averages`` blocks of band-limited noise; periodic
random records ``averages`` realizations of a multisine instead, each held for transient and
steady periods and stored as one block."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from analysis.documents import TomlTable
from analysis.recordings import Excitation, PeriodicLayout
from drivers.outputs import MultisineOutput, RandomOutput

from .._campaign_fields import CampaignError, _levels, _num, _opt, _table, _unknown
from .._observer import PlanInfo
from .._plans import LevelPlan, Runner, register_plan


@register_plan
@dataclass
class RandomSpec(LevelPlan):
    """Random plan ([random]): per level, hold the force rms, then record ``averages`` blocks
    (periodic: ``averages`` realizations of a multisine of period ``block_size``)."""

    levels: list[float]
    averages: int
    block_size: int
    band: tuple[float, float]
    settle_blocks: int = 1
    tolerance: float = 0.05
    max_control_iterations: int = 6
    periodic: bool = False       # periodic random: block_size = period, averages = realizations
    periods: int = 8             # steady periods per realization (periodic only)
    transient_periods: int = 1   # leading periods per realization, dropped (periodic only)

    kind = excitation = Excitation.RANDOM
    table = "random"

    @classmethod
    def from_table(cls, data: TomlTable, fs: float) -> "RandomSpec":
        """The [random] table."""
        t = _table(data, "random")
        _unknown(t, {"levels", "averages", "block_size", "band", "settle_blocks",
                     "tolerance", "max_control_iterations", "periodic", "periods",
                     "transient_periods"}, "random")
        band = t.get("band")
        if not (isinstance(band, list) and len(band) == 2 and all(
                isinstance(b, (int, float)) and not isinstance(b, bool) for b in band)
                and 0 <= band[0] < band[1] <= fs / 2):
            raise CampaignError(f"[random] band must be [lo, hi] Hz with 0 <= lo < hi <= fs/2 "
                                f"= {fs / 2:g}, got {band!r}")
        spec = cls(_levels(t, "random"), _num(t, "averages", "random", lo=1, integer=True,
                                              hi=100000),
                   _num(t, "block_size", "random", lo=16, hi=2**22, integer=True),
                   (float(band[0]), float(band[1])),
                   _opt(t, "settle_blocks", "random", cls, lo=0, integer=True),
                   _opt(t, "tolerance", "random", cls, lo=0, open_lo=True, hi=1),
                   _opt(t, "max_control_iterations", "random", cls, lo=1, integer=True,
                        hi=100))
        return _periodic(t, spec, fs)

    @property
    def title(self) -> str:
        """``periodic-random`` for a periodic plan, else the kind."""
        return "periodic-random" if self.periodic else str(self.kind)

    @property
    def unit(self) -> str:
        """A realization (periodic) or a block."""
        return "realization" if self.periodic else "block"

    @property
    def per_level(self) -> int:
        """``averages`` blocks or realizations."""
        return self.averages

    @property
    def skip(self) -> int:
        """The transient periods of a realization (periodic), else none."""
        return self.transient_periods * self.block_size if self.periodic else 0

    @property
    def block_len(self) -> int:
        """A block, or a realization's transient and steady periods."""
        return self.block_size * ((self.transient_periods + self.periods) if self.periodic
                                  else 1)

    def blocks_per_level(self, fs: float) -> tuple[int, int]:
        """Control (settle blocks + one measured, per try) and the recorded blocks."""
        control = self.settle_blocks + 1
        if self.periodic:                   # a block is one period here
            record = self.averages * (self.transient_periods + self.periods)
            return control + record, self.max_control_iterations * control + record
        return control + self.averages - 1, self.max_control_iterations * control + \
            self.averages

    def layout(self) -> PeriodicLayout | None:
        """Periodic-random runs: a block is one realization of the multisine."""
        if not self.periodic:
            return None
        return PeriodicLayout(self.block_size, self.transient_periods, self.periods,
                              self.averages)

    def start_info(self) -> PlanInfo:
        """The averages, and a periodic plan's period and transient periods."""
        return PlanInfo(averages=self.averages,
                        period=self.block_size if self.periodic else None,
                        transient_periods=self.transient_periods if self.periodic else 1)

    def run(self, runner: Runner) -> None:
        """Per level: the force rms held on the level's noise, then ``averages`` blocks
        (periodic: `_run_periodic`)."""
        if self.periodic:
            self._run_periodic(runner)
            return
        for i, level in enumerate(self.levels):
            lw = runner.level_start(i, level, self.averages)
            if lw.n_segments >= self.averages:
                runner.level_end(lw, level, self.averages)
                continue
            drive = min(level / runner.gain, runner.c.max_drive)
            seed = (runner.c.plant.seed if runner.c.plant else 0) * 1000 + 100 * i + \
                lw.next_seq
            runner.start(RandomOutput(self.band, seed), drive)
            drive, data, t0 = self._control_rms(runner, level, drive)
            while lw.n_segments < self.averages:
                if data is None:
                    data, t0 = runner.take(self.block_size)
                force, resp = runner.split(data)
                seq = lw.append_block(force, resp, t=t0)
                runner.observer.block(i, seq, force, resp)
                runner.stored(lw, level, self.averages, float(np.std(force)), drive)
                data = None
            runner.stop()
            runner.level_end(lw, level, self.averages)

    def _run_periodic(self, runner: Runner) -> None:
        """Per level ``averages`` realizations, each a multisine with its own phases held for
        transient + steady periods and stored as one block; the drive is ramped down and up
        between realizations (the transient periods absorb it)."""
        n = (self.transient_periods + self.periods) * self.block_size
        for i, level in enumerate(self.levels):
            lw = runner.level_start(i, level, self.averages)
            drive = min(level / runner.gain, runner.c.max_drive)
            base = (runner.c.plant.seed if runner.c.plant else 0) * 1000 + 100 * i
            controlled = False
            while lw.n_segments < self.averages:
                runner.start(MultisineOutput(self.band, self.block_size, base + lw.next_seq),
                             drive)
                if not controlled:   # on whole periods: a period's rms is the level's
                    drive = self._control_rms(runner, level, drive)[0]
                    controlled = True
                data, t0 = runner.take(n)
                force, resp = runner.split(data)
                seq = lw.append_block(force, resp, t=t0)
                runner.observer.block(i, seq, force, resp)
                runner.stored(lw, level, self.averages, float(np.std(force[self.skip:])),
                              drive)
                runner.stop()
            runner.level_end(lw, level, self.averages)

    def _control_rms(self, runner: Runner, level: float, drive: float
                     ) -> tuple[float, np.ndarray | None, float]:
        """Bring the force rms within tolerance of ``level`` (`Runner.control`)."""
        col = runner.force_col
        return runner.control(level, drive, lambda data: float(np.std(data[:, col])),
                              "force rms", self.block_size, self.settle_blocks,
                              self.tolerance, self.max_control_iterations)


def _periodic(t: dict, spec: RandomSpec, fs: float) -> RandomSpec:
    """The periodic-random keys of [random]: a multisine of period block_size, ``averages``
    realizations of transient_periods + periods periods each."""
    periodic = t.get("periodic", False)
    if not isinstance(periodic, bool):
        raise CampaignError(f"[random] periodic must be true or false, got {periodic!r}")
    if not periodic:
        extra = sorted({"periods", "transient_periods"} & set(t))
        if extra:
            raise CampaignError(f"[random] {', '.join(extra)} needs periodic = true")
        return spec
    lo, hi = spec.band
    df = fs / spec.block_size
    if math.floor(hi / df) < max(math.ceil(lo / df), 1):
        raise CampaignError(f"[random] band {lo:g}-{hi:g} Hz holds no line of a "
                            f"{spec.block_size}-sample period (lines every {df:g} Hz); widen "
                            "the band or lengthen block_size")
    spec.periodic = True
    spec.periods = _opt(t, "periods", "random", RandomSpec, lo=1, integer=True, hi=10000)
    spec.transient_periods = _opt(t, "transient_periods", "random", RandomSpec, lo=1,
                                  integer=True, hi=1000)
    return spec
