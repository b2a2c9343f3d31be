"""Lazy registry of backends, chosen by name or URL (python-can ``interfaces`` style).

``open_shaker(url, **kw)`` / ``open_daq(url, **kw)`` import the backend module only when its
scheme is used, so a missing optional dependency (python-can) matters only to CAN users.

=========================================  ==================================================
URL                                        backend
=========================================  ==================================================
``sim://NAME``                             `drivers.sim` (rig by ``rig=`` or registered name)
``serial:///dev/ttyUSB0?baud=115200``      `drivers.serial_shaker` / `drivers.serial_daq`
``can://INTERFACE/CHANNEL?bitrate=500000`` `drivers.can_daq` (DAQ only)
=========================================  ==================================================
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qsl, urlsplit

from .base import Acquirer, SignalGenerator
from .errors import DriverConfigError, UnknownBackendError

SHAKERS: dict[str, tuple[str, str]] = {
    "sim": ("drivers.sim", "SimShaker"),
    "serial": ("drivers.serial_shaker", "SerialShaker"),
}
DAQS: dict[str, tuple[str, str]] = {
    "sim": ("drivers.sim", "SimDaq"),
    "serial": ("drivers.serial_daq", "SerialDaq"),
    "can": ("drivers.can_daq", "CanDaq"),
}


def _number(text: str) -> Any:
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return text


@dataclass(frozen=True)
class DeviceUrl:
    """A device URL parsed: its scheme, the backend's positional arguments (a serial port;
    a CAN interface and channel) and its query options (numbers where they read as such)."""

    scheme: str
    args: tuple[str, ...]
    options: Mapping[str, Any]


def parse_url(url: str) -> DeviceUrl:
    """Split a device URL into scheme, positional arguments and keyword options."""
    parts = urlsplit(url)
    if not parts.scheme:
        raise DriverConfigError(f"device URL '{url}' has no scheme; write e.g. sim://, "
                                "serial:///dev/ttyUSB0 or can://virtual/channel0")
    query = {k: _number(v) for k, v in parse_qsl(parts.query, keep_blank_values=False)}
    if parts.scheme == "serial":
        if not parts.path:
            raise DriverConfigError(f"serial URL '{url}' names no port; write "
                                    "serial:///dev/ttyUSB0")
        args = [parts.path]
    elif parts.scheme == "can":
        if not parts.netloc or not parts.path.strip("/"):
            raise DriverConfigError(f"CAN URL '{url}' needs an interface and a channel: "
                                    "can://INTERFACE/CHANNEL, e.g. can://virtual/channel0")
        args = [parts.netloc, parts.path.strip("/")]
    else:
        args = [parts.netloc] if parts.netloc else []
    return DeviceUrl(parts.scheme, tuple(args), query)


def _open(table: dict[str, tuple[str, str]], what: str, url: str, kwargs: Mapping[str, Any]):
    parsed = parse_url(url)
    scheme = parsed.scheme
    if scheme not in table:
        raise UnknownBackendError(f"no {what} backend for '{scheme}://'; available: "
                                  f"{', '.join(s + '://' for s in table)}")
    module_name, cls_name = table[scheme]
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownBackendError(f"the {scheme}:// {what} backend needs a missing package "
                                  f"({exc.name}); install nlid-lab[can]") from None
    try:
        return getattr(module, cls_name)(*parsed.args, **{**parsed.options, **kwargs})
    except TypeError as exc:
        raise DriverConfigError(f"bad option for the {scheme}:// {what}: {exc}") from None


def open_shaker(url: str, **kwargs: Any) -> SignalGenerator:
    """Open the shaker controller named by ``url``."""
    return _open(SHAKERS, "shaker", url, kwargs)


def open_daq(url: str, **kwargs: Any) -> Acquirer:
    """Open the DAQ named by ``url``."""
    return _open(DAQS, "DAQ", url, kwargs)
