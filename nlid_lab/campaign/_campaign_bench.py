"""Open the shaker and DAQ of a campaign, starting the simulated rig and emulators it names.

``sim://`` runs both devices in-process on one `SimRig`; ``serial-emu://`` and
``can-emu://INTERFACE/CHANNEL`` start the bundled emulators on that rig (pseudo-terminals,
python-can bus) and connect the production ``serial://`` / ``can://`` drivers to them.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from drivers.base import Acquirer, Channel, SignalGenerator, default_stall_timeout
from drivers.errors import DriverConfigError
from drivers.registry import open_daq, open_shaker
from drivers.rig import SimRig

from ._campaign_config import Campaign, CampaignError, load_plant_model
from ._campaign_devices import scheme

#: x real time. CAN at 4: the python-can virtual bus copies every frame (~20 us each), and at
#: 8x a 1024 Hz stream (8,192 frames/s, the most a 1 Mbit/s bus carries) took the process
#: more CPU than a loaded 2-core machine gives it, starving the shaker's watchdog feeder
DEFAULT_PACE = {"serial-emu": 8.0, "can-emu": 4.0}


@dataclass
class Bench:
    """The open devices of a campaign (and the simulation behind them, if any)."""

    shaker: SignalGenerator
    daq: Acquirer
    source: str
    rig: SimRig | None = None
    model_toml: str | None = None
    emulators: list[Any] = field(default_factory=list)
    channels: list[Channel] = field(default_factory=list)   # as the DAQ reads them

    @property
    def daq_emulator(self) -> Any:
        return next((e for e in self.emulators if hasattr(e, "wiring")), None)

    @property
    def shaker_emulator(self) -> Any:
        return next((e for e in self.emulators if hasattr(e, "IDN") and "SHAKER" in e.IDN),
                    None)


def _query(url: str) -> dict[str, str]:
    return dict(parse_qsl(urlsplit(url).query))


def _pace(campaign: Campaign, url: str) -> float:
    q = _query(url)
    try:
        pace = float(q["pace"]) if "pace" in q else campaign.pace
    except ValueError:
        raise CampaignError(f"pace in '{url}' must be a number") from None
    return DEFAULT_PACE[scheme(url)] if pace is None else pace


def _rig(campaign: Campaign) -> tuple[SimRig, str, list[Channel]]:
    """The simulated rig, its model's text and the channels at the model's points."""
    spec = campaign.plant
    assert spec is not None
    model = load_plant_model(campaign)
    channels = campaign.daq_channels(model)
    force_dof = next(ch.dof for ch in channels if ch.quantity == "force")
    rig = SimRig(model, campaign.fs, force_dof, shaker_gain=spec.shaker_gain,
                 noise_std=spec.noise_std, response_kind=campaign.plant_kind,
                 seed=spec.seed, oversample=spec.oversample)
    return rig, spec.model.read_text(), channels


@contextlib.contextmanager
def open_bench(campaign: Campaign):
    """Context manager yielding a `Bench`; closes devices, then emulators."""
    stack = contextlib.ExitStack()
    with stack:
        rig = model_toml = None
        channels = campaign.channels
        if campaign.simulated:
            rig, model_toml, channels = _rig(campaign)
        emulators: list[Any] = []
        # the DAQ first: its imports and bus set-up (python-can scans its plugins: 100-300 ms
        # on a loaded machine, GIL held) must not starve the shaker's watchdog feeder, which
        # runs from the shaker's opening on; closed in reverse, the drive stops first
        daq = stack.enter_context(_open_daq(campaign, rig, emulators, stack))
        shaker = stack.enter_context(_open_shaker(campaign, rig, emulators, stack))
        yield Bench(shaker, daq, scheme(campaign.daq_url).replace("-emu", ""), rig,
                    model_toml, emulators, channels)


def _closing_emulator(emu: Any, emulators: list[Any], stack: contextlib.ExitStack) -> Any:
    emu.start()
    emulators.append(emu)
    stack.callback(emu.close)
    return emu


def _open_shaker(c: Campaign, rig: SimRig | None, emulators: list[Any],
                 stack: contextlib.ExitStack) -> SignalGenerator:
    kind = scheme(c.shaker_url)
    if kind == "sim":  # in-process: the drive dies with the host, no link to watch
        return open_shaker("sim://", rig=rig, ramp_time=c.ramp_time)
    options: dict[str, Any] = {"ramp_time": c.ramp_time}
    if c.watchdog is not None:
        options["watchdog"] = c.watchdog
    if kind == "serial-emu":
        from drivers.emulators import SerialShakerEmulator   # emulators start on use
        emu = _closing_emulator(SerialShakerEmulator(rig), emulators, stack)
        return open_shaker(f"serial://{emu.port}", **options)
    return open_shaker(c.shaker_url, **options)


def _open_daq(c: Campaign, rig: SimRig | None, emulators: list[Any],
              stack: contextlib.ExitStack) -> Acquirer:
    kind = scheme(c.daq_url)
    if kind == "sim":
        return open_daq("sim://", rig=rig)
    faults = c.fault_spec()
    if kind == "serial-emu":
        from drivers.emulators import SerialDaqEmulator   # emulators start on use
        pace = _pace(c, c.daq_url)
        emu = _closing_emulator(SerialDaqEmulator(rig, c.channels, pace=pace, faults=faults),
                                emulators, stack)
        # its frames come `pace` times as often as a real device's
        interval = c.frame_size / (c.fs * pace) if pace > 0 else 0.0
        return open_daq(f"serial://{emu.port}",
                        stall_timeout=c.comms_timeout or default_stall_timeout(interval))
    if kind == "can-emu":
        from drivers.emulators import ROWS_PER_TICK, CanDaqEmulator   # needs python-can (extra)
        parts = urlsplit(c.daq_url)
        channel = parts.path.strip("/")
        if not parts.netloc or not channel:
            raise DriverConfigError(f"'{c.daq_url}': write can-emu://INTERFACE/CHANNEL, e.g. "
                                    "can-emu://virtual/nlid0")
        pace = _pace(c, c.daq_url)
        _closing_emulator(CanDaqEmulator(rig, c.channels, parts.netloc, channel, pace=pace,
                                         faults=faults), emulators, stack)
        # it sends sample rows in bursts of ROWS_PER_TICK, `pace` times as often as real time
        interval = ROWS_PER_TICK / (c.fs * pace)
        return open_daq(f"can://{parts.netloc}/{channel}",
                        stall_timeout=c.comms_timeout or default_stall_timeout(interval))
    return open_daq(c.daq_url, stall_timeout=c.comms_timeout)
