"""Sensor-map TOML files (docs/model-format.md#sensor-maps) and applying one to a recording."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from analysis.errors import RecordingError
from analysis.models import parse_toml, read_text
from analysis.recordings import Recording, SensorMap, sensor_map, table_keys

from ._recording_keys import RecordingFileError


def read_sensors(path: str | os.PathLike) -> dict[str, list[str]]:
    """A sensor-map TOML file (``response_points``, ``response_kinds``, ``force_points``:
    lists of names; docs/model-format.md#sensor-maps) as recording keys."""
    path = Path(path)
    text = read_text(path, "sensor map", RecordingFileError, max_bytes=1 << 16)
    data = parse_toml(text, str(path), RecordingFileError)
    try:
        return table_keys(data, "a sensor map")
    except RecordingError as exc:
        raise RecordingFileError(f"{path}: {exc}") from None


def with_sensors(rec: Recording, keys: dict[str, list[str]]) -> Recording:
    """``rec`` with the sensor map of ``keys`` (`read_sensors`; missing keys from ``rec``'s
    own map); the force DOFs follow ``force_points``."""
    own = sensor_map(rec).to_keys() if rec.sensors is not None else {}
    merged = {**own, **{k: np.array(v) for k, v in keys.items()}}
    try:
        smap = SensorMap.from_keys(merged, rec.n_dof, rec.force_dofs, None)
        smap.validate(rec.n_dof, rec.n_in)
        return dataclasses.replace(rec, force_dofs=np.asarray(smap.force_channels),
                                   sensors=smap, extra=dict(rec.extra), meta=dict(rec.meta))
    except ValueError as exc:
        raise RecordingFileError(f"{rec.meta.get('source', 'recording')}: {exc}") from None
