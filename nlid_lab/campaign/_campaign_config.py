"""Campaign files (TOML): parsing and validation into a `Campaign` (docs/campaign-format.md).

Every problem raises `CampaignError` (an `InputError`: the CLI exits 2) naming the key and
the fix. Relative paths are resolved against the campaign file's folder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from analysis.documents import TomlTable
from analysis.models import Model, parse_toml, read_text
from analysis.recordings import KIND_ORDER, MIXED, ResponseKind, SensorMap
from drivers import DEFAULT_RAMP_TIME, Channel
from drivers.faults import FaultSpec

from ..sim_budget import excess
from ._campaign_devices import (SIMULATED, Role, _channels, _check_channel_set, _emulator,
                               _limits, _sensor_channels, _sensors, _url, _watchdog, scheme)
from ._campaign_fields import CampaignError, _choice, _num, _opt, _table, _unknown
from ._plans import PLANS, LevelPlan, plan_of
from . import _kinds  # noqa: F401  (registers the built-in kinds in PLANS)

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
