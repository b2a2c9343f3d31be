"""Stepped-sine table levels in run files (`analysis.recordings.StepTable`, run schema 3).

A table run has the run file's header, levels table, log and results as any run (so
``save_result``, ``view`` and ``report`` work unchanged) and no sample blocks: each level's
table is the group ``/steptables/<index>`` with datasets ``freqs``, ``force_phasor``,
``response_phasor`` (and ``harmonics``, ``force_harmonics``, ``response_harmonics`` when
given), its own ``extra`` keys, and attributes ``control``, ``control_dof``, ``level`` and
``crc`` (CRC-32 of the phasors, checked on read). The run's attribute ``layout = "table"``
marks it; ``fs`` is NaN. Written whole into a temporary file renamed into place: a killed
import leaves no run file.
"""

from __future__ import annotations

import json
import os
import zlib
from pathlib import Path
from typing import Sequence

import h5py
import numpy as np

from analysis.documents import JsonObject
from analysis.recordings import KEYS as SENSOR_KEYS, SensorMap, StepTable

from ._common import (FORMAT, SOFTWARE, StoreError, _default_channels, _channel_table,
                      _json_default, _read_extra, _write_extra, utc_now)
from ._rebuild import _create

#: run schema of table runs: older readers refuse them ("upgrade nlid-lab")
TABLES_SCHEMA_VERSION = 3
#: the run attribute marking a table run
LAYOUT = "table"
_ARRAYS = ("freqs", "force_phasor", "response_phasor", "harmonics", "force_harmonics",
           "response_harmonics")


def is_table_run(meta: JsonObject) -> bool:
    """True for the attributes of a run whose levels are tables."""
    return meta.get("layout") == LAYOUT


def _crc(arrays: Sequence[np.ndarray]) -> int:
    crc = 0
    for arr in arrays:
        crc = zlib.crc32(np.ascontiguousarray(arr).tobytes(), crc)
    return crc


def _check_same_run(tables: Sequence[StepTable]) -> None:
    first = tables[0]
    for i, t in enumerate(tables[1:], 2):
        same = {"force_dofs": np.array_equal(first.force_dofs, t.force_dofs),
                "response channels": first.n_dof == t.n_dof,
                "response_kind": first.response_kind == t.response_kind,
                "control": first.control == t.control,
                "control_dof": first.control_dof == t.control_dof,
                "sensor map": first.sensors == t.sensors}
        for what, ok in same.items():
            if not ok:
                raise StoreError(f"table {i} differs from the first in its {what}; levels of "
                                 "one run share it (import them as separate runs)")


def save_tables(path: str | os.PathLike, tables: Sequence[StepTable], *, source: str = "import",
                settings: dict | None = None, model_toml: str | None = None) -> None:
    """Write tables as the levels of one complete run file (replacing ``path``)."""
    path = Path(path)
    tables = list(tables)
    if not tables:
        raise StoreError("no table to store")
    _check_same_run(tables)
    first = tables[0]
    attrs = {"format": FORMAT, "schema_version": TABLES_SCHEMA_VERSION, "software": SOFTWARE,
             "created_utc": utc_now(), "source": source, "fs": np.nan,
             "excitation": "stepped-sine", "layout": LAYOUT,
             "excitation_settings": json.dumps({"kind": "stepped-sine", "table": True}),
             "settings": json.dumps(settings or {}, default=_json_default),
             "force_dofs": first.force_dofs, "n_dof": first.n_dof,
             "response_kind": first.response_kind, "model_toml": model_toml or "",
             "force_hold": "none", "control": str(first.control),
             "control_dof": -1 if first.control_dof is None else first.control_dof}
    if first.sensors is not None:
        attrs["sensors"] = json.dumps({k: list(getattr(first.sensors, k)) for k in SENSOR_KEYS})
    kind = first.response_kind if first.sensors is None else first.sensors.response_kinds[0]
    chans = _channel_table(_default_channels(first.force_dofs, first.n_dof, kind,
                                             first.sensors), first.force_dofs, first.n_dof)

    def fill(f: h5py.File) -> None:
        f["levels"].resize((len(tables),))
        f["levels"][:] = np.array([(i, t.level, 1) for i, t in enumerate(tables)],
                                  dtype=f["levels"].dtype)
        f["state/status"][()] = np.bytes_("complete")
        f["state/updated_utc"][()] = np.bytes_(utc_now())
        for i, t in enumerate(tables):
            g = f.create_group(f"steptables/{i}")
            arrays = _arrays(t)
            for name, arr in arrays.items():
                g.create_dataset(name, data=arr)
            g.attrs.update(control=str(t.control), level=t.level,
                           control_dof=-1 if t.control_dof is None else t.control_dof,
                           crc=_crc(list(arrays.values())))
            if t.extra:
                _write_extra(g, t.extra)

    _create(path, attrs, chans, fill)


def _arrays(t: StepTable) -> dict[str, np.ndarray]:
    out = {"freqs": t.freqs, "force_phasor": t.force_phasor,
           "response_phasor": t.response_phasor}
    if t.harmonics:
        out.update(harmonics=np.asarray(t.harmonics, dtype=np.int64),
                   force_harmonics=t.force_harmonics, response_harmonics=t.response_harmonics)
    return out


def table_steps(f: h5py.File) -> dict[int, int]:
    """Steps of each stored table level, by level index (what a level's ``n_segments``
    counts in a table run)."""
    group = f.get("steptables")
    return {} if group is None else {int(k): int(g["freqs"].shape[0]) for k, g in group.items()}


def read_table(f: h5py.File, index: int, meta: JsonObject,
               sensors: SensorMap | None) -> StepTable:
    """Level ``index`` of an open table run as a `StepTable` (its checksum verified)."""
    g = f.get(f"steptables/{index}")
    if g is None:
        raise StoreError(f"{f.filename} has no table for level {index}")
    arrays = {name: g[name][()] for name in _ARRAYS if name in g}
    if _crc(list(arrays.values())) != int(g.attrs["crc"]):
        raise StoreError(f"{f.filename} level {index}: the table fails its checksum (the file "
                         "is damaged); import the source again")
    cdof = int(g.attrs["control_dof"])
    return StepTable(
        freqs=arrays["freqs"], force_phasor=arrays["force_phasor"],
        response_phasor=arrays["response_phasor"], force_dofs=meta["force_dofs"],
        control=str(g.attrs["control"]), level=float(g.attrs["level"]),
        response_kind=meta["response_kind"], control_dof=None if cdof < 0 else cdof,
        harmonics=tuple(arrays.get("harmonics", ())),
        force_harmonics=arrays.get("force_harmonics"),
        response_harmonics=arrays.get("response_harmonics"), sensors=sensors,
        extra=_read_extra(g),
        meta={"run": str(f.filename), "level_index": index, "source": meta.get("source"),
              "settings": meta.get("settings")})
