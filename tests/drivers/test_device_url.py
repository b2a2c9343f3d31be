"""A device URL parsed once into a frozen `DeviceUrl`: scheme, the backend's positional
arguments and its options (numbers where they read as such)."""

from __future__ import annotations

import dataclasses

import pytest

from drivers.errors import DriverConfigError
from drivers.registry import DeviceUrl, parse_url


def test_urls_parse_into_their_fields():
    assert parse_url("serial:///dev/ttyUSB0?baud=115200&parity=N") == DeviceUrl(
        "serial", ("/dev/ttyUSB0",), {"baud": 115200, "parity": "N"})
    assert parse_url("can://virtual/channel0?bitrate=500000") == DeviceUrl(
        "can", ("virtual", "channel0"), {"bitrate": 500000})
    assert parse_url("sim://rig?gain=0.5") == DeviceUrl("sim", ("rig",), {"gain": 0.5})
    assert parse_url("sim://") == DeviceUrl("sim", (), {})
    with pytest.raises(dataclasses.FrozenInstanceError):
        parse_url("sim://").scheme = "can"


@pytest.mark.parametrize("url, match", [("ttyUSB0", "no scheme"), ("serial://", "no port"),
                                        ("can://virtual", "interface and a channel")])
def test_bad_urls_name_the_fix(url, match):
    with pytest.raises(DriverConfigError, match=match):
        parse_url(url)
