"""The device tables of a campaign file: ``[shaker]`` and ``[daq]`` URLs (their schemes from
the driver registry), ``[[channel]]`` or ``[sensors]``, ``[safety]`` limits, ``[emulator]``
pace and faults, the shaker's watchdog (`_campaign_config` reads the rest)."""

from __future__ import annotations

from enum import StrEnum
from typing import Any
from urllib.parse import urlsplit

from analysis.documents import TomlTable
from analysis.errors import RecordingError
from analysis.recordings import SensorMap, table_keys
from drivers import DAQS, SHAKERS, Channel, DriverConfigError
from drivers.faults import FaultSpec

from ._campaign_fields import CampaignError, _num, _opt, _table, _unknown

#: Simulated benches: ``sim`` runs both devices in-process; ``<scheme>-emu`` starts the bundled
#: emulator of a registered backend and connects that backend's driver to it.
EMULATED = {"serial-emu": "serial", "can-emu": "can"}
SIMULATED = ("sim", *EMULATED)


class Role(StrEnum):
    """The two devices of a campaign, each a table of the campaign file."""

    SHAKER = "shaker"
    DAQ = "daq"


def schemes(role: Role) -> tuple[str, ...]:
    """The URL schemes a campaign accepts for ``role``: the driver registry's backends
    (`drivers.SHAKERS`, `drivers.DAQS`), their emulated benches, ``sim``."""
    backends = SHAKERS if role == Role.SHAKER else DAQS
    emulated = tuple(emu for emu, real in EMULATED.items() if real in backends)
    return (*backends, *emulated)


def scheme(url: str) -> str:
    """The scheme of a device URL (``sim``, ``serial``, ``can-emu``, ...)."""
    return urlsplit(url).scheme


def _url(table: dict, role: Role) -> str:
    url, allowed = table.get("url"), schemes(role)
    if not isinstance(url, str) or scheme(url) not in allowed:
        raise CampaignError(f"[{role}] url must be a string starting with one of "
                            f"{', '.join(s + '://' for s in allowed)}, got {url!r}")
    return url


def _channels(raw: Any) -> list[Channel]:
    if not isinstance(raw, list) or not raw or not all(isinstance(c, dict) for c in raw):
        raise CampaignError("give the DAQ inputs as [[channel]] tables (name, quantity, dof, "
                            "sensitivity)")
    out = []
    for i, c in enumerate(raw):
        _unknown(c, {"name", "quantity", "dof", "sensitivity", "unit"}, f"channel {i}")
        if not isinstance(c.get("name"), str) or not c["name"]:
            raise CampaignError(f"[[channel]] {i} needs a non-empty 'name'")
        dof = c.get("dof")
        if isinstance(dof, bool) or not isinstance(dof, int):
            raise CampaignError(f"channel '{c['name']}': dof must be an integer (0-based)")
        sens = _opt(c, "sensitivity", f"channel {c['name']}", Channel, lo=0.0, open_lo=True)
        try:
            out.append(Channel(c["name"], str(c.get("quantity", "")), dof, sens,
                               str(c.get("unit", ""))))
        except DriverConfigError as exc:
            raise CampaignError(str(exc)) from None
    return out


def _sensors(data: dict, daq: dict, daq_url: str) -> SensorMap | None:
    """The [sensors] table (the vocabulary of a ``--sensors`` file) as a `SensorMap`, or None."""
    if "sensors" not in data:
        return None
    if "channel" in data:
        raise CampaignError("give [sensors] or [[channel]] tables, not both: with [sensors] the "
                            "channels are its points, named after them")
    if scheme(daq_url) != "sim":
        raise CampaignError(f"[sensors] needs the sim:// backend ({scheme(daq_url)}:// streams "
                            "one [[channel]] per model DOF); drop [sensors] and give [[channel]] "
                            "tables, or use sim://")
    try:
        keys = table_keys(data["sensors"], "[sensors]")
    except RecordingError as exc:
        raise CampaignError(str(exc)) from None
    for key in ("response_points", "force_points"):
        if key not in keys:
            raise CampaignError(f"[sensors] needs {key}, e.g. {key} = [\"drive\"]")
    if len(keys["force_points"]) != 1:
        raise CampaignError(f"[sensors] force_points names {len(keys['force_points'])} "
                            "points; give the one point the shaker drives")
    try:
        smap = SensorMap.from_keys(keys, len(keys["response_points"]), [],
                                   daq.get("response_kind"))
        smap.validate(len(smap.response_points), 1)
    except RecordingError as exc:
        raise CampaignError(f"[sensors] {exc}") from None
    return smap


def _sensor_channels(smap: SensorMap) -> list[Channel]:
    """The channels a sensor map records: the force (``force@POINT``), then one per response
    point in its kind, named after the point; ``dof`` is the run's channel number."""
    force = Channel(f"force@{smap.force_points[0]}", "force", smap.force_channels[0])
    return [force] + [Channel(p, k, j) for j, (p, k) in
                      enumerate(zip(smap.response_points, smap.response_kinds))]


def _check_channel_set(channels: list[Channel], kind: str) -> None:
    names = [c.name for c in channels]
    if len(set(names)) != len(names):
        raise CampaignError(f"channel names must be unique, got {names}")
    forces = [c for c in channels if c.quantity == "force"]
    if len(forces) != 1:
        raise CampaignError(f"give exactly one force channel (one shaker), got {len(forces)}")
    resp = [c for c in channels if c.quantity != "force"]
    if not resp or any(c.quantity != kind for c in resp):
        raise CampaignError(f"every response channel must measure '{kind}' "
                            "(daq.response_kind)")
    if sorted(c.dof for c in resp) != list(range(len(resp))):
        raise CampaignError("give one response channel per DOF 0..n_dof-1, got DOFs "
                            f"{sorted(c.dof for c in resp)}")
    if forces[0].dof >= len(resp):
        raise CampaignError(f"force channel DOF {forces[0].dof} has no response channel")


def _limits(data: TomlTable, channels: list[Channel]) -> dict[str, float]:
    """``[safety] limits``: channel name -> max |value|."""
    safety = _table(data, "safety", required=False)
    _unknown(safety, {"limits"}, "safety")
    limits = safety.get("limits", {})
    if not isinstance(limits, dict):
        raise CampaignError("[safety] limits must be a table {channel name = max |value|}")
    for key, value in limits.items():
        if key not in {c.name for c in channels}:
            raise CampaignError(f"[safety] limits names unknown channel '{key}' (channels: "
                                f"{', '.join(c.name for c in channels)})")
        _num(limits, key, "safety.limits", lo=0.0, open_lo=True)
    return {k: float(v) for k, v in limits.items()}


def _emulator(data: TomlTable) -> tuple[float | None, TomlTable]:
    """``[emulator]`` pace and faults (checked by `FaultSpec`, kept as written)."""
    emu = _table(data, "emulator", required=False)
    _unknown(emu, {"pace", "faults"}, "emulator")
    pace = _num(emu, "pace", "emulator", default=None, lo=0.0) if "pace" in emu else None
    faults = emu.get("faults", {})
    if not isinstance(faults, dict):
        raise CampaignError("[emulator] faults must be a table")
    try:
        FaultSpec.from_dict(faults, "emulator.faults")
    except DriverConfigError as exc:
        raise CampaignError(str(exc)) from None
    return pace, faults


def _watchdog(shaker: TomlTable) -> float | None:
    """``[shaker] watchdog``, s: 0 (off) or 0.02..60; None when not given."""
    if "watchdog" not in shaker:
        return None
    watchdog = _num(shaker, "watchdog", "shaker", lo=0.0, hi=60)
    if 0 < watchdog < 0.02:
        raise CampaignError(f"[shaker] watchdog must be 0 (off) or 0.02..60 s, got "
                            f"{watchdog!r}")
    return watchdog
