"""CSV recordings <-> `analysis.Recording` (docs/recording-formats.md).

CSV holds random and swept-sine recordings: ``# key = value`` comment lines with the recording
keys, then a header row naming a time column (``t`` or ``time``, seconds) and one column per
channel written ``NAME@DOF``; names starting with ``f`` are forces, the others responses
(override with ``force_cols``). Keys no `Recording` field holds are kept in
``Recording.extra`` and written back, so every key survives a round trip. A stepped-sine table
is read and written by `nlid_lab.formats._tables`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from analysis.documents import MatTree
from analysis.models import read_text
from analysis.recordings import (KEYS as SENSOR_KEYS, Excitation, Recording,
                                 RecordingKeys, StepTable, sensor_map)

from ._csv_header import Column, is_force, parse_header
from ._csv_text import MAX_CSV_BYTES, csv_keys, csv_table
from ._monitors import MONITOR_KEYS, csv_monitor_columns, monitor_fields, trimmed
from ._npz import recording_keys
from ._recording_keys import (RecordingFileError, extra_keys, force_hold_of, layout_of,
                              level_of, scalar_key, sensors_of)
from ._sweep_keys import sweep_fields
from ._tables import csv_text, table_from_csv
from ._units import kind_of_name, lookup, split_label


def read_csv(path: str | os.PathLike, force_cols: list[str] | None = None,
             response_kind: str | None = None, level: float | None = None,
             force_dofs: list[int] | None = None, excitation: str | None = None,
             keys: RecordingKeys | None = None) -> Recording:
    """Read a random recording from CSV (see the module docstring for the header).

    ``# key = value`` comment lines before the header carry recording keys (``fs``,
    ``response_kind``, ``force_hold``, ``period``...; others kept in ``extra``; ``force_dofs``
    when the header names no DOF, or the ``force_dofs`` argument). ``response_kind`` None
    takes the unit of the response columns, else the file's key, else displacement.
    ``excitation`` (else a ``# excitation`` line, else random) may be ``"swept-sine"``: the
    sweep keys, or the law estimated from the force (`sweep_keys.sweep_fields`). ``keys``
    add to (override) the file's ``# key`` lines.
    """
    path = Path(path)
    text = read_text(path, "recording", RecordingFileError, max_bytes=MAX_CSV_BYTES)
    keys = {**csv_keys(text, path), **{k: np.asarray(v) for k, v in (keys or {}).items()}}
    names, data = csv_table(text, path)
    if "freqs" in (n.strip() for n in names):        # a stepped-sine table
        return table_from_csv(keys, names, data, path)
    if force_dofs is not None:
        keys["force_dofs"] = np.asarray(force_dofs)
    if data.shape[0] < 2:
        raise RecordingFileError(f"{path}: needs a header row and at least two data rows")
    if data.shape[1] != len(names):
        raise RecordingFileError(f"{path}: {data.shape[1]} data columns but {len(names)} "
                                 "header names")
    names, data = _without_monitors(names, data, keys, path)
    time_col, time_scale, chans = parse_header(names, force_cols)
    fs = _csv_fs(data[:, time_col] * time_scale, keys, path)
    forces, responses = _channels(chans, force_cols, path)
    force_dofs = _csv_force_dofs(keys, forces, responses, path)
    file_kind = scalar_key(keys, "response_kind", str, path) if "response_kind" in keys else None
    kind = _response_kind(keys, responses, file_kind, response_kind, path)
    exc = excitation or (scalar_key(keys, "excitation", str, path) if "excitation" in keys
                         else "random")
    if exc not in (Excitation.RANDOM, Excitation.SWEPT_SINE):
        raise RecordingFileError(f"{path}: CSV holds random or swept-sine recordings, not {exc}")
    keys["excitation"] = np.str_(exc)
    keys.pop("force_dofs", None)
    try:
        file_level, level_from = level_of(keys, path, exc)
        force = data[:, [c.index for c in forces]] * [c.factor for c in forces]
        response = data[:, [c.index for c in responses]] * [c.factor for c in responses]
        monitors, units = monitor_fields(keys, force.shape[:-1], path)
        sweep = None
        if exc == Excitation.SWEPT_SINE:
            sweep, force, response, amplitude = sweep_fields(keys, force, response, fs)
            file_level = amplitude if file_level is None else file_level
            if monitors and len(force) != data.shape[0]:      # law estimated: trimmed
                monitors = trimmed(monitors, sweep.trimmed_lead, force.shape[0])
        sensors, _ = sensors_of({**keys, "force_dofs": np.asarray(force_dofs)}, response,
                              response_kind or file_kind, path)
        return Recording(
            fs=fs, excitation=exc, force_dofs=force_dofs, force=force, response=response,
            response_kind=kind, sensors=sensors,
            level=file_level if level is None else level, force_hold=force_hold_of(keys, path),
            layout=layout_of(keys, path, data.shape[0]), sweep=sweep,
            extra=extra_keys(keys, exc, level_from), monitors=monitors, monitor_units=units,
            meta={"source": str(path), "channels": [c.name for c in forces + responses]})
    except (TypeError, ValueError) as exc:  # RecordingError included: name the file
        raise RecordingFileError(f"{path}: {exc}") from None


def _without_monitors(names: list[str], data: np.ndarray, keys: RecordingKeys, path: Path
                      ) -> tuple[list[str], np.ndarray]:
    """The header and data less the monitor columns, which go to ``keys`` (``monitor``,
    ``monitor_units`` from the header's units unless the file's keys give them)."""
    mcols = csv_monitor_columns(names, keys, path)
    if not mcols:
        return names, data
    keys["monitor"] = data[:, mcols]
    keys.setdefault("monitor_units", np.array([split_label(names[j])[1] or ""
                                               for j in mcols]))
    return [h for j, h in enumerate(names) if j not in mcols], np.delete(data, mcols, axis=1)


def _channels(chans: list[Column], force_cols: list[str] | None, path: Path
              ) -> tuple[list[Column], list[Column]]:
    """The force columns, and the response columns in DOF order (covering 0..n-1)."""
    forces = [c for c in chans if is_force(c, force_cols)]
    responses = [c for c in chans if not is_force(c, force_cols)]
    if not forces or not responses:
        raise RecordingFileError(f"{path}: need at least one force and one response column "
                                 "(forces are named f...@DOF or carry a force unit, 'Force (N)'"
                                 ", unless --force-cols is given)")
    responses = sorted(responses, key=lambda c: c.dof if c.dof is not None else c.index)
    dofs = [c.dof for c in responses]
    if responses[0].dof is not None and dofs != list(range(len(dofs))):
        raise RecordingFileError(f"{path}: response columns must cover DOFs 0..n-1 once each, "
                                 f"got DOFs {dofs}")
    return forces, responses


def _response_kind(keys: RecordingKeys, responses: list[Column], file_kind: str | None,
                   asked: str | None, path: Path) -> str:
    """The response kind: ``asked`` (``--response-kind``), else the file's key, else the
    columns' unit, else displacement; all that are given must agree. Columns whose units name
    different kinds are a sensor map (``response_kinds`` added to ``keys``)."""
    unit_kinds = {c.quantity for c in responses if c.quantity is not None}
    if len(unit_kinds) > 1 and all(c.quantity for c in responses) \
            and "response_kinds" not in keys:   # units say each column's kind: a sensor map
        keys["response_kinds"] = np.array([c.quantity for c in responses])
        unit_kinds = set()
    if len(unit_kinds) > 1 or (unit_kinds and len(unit_kinds) == 1
                               and any(c.quantity is None for c in responses)):
        raise RecordingFileError(f"{path}: the response columns measure different quantities "
                                 f"({', '.join(sorted(map(str, unit_kinds)))}); import them as "
                                 "separate recordings")
    for what, kind in (("the file's response_kind", file_kind), ("--response-kind", asked)):
        if kind is not None and unit_kinds and kind not in unit_kinds:
            raise RecordingFileError(f"{path}: {what} is {kind} but the column units say "
                                     f"{unit_kinds.pop()}; drop one of them")
    if asked is not None and file_kind not in (None, asked):
        raise RecordingFileError(f"{path}: the file says response_kind = {file_kind} but "
                                 f"{asked} was asked for; drop one of them")
    named = {kind_of_name(c.name) for c in responses}      # Acc1, Acceleration2: as a map reads
    return asked or file_kind or (unit_kinds.pop() if unit_kinds else named.pop()
                                  if len(named) == 1 and None not in named else "displacement")


def _csv_force_dofs(keys: dict, forces: list[Column], responses: list[Column],
                    path: Path) -> list[int]:
    """The DOF (response point) of each force: from ``NAME@DOF``, else a ``force_dofs`` key."""
    if forces[0].dof is not None:
        if "force_dofs" in keys:
            raise RecordingFileError(f"{path}: the header names the force DOFs; remove the "
                                     "'# force_dofs' line")
        return [c.dof for c in forces]
    if "force_dofs" not in keys:
        raise RecordingFileError(f"{path}: say where each force acts: a '# force_dofs = K' line "
                                 "(K the 0-based response column measured at the drive point, "
                                 "a list for several forces) or NAME@DOF headers")
    dofs = np.atleast_1d(keys["force_dofs"])
    if dofs.size != len(forces) or dofs.dtype.kind not in "iu":
        raise RecordingFileError(f"{path}: force_dofs must give one integer per force column "
                                 f"({len(forces)}), got {keys['force_dofs']}")
    if np.any(dofs < 0) or np.any(dofs >= len(responses)):
        raise RecordingFileError(f"{path}: force_dofs {dofs.tolist()} outside the response "
                                 f"columns 0..{len(responses) - 1}")
    return dofs.astype(int).tolist()


def read_csv_columns(path: str | os.PathLike) -> tuple[MatTree, dict[str, str]]:
    """Every column of a CSV export by its header name, for a channel map (`nlid_lab.formats._mat_io`).

    For exports that do not follow this module's header (``Force,Voltage,Acceleration1,...``,
    no time column): the names lose their unit (``Acc1 [m/s^2]`` -> ``Acc1``), which is
    returned beside them; ``# key = value`` lines come as leaves too (``fs``, ``period``...).

    Returns
    -------
    tree : dict
        Column name -> samples (as written), and the file's keys.
    units : dict
        Column name -> the unit its header gave.
    """
    path = Path(path)
    text = read_text(path, "recording", RecordingFileError, max_bytes=MAX_CSV_BYTES)
    tree: MatTree = dict(csv_keys(text, path))
    names, data = csv_table(text, path)
    units = {}
    for j, raw in enumerate(names):
        name, unit = split_label(raw)
        if name in tree:
            raise RecordingFileError(f"{path}: column '{name}' appears twice (or also as a "
                                     "'# key = value' line); rename one")
        tree[name] = data[:, j]
        if unit:
            units[name] = unit
    return tree, units



def csv_time_rate(t: np.ndarray, unit: str | None, path: Path) -> float:
    """Sample rate of a mapped CSV's time column (``unit`` from its header: s or ms)."""
    scale = 1.0
    if unit is not None:
        scale, quantity = lookup(unit, f"{path}: time column")
        if quantity != "time":
            raise RecordingFileError(f"{path}: the time column is in {unit}, not a time unit "
                                     "(s, ms)")
    return _csv_fs(np.asarray(t, dtype=float) * scale, {}, path)


def _csv_fs(t: np.ndarray, keys: dict, path: Path) -> float:
    """Sample rate of a uniform time column (the ``fs`` key when given, checked)."""
    span = t[-1] - t[0]
    fs = (len(t) - 1) / span if np.isfinite(span) and span > 0 else np.nan
    if "fs" in keys:
        given = scalar_key(keys, "fs", float, path)
        if not abs(given - fs) <= 1e-6 * abs(given):
            raise RecordingFileError(f"{path}: fs = {given:g} but the time column steps at "
                                     f"{fs:g} Hz; fix one of them")
        fs = given
    grid = t[0] + np.arange(len(t)) / fs
    if not np.isfinite(fs) or not np.all(np.abs(t - grid) <= 0.01 / fs):   # NaN too
        raise RecordingFileError(f"{path}: the time column must increase in equal steps "
                                 "(uniform sampling, jitter below 1 % of a sample)")
    return fs


def _csv_value(key: str, value: np.ndarray) -> str:
    arr = np.asarray(value)
    if arr.ndim == 0 and arr.dtype.kind == "U":
        return f'"{arr.item()}"'
    if arr.ndim == 0 and arr.dtype.kind in "iu":
        return str(int(arr))
    if arr.ndim == 0 and arr.dtype.kind == "f":
        return repr(float(arr))
    raise RecordingFileError(f"key '{key}' ({arr.dtype}, shape {arr.shape}) cannot be written "
                             "to CSV (numbers and strings only); export as NPZ")


def write_csv(path: str | os.PathLike, rec: Recording | StepTable) -> None:
    """Write a random ``rec`` as CSV: ``# key = value`` lines for its keys, then header
    ``t,f0@DOF,...,x0@0,...`` and the samples (a table: `nlid_lab.formats._tables.csv_text`)."""
    if isinstance(rec, StepTable):
        Path(path).write_text(csv_text(rec))
        return
    if rec.excitation == Excitation.STEPPED_SINE:
        raise RecordingFileError("CSV holds random and swept-sine recordings; write stepped "
                                 "sine as NPZ")
    drop = ("force_dofs", "force", "response", "monitor") + (
        ("excitation",) if rec.excitation == Excitation.RANDOM else ())
    keys = {k: v for k, v in recording_keys(rec).items() if k not in drop}
    keys.update({k: np.str_(",".join(v.tolist())) for k, v in keys.items()
                 if k in SENSOR_KEYS + MONITOR_KEYS})
    lines = [f"# {k} = {_csv_value(k, v)}" for k, v in keys.items()]
    kinds = sensor_map(rec).response_kinds
    names = (["t"] + [f"f{i}@{d}" for i, d in enumerate(rec.force_dofs)]
             + [f"{kinds[j][0]}{j}@{j}" for j in range(rec.n_dof)] + list(rec.monitors))
    t = np.arange(rec.force.shape[0]) / rec.fs
    np.savetxt(path, np.column_stack([t, rec.force, rec.response, *rec.monitors.values()]),
               delimiter=",",
               header="\n".join(lines + [",".join(names)]), comments="", fmt="%.17g")
