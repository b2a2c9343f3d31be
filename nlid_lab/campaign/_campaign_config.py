"""Campaign files (TOML): parsing and validation into a `Campaign` (docs/campaign-format.md).

Every problem raises `CampaignError` (an `InputError`: the CLI exits 2) naming the key and
the fix. Relative paths are resolved against the campaign file's folder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from analysis.documents import JsonObject, TomlTable
from analysis.errors import RecordingError
from analysis.models import Model, parse_toml, read_text
from analysis.recordings import (KIND_ORDER, MIXED, Control, Excitation, PeriodicLayout,
                                 ResponseKind, SensorMap, SweepLaw)
from drivers import DEFAULT_RAMP_TIME, Channel
from drivers.faults import FaultSpec

from ..sim_budget import excess
from ._campaign_devices import (SIMULATED, Role, _channels, _check_channel_set, _emulator,
                               _limits, _sensor_channels, _sensors, _url, _watchdog, scheme)
from ._campaign_fields import (CampaignError, _choice, _levels, _num, _opt, _table,
                              _unknown)
from ._plans import PLANS, LevelPlan, plan_of, register_plan

DIRECTIONS = ("up", "down", "up-down")
#: the campaign file's tables and keys besides its kind's table (`LevelPlan.table`)
TOP_KEYS = {"name", "kind", "plant", "shaker", "daq", "channel", "safety", "emulator",
            "sensors"}
MAX_PLAN_S = 3600.0          # measurement time `campaign run` starts without --yes
MAX_PLAN_BYTES = 2 * 2**30   # recorded data `campaign run` starts without --yes


@dataclass
class PlantSpec:
    model: Path
    seed: int = 0
    shaker_gain: float = 1.0
    noise_std: float = 0.0
    oversample: int | None = None


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
        return "periodic-random" if self.periodic else str(self.kind)

    @property
    def unit(self) -> str:
        return "realization" if self.periodic else "block"

    @property
    def per_level(self) -> int:
        return self.averages

    @property
    def skip(self) -> int:
        return self.transient_periods * self.block_size if self.periodic else 0

    @property
    def block_len(self) -> int:
        return self.block_size * ((self.transient_periods + self.periods) if self.periodic
                                  else 1)

    def blocks_per_level(self, fs: float) -> tuple[int, int]:
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

    def start_info(self) -> dict[str, Any]:
        return {"averages": self.averages,
                "period": self.block_size if self.periodic else None,
                "transient_periods": self.transient_periods if self.periodic else 1}

    def run(self, runner: Any) -> None:
        runner.random(self)


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
        return "step"

    @property
    def per_level(self) -> int:
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
        plan = dict(self.__dict__)
        if self.control_dof is not None:
            dofs = sorted(ch.dof for ch in channels if ch.quantity != "force")
            plan["control_dof"] = dofs.index(self.control_dof)   # the run's response channel
        return plan

    def start_info(self) -> dict[str, Any]:
        return {"averages": None, "n_steps": len(self.freqs),
                "harmonics": tuple(range(self.harmonics + 1))}

    def held(self, channels: list[Channel]) -> tuple[str, str]:
        if self.control != Control.RESPONSE:
            return ("force", "N")
        ch = next(ch for ch in channels if ch.quantity != "force" and ch.dof == self.control_dof)
        return (f"response ({ch.name})", ch.unit)

    def run(self, runner: Any) -> None:
        runner.stepped(self)


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
        return _sweep(data, fs)

    @property
    def unit(self) -> str:
        return "sweep"

    @property
    def per_level(self) -> int:
        return 1

    def blocks_per_level(self, fs: float) -> tuple[int, int]:
        """Control: skip + measure per try; the sweep itself with its lead."""
        sweep = math.ceil((max(lw.duration for lw in self.laws) + 2 * self.lead_s) * fs
                          / self.block_size)
        return 2 + sweep, 2 * self.max_control_iterations + sweep

    def stored_bytes(self, n_channels: int, fs: float) -> int:
        return (self.blocks_per_level(fs)[0] - 2) * self.block_size * n_channels * 8

    def settings(self, channels: list[Channel]) -> JsonObject:
        plan = dict(self.__dict__)
        plan["laws"] = [dict(law.__dict__) for law in self.laws]
        return plan

    def start_info(self) -> dict[str, Any]:
        return {"averages": 1}   # sweep: H1 live

    def run(self, runner: Any) -> None:
        runner.swept(self)


@dataclass
class Campaign:
    """A validated campaign."""

    name: str
    shaker_url: str
    daq_url: str
    fs: float
    channels: list[Channel]
    response_kind: str                   # a `ResponseKind`, or ``MIXED`` with a sensor map
    plan: LevelPlan                      # the kind's plan (`PLANS`)
    plant: PlantSpec | None = None
    frame_size: int = 32
    comms_timeout: float | None = None   # None: the DAQ driver's frame interval + margin
    ramp_time: float = DEFAULT_RAMP_TIME
    gain_guess: float = 1.0
    max_drive: float = 10.0
    watchdog: float | None = None
    limits: dict[str, float] = field(default_factory=dict)
    pace: float | None = None
    faults: TomlTable = field(default_factory=dict)
    source: Path | None = None
    raw: TomlTable = field(default_factory=dict)
    sensors: SensorMap | None = None   # [sensors]: channels at model points (sim:// only)

    @property
    def kind(self) -> str:
        """The campaign file's ``kind``: its plan's (an `Excitation` for the built-in kinds)."""
        return self.plan.kind

    @property
    def simulated(self) -> bool:
        return scheme(self.shaker_url) in SIMULATED

    def blocks_per_level(self) -> tuple[int, int]:
        """DAQ blocks of ``plan.block_size`` one level takes: at least (level control right
        at once, every step settled at the first check) and at most (every control and
        settling allowance used); drive ramps and transport latency come on top."""
        return self.plan.blocks_per_level(self.fs)

    def plan_size(self) -> tuple[float, float, int]:
        """Least and most measurement time (s) of the whole plan (see `blocks_per_level`), and
        the bytes of float64 samples the least time records on every channel."""
        lo, hi = self.blocks_per_level()
        samples = len(self.levels) * lo * self.plan.block_size
        return samples / self.fs, len(self.levels) * hi * self.plan.block_size / self.fs, \
            samples * len(self.channels) * 8

    def stored_bytes(self) -> int:
        """Bytes the run file holds at the end of the plan: the samples of every stored
        block or step on every channel (float64) and each step's harmonics (JSON) in
        stepped-sine runs."""
        return len(self.levels) * self.plan.stored_bytes(len(self.channels), self.fs)

    def plan_summary(self) -> str:
        """One line: the planned measurement time and recorded data."""
        lo, hi, nbytes = self.plan_size()
        return (f"measurement time {duration(lo)} to {duration(hi)} (level control and "
                f"settling) plus drive ramps, at least {nbytes / 1e6:.3g} MB of data")

    def plan_excess(self, model=None) -> str | None:
        """Why the plan is beyond what `campaign run` starts unconfirmed, or None; with the
        simulated plant's ``model``, also the plant's work (`nlid_lab.sim_budget`)."""
        lo, _, nbytes = self.plan_size()
        if model is not None and self.plant is not None:
            too_much = excess(model, self.fs, round(lo * self.fs), self.plant.oversample)
            if too_much:
                return f"the plan: {too_much}"
        if lo > MAX_PLAN_S:
            return f"the plan takes at least {duration(lo)}, more than {duration(MAX_PLAN_S)}"
        if nbytes > MAX_PLAN_BYTES:
            return (f"the plan records at least {nbytes / 1e9:.3g} GB, more than "
                    f"{MAX_PLAN_BYTES / 1e9:.3g} GB")
        return None

    @property
    def force_dof(self) -> int:
        """Response channel (DOF of the run) at the shaker's point."""
        return next(c.dof for c in self.channels if c.quantity == "force")

    @property
    def plant_kind(self) -> str:
        """The simulated plant's response kind: the channels' kind, the highest one when
        a sensor map mixes kinds (`[plant] noise_std` is added to channels of that kind)."""
        if self.response_kind != MIXED:
            return self.response_kind
        return max(self.sensors.response_kinds, key=KIND_ORDER.__getitem__)

    def daq_channels(self, model) -> list[Channel]:
        """The channels as the simulated DAQ reads them: with a sensor map, each at its
        point's index in ``model`` (the run's channels are numbered in map order)."""
        if self.sensors is None:
            return self.channels
        smap = self.sensors
        points = [smap.force_points[0]] + list(smap.response_points)
        return [Channel(ch.name, ch.quantity, model.point_index(p), ch.sensitivity, ch.unit)
                for ch, p in zip(self.channels, points)]

    @property
    def n_dof(self) -> int:
        return sum(c.quantity != "force" for c in self.channels)

    @property
    def levels(self) -> list[float]:
        return self.plan.levels

    def fault_spec(self) -> FaultSpec:
        return FaultSpec.from_dict(self.faults, "emulator.faults")


def duration(seconds: float) -> str:
    """``seconds`` as s, min or h for the terminal."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.1f} min" if seconds < 7200 else f"{seconds / 3600:.1f} h"


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


def _sweep(data: dict, fs: float) -> SweepSpec:
    """The [sweep] table: levels (force amplitudes), start, stop, law, rate, direction."""
    t = _table(data, "sweep")
    _unknown(t, {"levels", "start", "stop", "law", "rate", "direction", "block_size",
                 "tolerance", "max_control_iterations", "lead"}, "sweep")
    start = _num(t, "start", "sweep", lo=0.0, open_lo=True)
    stop = _num(t, "stop", "sweep", lo=0.0, open_lo=True)
    if not start < stop < fs / 2:
        raise CampaignError(f"[sweep] need 0 < start < stop < fs/2 = {fs / 2:g} Hz (direction "
                            f"says which way), got {start:g}, {stop:g}")
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
    return SweepSpec([a for a in amps for _ in ways], [w for _ in amps for w in ways],
                     _opt(t, "block_size", "sweep", SweepSpec, lo=16, hi=2**22, integer=True),
                     _opt(t, "tolerance", "sweep", SweepSpec, lo=0, open_lo=True, hi=1),
                     _opt(t, "max_control_iterations", "sweep", SweepSpec, lo=1, integer=True,
                          hi=100),
                     _opt(t, "lead", "sweep", SweepSpec, "lead_s", lo=0.0, hi=60))


def _plant(data: TomlTable, base: Path | None, shaker_url: str, daq_url: str
           ) -> PlantSpec | None:
    """The ``[plant]`` of a simulated bench (None for real hardware); both devices simulated
    or both real, and ``sim://`` for both or neither."""
    sims = [scheme(u) in SIMULATED for u in (shaker_url, daq_url)]
    if sims[0] != sims[1]:
        raise CampaignError("shaker and DAQ must both be simulated (sim://, serial-emu://, "
                            "can-emu://) or both real: one simulated plant is one loop")
    if (scheme(shaker_url) == "sim") != (scheme(daq_url) == "sim"):
        raise CampaignError("sim:// is in-process: use it for both shaker and DAQ, or use "
                            "emulators for both")
    if not sims[0]:
        return None
    p = _table(data, "plant")
    _unknown(p, {"model", "seed", "shaker_gain", "noise_std", "oversample"}, "plant")
    if not isinstance(p.get("model"), str):
        raise CampaignError("[plant] model must be the path of a model TOML file")
    model = Path(p["model"])
    if not model.is_absolute() and base is not None:
        model = base / model
    over = p.get("oversample")
    if over is not None:
        over = _num(p, "oversample", "plant", lo=1, integer=True, hi=1000)
    return PlantSpec(model, _opt(p, "seed", "plant", PlantSpec, lo=0, integer=True),
                     _opt(p, "shaker_gain", "plant", PlantSpec, lo=0, open_lo=True),
                     _opt(p, "noise_std", "plant", PlantSpec, lo=0), over)


def parse_campaign(data: TomlTable, base: Path | None = None) -> Campaign:
    """Validate a campaign dict (as read from TOML); paths relative to ``base``."""
    if not isinstance(data, dict):
        raise CampaignError("a campaign file is a TOML table")
    _unknown(data, TOP_KEYS | {p.table for p in PLANS.values()}, "top level")
    plan_class = plan_of(data)
    shaker, daq = _table(data, "shaker"), _table(data, "daq")
    _unknown(shaker, {"url", "ramp_time", "gain_guess", "max_drive", "watchdog"}, "shaker")
    _unknown(daq, {"url", "fs", "frame_size", "response_kind", "comms_timeout"}, "daq")
    shaker_url, daq_url = _url(shaker, Role.SHAKER), _url(daq, Role.DAQ)
    fs = _num(daq, "fs", "daq", lo=0.0, open_lo=True, hi=1e6)
    response_kind = _choice(daq.get("response_kind", ResponseKind.DISPLACEMENT), ResponseKind,
                            "[daq] response_kind")
    sensors = _sensors(data, daq, daq_url)
    if sensors is None:
        channels = _channels(data.get("channel"))
        _check_channel_set(channels, response_kind)
    else:
        channels, response_kind = _sensor_channels(sensors), sensors.kind
    plant = _plant(data, base, shaker_url, daq_url)
    limits = _limits(data, channels)
    pace, faults = _emulator(data)
    watchdog = _watchdog(shaker)
    frame_default = max(1, min(256, int(fs / 32)))
    name = data.get("name", "campaign")
    if not isinstance(name, str):
        raise CampaignError("name must be a string")
    plan = plan_class.from_table(data, fs)
    plan.check(channels)
    return Campaign(
        name=name, shaker_url=shaker_url, daq_url=daq_url, fs=fs,
        channels=channels, response_kind=response_kind, plan=plan,
        plant=plant,
        frame_size=_num(daq, "frame_size", "daq", default=frame_default, lo=1, hi=4096,
                        integer=True),
        comms_timeout=_opt(daq, "comms_timeout", "daq", Campaign, lo=0.001, hi=60),
        ramp_time=_opt(shaker, "ramp_time", "shaker", Campaign, lo=0.0, hi=10),
        gain_guess=_opt(shaker, "gain_guess", "shaker", Campaign, lo=0.0, open_lo=True),
        max_drive=_opt(shaker, "max_drive", "shaker", Campaign, lo=0.0, open_lo=True),
        watchdog=watchdog,
        limits=limits, pace=pace, faults=dict(faults),
        source=None, raw=data, sensors=sensors)


def load_plant_model(campaign: Campaign):
    """The simulated plant's `Model`, checked against the campaign's response channels."""
    assert campaign.plant is not None
    model = Model.load(campaign.plant.model)
    if campaign.sensors is not None:
        for point in campaign.sensors.response_points:
            if point not in model.points:
                raise CampaignError(f"[sensors] point '{point}' is not in the model "
                                    f"{campaign.plant.model.name} (its points: "
                                    f"{', '.join(model.points)}); fix the name")
        return model
    if model.n_dof != campaign.n_dof:
        raise CampaignError(f"the model has {model.n_dof} DOFs but the campaign lists "
                            f"{campaign.n_dof} response channels; give one per DOF")
    return model


def load_campaign(path: str | Path) -> Campaign:
    """Read and validate a campaign TOML file."""
    path = Path(path)
    text = read_text(path, "campaign file", CampaignError)
    data = parse_toml(text, str(path), CampaignError)
    try:
        campaign = parse_campaign(data, path.resolve().parent)
    except CampaignError as exc:
        raise CampaignError(f"{path}: {exc}") from None
    campaign.source = path
    return campaign
