"""Result tables in HDF5: one dataset per column under ``/table``.

Layout (stable, readable with plain h5py or ``pandas.read_hdf``-free tools)::

    /table                  group; attrs: ``columns`` (JSON list, column order), ``n_rows``,
                            plus the caller's attrs (str/number as they are, others as JSON)
    /table/<column>         1-D dataset, one entry per row:
                            float64 (missing -> NaN), int64, bool or UTF-8 string (missing -> "")

A column's type is taken from its values: all int -> int64, all bool -> bool, numbers with
gaps or floats -> float64, anything else -> string. Rows read back hold every column.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from analysis.documents import JsonObject
from analysis.errors import InputError

from ._space import HEADER_BYTES, require

GROUP = "table"


class TableError(InputError):
    """A results table file is missing, unreadable or not in this layout."""


#: one row of a results table: column name -> scalar (None: missing)
TableRow = dict[str, float | int | bool | str | None]


def write_table(path: str | Path, rows: list[TableRow], attrs: JsonObject) -> None:
    """Write ``rows`` (dicts of scalars) and ``attrs`` to HDF5 file ``path`` (overwritten)."""
    columns: list[str] = []
    for row in rows:
        columns += [key for key in row if key not in columns]
    data = {name: _column([row.get(name) for row in rows]) for name in columns}
    # checked before HDF5 writes anything: a write failing on a full disk leaves h5py unable
    # to close the file (docs/reliability-store.md)
    require(Path(path), sum(np.asarray(d).nbytes for d in data.values()) + HEADER_BYTES,
            f"the results table {path}")
    with h5py.File(path, "w") as f:
        group = f.create_group(GROUP)
        for name in columns:
            group.create_dataset(name, data=data[name])
        group.attrs["columns"] = json.dumps(columns)
        group.attrs["n_rows"] = len(rows)
        for key, value in attrs.items():
            group.attrs[key] = _attr(value)


def read_table(path: str | Path) -> tuple[list[TableRow], JsonObject]:
    """Rows (list of dicts, column order kept) and attrs of a table written by `write_table`."""
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise TableError(f"{path}: cannot open as HDF5 ({exc}); give a results file written "
                         "by 'nlid-lab reanalyze'") from None
    with f:
        if GROUP not in f or "columns" not in f[GROUP].attrs:
            raise TableError(f"{path}: no /{GROUP} group; give a results file written by "
                             "'nlid-lab reanalyze'")
        group = f[GROUP]
        columns = json.loads(group.attrs["columns"])
        n_rows = int(group.attrs["n_rows"])
        data = {name: _values(group[name]) for name in columns}
        attrs = {key: _from_attr(value) for key, value in group.attrs.items()
                 if key not in ("columns", "n_rows")}
    rows = [{name: data[name][i] for name in columns} for i in range(n_rows)]
    return rows, attrs


def _column(values: list[Any]) -> np.ndarray:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, (bool, np.bool_)) for v in present) \
            and len(present) == len(values):
        return np.asarray(values, dtype=bool)
    numeric = all(isinstance(v, (int, float, np.integer, np.floating))
                  and not isinstance(v, (bool, np.bool_)) for v in present)
    if numeric and present:
        if len(present) == len(values) and all(isinstance(v, (int, np.integer))
                                               for v in present):
            return np.asarray(values, dtype=np.int64)
        return np.asarray([math.nan if v is None else float(v) for v in values])
    text = ["" if v is None else str(v) for v in values]
    return np.asarray(text, dtype=h5py.string_dtype("utf-8"))


def _values(dataset: h5py.Dataset) -> list[Any]:
    if h5py.check_string_dtype(dataset.dtype) is not None:
        return [s.decode("utf-8") if isinstance(s, bytes) else str(s) for s in dataset[()]]
    return dataset[()].tolist()


def _attr(value: Any) -> Any:
    if isinstance(value, (str, bool, int, float, np.integer, np.floating)):
        return value
    return "json:" + json.dumps(value)


def _from_attr(value: Any) -> Any:
    if isinstance(value, bytes):
        value = value.decode("utf-8")
    if isinstance(value, str) and value.startswith("json:"):
        return json.loads(value[5:])
    if isinstance(value, np.generic):
        return value.item()
    return value
