"""Monitor channels of a recording file (``Recording.monitors``): the keys ``monitor``,
``monitor_names`` and ``monitor_units`` (docs/recording-formats.md#monitor-channels).

A monitor is a channel that is neither force nor response (the shaker amplifier's drive
voltage of a GVT export): kept as recorded, never read by an estimator. In NPZ and MAT files
all monitors are one array ``monitor`` shaped like ``force`` with one column per monitor;
``monitor_names`` names the columns, ``monitor_units`` gives their units (``""``: none). CSV
files write them as columns after the responses, named as the monitors, with the two name
keys as ``# key = value`` lines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.errors import InputError
from analysis.recordings import Recording, RecordingKeys, names

from ._units import split_label

MONITOR_KEYS = ("monitor", "monitor_names", "monitor_units")


def monitor_fields(data: RecordingKeys, force_shape: tuple[int, ...], path: Path
                   ) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """``Recording.monitors`` and ``monitor_units`` from a file's keys (none: empty dicts).

    Raises
    ------
    InputError
        ``monitor`` without names (or names without ``monitor``), a column count that is not
        the number of names, repeated names, or samples that are not the force's.
    """
    if "monitor" not in data and "monitor_names" not in data:
        if "monitor_units" in data:
            raise InputError(f"{path}: monitor_units given without monitor; remove it")
        return {}, {}
    if "monitor" not in data or "monitor_names" not in data:
        have, lack = (("monitor", "monitor_names") if "monitor" in data
                      else ("monitor_names", "monitor"))
        raise InputError(f"{path}: {have} given without {lack}; give both (a monitor array "
                         "and one name per column)")
    arr = np.asarray(data["monitor"])
    if arr.dtype.kind not in "iuf":
        raise InputError(f"{path}: 'monitor' must hold real numbers, got dtype {arr.dtype}")
    labels = names(data["monitor_names"], "monitor_names")
    units = (names(data["monitor_units"], "monitor_units") if "monitor_units" in data
             else [""] * len(labels))
    if arr.shape[:-1] != tuple(force_shape) or arr.ndim != len(force_shape) + 1:
        want = tuple(force_shape) + (len(labels),)
        raise InputError(f"{path}: 'monitor' has shape {arr.shape}; expected {want} (the "
                         "force's samples, one column per monitor)")
    if arr.shape[-1] != len(labels) or len(units) != len(labels):
        raise InputError(f"{path}: 'monitor' has {arr.shape[-1]} column(s), monitor_names "
                         f"{len(labels)} and monitor_units {len(units)}; give one name and "
                         "unit per column")
    if len(set(labels)) != len(labels):
        raise InputError(f"{path}: monitor_names {labels} repeats a name; rename one")
    monitors = {name: arr[..., j] for j, name in enumerate(labels)}
    return monitors, {n: u for n, u in zip(labels, units) if u}


def monitor_keys(rec: Recording) -> dict[str, np.ndarray]:
    """The file keys of ``rec``'s monitors (none: an empty dict)."""
    if not rec.monitors:
        return {}
    labels = list(rec.monitors)
    return {"monitor": np.stack([rec.monitors[k] for k in labels], axis=-1),
            "monitor_names": np.array(labels),
            "monitor_units": np.array([rec.monitor_units.get(k, "") for k in labels])}


def trimmed(monitors: dict[str, np.ndarray], lead: int, n: int) -> dict[str, np.ndarray]:
    """``monitors`` cut to the ``n`` samples from ``lead`` on (a swept sine's trimmed span)."""
    return {k: v[lead:lead + n] for k, v in monitors.items()}


def csv_monitor_columns(header: list[str], keys: RecordingKeys, path: Path) -> list[int]:
    """Columns of a CSV header that hold the monitors its ``monitor_names`` key lists (a
    column named exactly so, or so with a unit: ``Voltage (V)``), in the key's order."""
    if "monitor_names" not in keys:
        return []
    wanted = names(keys["monitor_names"], "monitor_names")
    raw = [h.strip() for h in header]
    base = [split_label(h)[0] for h in header]
    cols = []
    for name in wanted:
        hit = raw.index(name) if name in raw else base.index(name) if name in base else None
        if hit is None:
            raise InputError(f"{path}: monitor_names lists '{name}', which is no column of the "
                             "header; fix the '# monitor_names' line")
        cols.append(hit)
    return cols
