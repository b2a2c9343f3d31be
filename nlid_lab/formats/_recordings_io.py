"""NPZ and CSV recordings <-> `analysis.Recording` (docs/recording-formats.md).

NPZ follows contracts sections 3 and 5. CSV holds random recordings: ``# key = value``
comment lines with the recording keys, then a header row naming a time column (``t`` or
``time``, seconds) and one column per channel written ``NAME@DOF``; names starting with ``f``
are forces, the others responses (override with ``force_cols``). Keys no `Recording` field
holds are kept in ``Recording.extra`` and written back, so every key survives a round trip.
"""

from __future__ import annotations

import csv
import io
import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import InputError
from analysis.recordings import (FORCE_HOLDS, KEYS as SENSOR_KEYS, SWEEP_KEYS, PeriodicLayout,
                                 Recording, SensorMap, StepTable, names, sensor_map)
from analysis.models import read_text

from ._monitors import (MONITOR_KEYS, csv_monitor_columns, monitor_fields, monitor_keys,
                        trimmed)
from ._sweep_keys import sweep_fields
from ._tables import (CONTROL_KEYS, control_fields, control_keys, csv_text, is_table,
                      step_table_keys, table_from_csv, table_from_keys)
from ._units import lookup, split_label

MAX_CSV_BYTES = 2**31  # a CSV recording is read into memory whole
_COLUMN = re.compile(r"^\s*([A-Za-z_][\w.\-]*)\s*@\s*(?:dof)?(\d+)\s*$")


class RecordingFileError(InputError):
    """A recording file is missing, unreadable or does not follow its format."""


def _scalar(data, key: str, cast, path: Path):
    arr = np.asarray(data[key])
    if arr.size != 1:
        raise RecordingFileError(f"{path}: '{key}' must be a scalar, got shape {arr.shape}")
    if cast is float:
        _real(arr, key, path)
    elif arr.dtype.kind not in "US":
        raise RecordingFileError(f"{path}: '{key}' must be a string, got {arr.dtype} {arr!r}")
    try:
        return cast(arr.reshape(()).item())
    except (TypeError, ValueError):
        raise RecordingFileError(f"{path}: '{key}' = {arr!r} is not a valid {cast.__name__}") \
            from None


def _real(arr: np.ndarray, key: str, path: Path, integer: bool = False) -> np.ndarray:
    """``arr`` if it holds real numbers (integers if ``integer``): no complex, text or bool."""
    kinds = "iu" if integer else "iuf"
    if arr.dtype.kind not in kinds:
        if integer and arr.dtype.kind == "f" and np.all(np.abs(arr) < 2**31) \
                and np.all(arr == np.round(arr)):  # False for NaN
            return arr.astype(int)
        what = "integers" if integer else "real numbers"
        raise RecordingFileError(f"{path}: '{key}' must hold {what}, got dtype {arr.dtype}; "
                                 "save plain numeric arrays")
    return arr


def _array(data, key: str, path: Path, integer: bool = False) -> np.ndarray:
    arr = _real(np.asarray(data[key]), key, path, integer)
    return np.atleast_1d(arr).astype(int) if integer else arr.astype(float)


def _load_npz(path: Path, what: str) -> dict[str, np.ndarray]:
    """All arrays of an NPZ file, with file problems turned into `RecordingFileError`."""
    if not path.exists():
        raise RecordingFileError(f"{what} {path} not found; check the path")
    if not zipfile.is_zipfile(path):
        raise RecordingFileError(f"{path} is not a readable NPZ file (not a zip archive); "
                                 "save it with numpy.savez")
    try:
        with np.load(path, allow_pickle=False) as data:
            return {key: data[key] for key in data.files}
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as exc:
        raise RecordingFileError(f"{path} is not a readable NPZ file ({exc})") from None


# Keys with a `Recording` field (contracts sections 3 and 5); every other key of a file is
# kept verbatim in `Recording.extra` and written back on export.
CORE_KEYS = ("fs", "excitation", "force_dofs", "force", "response", "response_kind", "freqs")
LEVEL_KEYS = ("force_rms", "force_amplitude", "level")
LAYOUT_KEYS = ("period", "transient_periods", "periods", "realizations")


def level_key(excitation: str) -> str:
    """The key a recording's nominal level is written under."""
    return "force_rms" if excitation == "random" else "force_amplitude"


def read_npz(path: str | os.PathLike) -> Recording | StepTable:
    """Read an NPZ recording (keys of contracts sections 3, 5 and 6; others kept in
    ``extra``)."""
    path = Path(path)
    return recording_from_keys(load_npz_keys(path), path)


def load_npz_keys(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Every key of an NPZ recording, unchecked (`recording_from_keys` checks them)."""
    return _load_npz(Path(path), "recording")


def recording_from_keys(data: dict[str, Any], path: str | os.PathLike
                        ) -> Recording | StepTable:
    """A `Recording` from NPZ-style keys (an NPZ file's, or a MAT import's), or a
    `StepTable` when they hold phasors; ``path`` names the source in messages and
    ``meta["source"]``."""
    path = Path(path)
    if is_table(data):
        return table_from_keys(data, path)
    missing = {"fs", "force", "response", "force_dofs"} - set(data)
    if missing == {"force_dofs"} and "force_points" in data:
        missing = set()
    if missing:
        raise RecordingFileError(f"{path}: missing key(s) {sorted(missing)}; an NPZ "
                                 "recording needs fs, force_dofs (or force_points), force and "
                                 "response")
    excitation = (_scalar(data, "excitation", str, path) if "excitation" in data
                  else ("stepped-sine" if "freqs" in data else "random"))
    try:
        force, response = _array(data, "force", path), _array(data, "response", path)
        fs = _scalar(data, "fs", float, path)
        level, level_from = _level(data, path, excitation)
        kind = _scalar(data, "response_kind", str, path) if "response_kind" in data else None
        monitors, units = monitor_fields(data, force.shape[:-1], path)
        sweep = None
        if excitation == "swept-sine":
            sweep, force, response, amplitude = sweep_fields(data, force, response, fs)
            level = amplitude if level is None else level
            if monitors and len(force) != len(next(iter(monitors.values()))):  # law estimated
                monitors = trimmed(monitors, sweep.trimmed_lead, force.shape[0])
        sensors, force_dofs = _sensors(data, response, kind, path)
        return Recording(
            fs=fs, excitation=excitation, force_dofs=force_dofs, force=force,
            response=response, response_kind=kind or "displacement", sensors=sensors,
            freqs=_array(data, "freqs", path) if "freqs" in data else None,
            level=level, force_hold=_force_hold(data, path),
            layout=_layout(data, path, force.shape[0] if force.ndim else 0), sweep=sweep,
            extra=_extra(data, excitation, level_from), meta={"source": str(path)},
            monitors=monitors, monitor_units=units,
            **(control_fields(data, path) if excitation == "stepped-sine" else {}))
    except (TypeError, ValueError) as exc:  # RecordingError included: name the file
        raise RecordingFileError(f"{path}: {exc}") from None


def _sensors(data: dict, response: np.ndarray, kind: str | None, path: Path
             ) -> tuple[SensorMap | None, np.ndarray]:
    """The sensor map of a file's keys (`analysis.recordings.KEYS`) and the force DOFs (the
    channels measuring ``force_points`` when the file gives no ``force_dofs``)."""
    n = response.shape[-1] if response.ndim else 0
    dofs = _array(data, "force_dofs", path, integer=True) if "force_dofs" in data else None
    smap = SensorMap.from_keys(data, n, [] if dofs is None else np.atleast_1d(dofs), kind)
    if smap is None:
        return None, dofs
    smap.validate(n, len(smap.force_points))
    return smap, np.asarray(smap.force_channels) if dofs is None else dofs


def _force_hold(data: dict, path: Path) -> str:
    if "force_hold" not in data:
        return "none"
    hold = _scalar(data, "force_hold", str, path)
    if hold not in FORCE_HOLDS:
        raise RecordingFileError(f"{path}: force_hold '{hold}' must be none or linear")
    return hold


def _layout(data: dict, path: Path, n: int) -> PeriodicLayout | None:
    """The periodic layout the file's keys describe (missing keys completed), else None."""
    given = {k: _scalar(data, k, float, path) for k in LAYOUT_KEYS if k in data}
    if not given:
        return None
    if "period" not in given:
        raise RecordingFileError(f"{path}: {sorted(given)} given without period (samples per "
                                 "period); add period or remove the layout keys")
    return PeriodicLayout.complete(n, **given)


def _level(data: dict, path: Path, excitation: str) -> tuple[float | None, str | None]:
    """Nominal level and the key it came from (the excitation's own key first)."""
    own = level_key(excitation)
    for key in (own,) + tuple(k for k in LEVEL_KEYS if k != own):
        if key in data:
            return _scalar(data, key, float, path), key
    return None, None


def _extra(data: dict, excitation: str, level_from: str | None) -> dict[str, np.ndarray]:
    """Keys no field holds. A level read from another key than the excitation's own (say
    ``level``) stays here too, so that the file's own key is written back."""
    known = (set(CORE_KEYS) | set(LAYOUT_KEYS) | set(SENSOR_KEYS) | set(MONITOR_KEYS)
             | {"force_hold"})
    if excitation == "swept-sine":
        known |= set(SWEEP_KEYS)
    if excitation == "stepped-sine":
        known |= set(CONTROL_KEYS)
    if level_from == level_key(excitation):
        known.add(level_from)
    return {k: np.asarray(v) for k, v in data.items() if k not in known}


def recording_keys(rec: Recording | StepTable) -> dict[str, np.ndarray]:
    """Every key of ``rec`` as written to NPZ (contracts sections 3, 5 and 6, then
    ``extra``)."""
    if isinstance(rec, StepTable):
        return step_table_keys(rec)
    out = {k: np.asarray(v) for k, v in rec.extra.items()}
    out.update({"fs": np.float64(rec.fs), "excitation": np.str_(rec.excitation),
                "force_dofs": rec.force_dofs, "force": rec.force, "response": rec.response,
                "response_kind": np.str_(rec.response_kind),
                "force_hold": np.str_(rec.force_hold)})
    if rec.freqs is not None:
        out["freqs"] = rec.freqs
    if rec.layout is not None:
        out.update({k: np.int64(getattr(rec.layout, k)) for k in LAYOUT_KEYS})
    if rec.sweep is not None:
        out.update(rec.sweep.keys())
    if rec.level is not None:
        out[level_key(rec.excitation)] = np.float64(rec.level)
    if rec.sensors is not None:
        out.update(rec.sensors.to_keys())
    out.update(monitor_keys(rec))
    out.update(control_keys(rec))
    return out


def write_npz(path: str | os.PathLike, rec: Recording | StepTable) -> None:
    """Write ``rec`` as an NPZ recording (every key of `recording_keys`)."""
    with open(path, "wb") as fh:  # np.savez would append ".npz" to other names
        np.savez(fh, **recording_keys(rec))


@dataclass
class _Column:
    """One channel column of a CSV recording."""

    index: int
    name: str
    dof: int | None
    factor: float = 1.0              # to SI
    quantity: str | None = None      # from the unit: force, displacement, velocity, ...


def parse_header(names: list[str], force_cols: list[str] | None = None
                 ) -> tuple[int, float, list[_Column]]:
    """Time column index, its scale to seconds, and the channel columns.

    A column is ``NAME@DOF`` or, as acquisition systems export them, ``NAME (UNIT)`` /
    ``NAME [UNIT]`` (``Force (N)``, ``Acc1 [m/s^2]``): the unit scales the column to SI and
    says what it measures (`nlid_lab.formats._units`). Either every channel names its DOF or none does.
    """
    time_col, time_scale, chans = [], 1.0, []
    for i, raw in enumerate(names):
        base, unit = split_label(raw)
        if base.lower() in ("t", "time"):
            time_col.append(i)
            if unit:
                factor, quantity = lookup(unit, f"CSV column '{raw.strip()}'")
                if quantity != "time":
                    raise RecordingFileError(f"CSV column '{raw.strip()}': the time column "
                                             "must be in s or ms")
                time_scale = factor
            continue
        m = _COLUMN.match(base)
        name, dof = (m.group(1), int(m.group(2))) if m else (base, None)
        if not name or not re.match(r"^[A-Za-z_][\w .\-]*$", name):
            raise RecordingFileError(f"CSV column '{raw.strip()}' is not NAME@DOF or NAME (UNIT)"
                                     " (e.g. f0@0, x1@1, 'Acc1 [m/s^2]')")
        factor, quantity = lookup(unit, f"CSV column '{raw.strip()}'") if unit else (1.0, None)
        chans.append(_Column(i, name, dof, factor, quantity))
    if len(time_col) != 1:
        raise RecordingFileError("CSV header needs exactly one time column named 't' or "
                                 f"'time' (optionally with its unit, 'Time (s)'); got {names}")
    if len({c.dof is None for c in chans}) > 1:
        raise RecordingFileError("CSV header: name the DOF of every channel (NAME@DOF) or of "
                                 "none (then responses are points 0.. in column order)")
    if force_cols is not None:
        unknown = set(force_cols) - {c.name for c in chans}
        if unknown:
            raise RecordingFileError(f"--force-cols names {sorted(unknown)} not in the header")
    return time_col[0], time_scale, chans


def _is_force(c: _Column, force_cols: list[str] | None) -> bool:
    if force_cols is not None:
        return c.name in force_cols
    if c.quantity is not None:
        return c.quantity == "force"
    return c.name.lower().startswith("f")


def _csv_table(text: str, path: Path) -> tuple[list[str], np.ndarray]:
    """Header names and data of a CSV export: comment lines (``#``) and any preamble before
    the header are skipped; the delimiter (``,``, ``;`` or tab) and a decimal comma are
    recognised from the first data row."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    for h in range(len(lines) - 1):
        for delim in (",", ";", "\t"):
            first = lines[h + 1].split(delim)
            names = next(csv.reader([lines[h]], delimiter=delim))
            if len(first) < 2 or len(first) != len(names):
                continue
            decimal_comma = delim != "," and any("," in c for c in first)
            try:
                [float(c.replace(",", ".") if decimal_comma else c) for c in first]
            except ValueError:
                continue
            body = lines[h + 1:]
            if decimal_comma:
                body = [ln.replace(",", ".") for ln in body]
            if len(body) < 2:
                break
            rows = _Rows(text, body, delim, len(names), path, h + 1)
            rows.check_fields()
            rows.check_last_text()
            try:
                data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delim, ndmin=2)
            except ValueError as exc:
                raise RecordingFileError(f"{path}: bad number in the data ({exc}); fix or "
                                         "delete that row") from None
            rows.check_last(data)
            return names, data
    raise RecordingFileError(f"{path}: needs a header row and at least two data rows of "
                             "numbers (comma, semicolon or tab separated) after any preamble")


_FIELD = re.compile(r"^\s*[+-]?\d*(\.(\d*))?([eE][+-]?(\d*))?\s*$")


@dataclass
class _Rows:
    """The data rows of a CSV table and the checks of what a cut write leaves behind.

    An exporter writes a row's fields left to right and its newline last, so a file cut while
    being written ends in a row without a newline whose last field is the prefix of a number:
    it lost, in this order, its exponent digits, its exponent, its fraction digits, its
    decimal point. Rows are otherwise never cut. The rule (`check_last`): a last row without
    a newline must hold every field, and its last field must be written as fully as the least
    complete nonzero field of its column elsewhere (decimal point, fraction and exponent
    digits; ``%g`` writes a zero as ``0``) and
    lie within ten times that column's largest magnitude (a lost exponent ``e-05`` makes the
    value 1e5 too large, a lost exponent digit as much as 1e9). A cut losing fraction digits
    only, in a column written with varying precision, changes one sample below its last kept
    digit and stays undetectable.
    """

    text: str
    body: list[str]
    delim: str
    n: int
    path: Path
    offset: int       # rows of the file before the first data row (blank and # lines aside)

    def check_fields(self) -> None:
        """Every row has the header's number of fields (a cut row has fewer)."""
        counts = np.fromiter((ln.count(self.delim) for ln in self.body), int, len(self.body))
        bad = np.flatnonzero(counts != self.n - 1)
        if not bad.size:
            return
        i = int(bad[0])
        where = f"line {self._line(i)}"
        if i == len(self.body) - 1:
            raise RecordingFileError(f"{self.path}: {where}, the last, has {counts[i] + 1} of "
                                     f"{self.n} fields: the file looks cut; export it again "
                                     "or delete that line")
        raise RecordingFileError(f"{self.path}: {where} has {counts[i] + 1} fields but the "
                                 f"header names {self.n}; fix or delete that line")

    @property
    def unterminated(self) -> bool:
        """Whether the last row has no newline (the one row a cut write leaves)."""
        return not self.text.rstrip(" \t").endswith(("\n", "\r"))

    def check_last_text(self) -> None:
        """Refuse an unterminated last row whose last field is no number (``-``, ``1e``)."""
        if not self.unterminated:
            return
        last = self.body[-1].rsplit(self.delim, 1)[-1].strip()
        try:
            float(last)
        except ValueError:
            self._cut(last, "not a number")

    def check_last(self, data: np.ndarray) -> None:
        """Refuse an unterminated last row whose last field looks cut (`_Rows`)."""
        if not self.unterminated:
            return
        last = self.body[-1].rsplit(self.delim, 1)[-1].strip()
        why = self._incomplete(last, data[:-1, -1])
        column = np.abs(data[:-1, -1])
        if why is None and not abs(data[-1, -1]) <= 10 * column.max():
            why = (f"{data[-1, -1]:.4g} is over ten times the column's largest value "
                   f"{column.max():.4g} elsewhere")
        if why is not None:
            self._cut(last, why)

    def _cut(self, last: str, why: str) -> None:
        raise RecordingFileError(
            f"{self.path}: line {self._line(len(self.body) - 1)}, the last, ends without a "
            f"newline and its last number '{last}' looks cut ({why}); export the file "
            "again, or delete that line (end it with a newline if it is whole)")

    def _incomplete(self, last: str, column: np.ndarray) -> str | None:
        """What ``last`` lacks that every other nonzero field of its column (values
        ``column``) has, if anything; zeros say nothing of the format (``%g`` writes ``0``)."""
        others = [_FIELD.match(ln.rsplit(self.delim, 1)[-1])
                  for ln, value in zip(self.body[:-1], column) if value != 0]
        mine = _FIELD.match(last)
        if mine is None or not others or any(m is None for m in others):
            return None  # not plain numbers: loadtxt has read them, nothing to compare

        def size(m: re.Match, k: int) -> int:   # groups 1, 3: present; 2, 4: digit count
            part = m.group(k) or ""
            return min(len(part), 1) if k in (1, 3) else len(part)

        for k, name in ((1, "decimal point"), (2, "fraction digits"), (3, "exponent"),
                        (4, "exponent digits")):
            if size(mine, k) < min(size(m, k) for m in others):
                return f"fewer {name} than every other number of its column" if k in (2, 4) \
                    else f"no {name}, which every other number of its column has"
        return None

    def _line(self, i: int) -> int:
        """The file line number (1-based) of data row ``i``."""
        want, seen = self.offset + i, -1
        for number, line in enumerate(self.text.splitlines(), 1):
            if line.strip() and not line.lstrip().startswith("#"):
                seen += 1
                if seen == want:
                    return number
        return self.text.count("\n") + 1


def read_csv(path: str | os.PathLike, force_cols: list[str] | None = None,
             response_kind: str | None = None, level: float | None = None,
             force_dofs: list[int] | None = None, excitation: str | None = None,
             keys: dict[str, Any] | None = None) -> Recording:
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
    keys = {**_csv_keys(text, path), **{k: np.asarray(v) for k, v in (keys or {}).items()}}
    names, data = _csv_table(text, path)
    if "freqs" in (n.strip() for n in names):        # a stepped-sine table
        return table_from_csv(keys, names, data, path)
    if force_dofs is not None:
        keys["force_dofs"] = np.asarray(force_dofs)
    if data.shape[0] < 2:
        raise RecordingFileError(f"{path}: needs a header row and at least two data rows")
    if data.shape[1] != len(names):
        raise RecordingFileError(f"{path}: {data.shape[1]} data columns but {len(names)} "
                                 "header names")
    mcols = csv_monitor_columns(names, keys, path)
    if mcols:
        keys["monitor"] = data[:, mcols]
        keys.setdefault("monitor_units", np.array([split_label(names[j])[1] or ""
                                                   for j in mcols]))
        names = [h for j, h in enumerate(names) if j not in mcols]
        data = np.delete(data, mcols, axis=1)
    time_col, time_scale, chans = parse_header(names, force_cols)
    fs = _csv_fs(data[:, time_col] * time_scale, keys, path)
    forces = [c for c in chans if _is_force(c, force_cols)]
    responses = [c for c in chans if not _is_force(c, force_cols)]
    if not forces or not responses:
        raise RecordingFileError(f"{path}: need at least one force and one response column "
                                 "(forces are named f...@DOF or carry a force unit, 'Force (N)'"
                                 ", unless --force-cols is given)")
    force_dofs = _csv_force_dofs(keys, forces, responses, path)
    responses = sorted(responses, key=lambda c: c.dof if c.dof is not None else c.index)
    dofs = [c.dof for c in responses]
    if responses[0].dof is not None and dofs != list(range(len(dofs))):
        raise RecordingFileError(f"{path}: response columns must cover DOFs 0..n-1 once each, "
                                 f"got DOFs {dofs}")
    file_kind = _scalar(keys, "response_kind", str, path) if "response_kind" in keys else None
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
    for what, kind in (("the file's response_kind", file_kind),
                       ("--response-kind", response_kind)):
        if kind is not None and unit_kinds and kind not in unit_kinds:
            raise RecordingFileError(f"{path}: {what} is {kind} but the column units say "
                                     f"{unit_kinds.pop()}; drop one of them")
    if response_kind is not None and file_kind not in (None, response_kind):
        raise RecordingFileError(f"{path}: the file says response_kind = {file_kind} but "
                                 f"{response_kind} was asked for; drop one of them")
    kind = response_kind or file_kind or (unit_kinds.pop() if unit_kinds else "displacement")
    exc = excitation or (_scalar(keys, "excitation", str, path) if "excitation" in keys
                         else "random")
    if exc not in ("random", "swept-sine"):
        raise RecordingFileError(f"{path}: CSV holds random or swept-sine recordings, not {exc}")
    keys["excitation"] = np.str_(exc)
    keys.pop("force_dofs", None)
    try:
        file_level, level_from = _level(keys, path, exc)
        force = data[:, [c.index for c in forces]] * [c.factor for c in forces]
        response = data[:, [c.index for c in responses]] * [c.factor for c in responses]
        monitors, units = monitor_fields(keys, force.shape[:-1], path)
        sweep = None
        if exc == "swept-sine":
            sweep, force, response, amplitude = sweep_fields(keys, force, response, fs)
            file_level = amplitude if file_level is None else file_level
            if monitors and len(force) != data.shape[0]:      # law estimated: trimmed
                monitors = trimmed(monitors, sweep.trimmed_lead, force.shape[0])
        sensors, _ = _sensors({**keys, "force_dofs": np.asarray(force_dofs)}, response,
                              response_kind or file_kind, path)
        return Recording(
            fs=fs, excitation=exc, force_dofs=force_dofs, force=force, response=response,
            response_kind=kind, sensors=sensors,
            level=file_level if level is None else level, force_hold=_force_hold(keys, path),
            layout=_layout(keys, path, data.shape[0]), sweep=sweep,
            extra=_extra(keys, exc, level_from), monitors=monitors, monitor_units=units,
            meta={"source": str(path), "channels": [c.name for c in forces + responses]})
    except (TypeError, ValueError) as exc:  # RecordingError included: name the file
        raise RecordingFileError(f"{path}: {exc}") from None


def _csv_force_dofs(keys: dict, forces: list[_Column], responses: list[_Column],
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


def read_csv_columns(path: str | os.PathLike) -> tuple[dict[str, Any], dict[str, str]]:
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
    tree: dict[str, Any] = dict(_csv_keys(text, path))
    names, data = _csv_table(text, path)
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


_CSV_KEY = re.compile(r"^\s*#\s*([A-Za-z_]\w*)\s*=\s*(.*?)\s*$")


def _csv_keys(text: str, path: Path) -> dict[str, np.ndarray]:
    """Recording keys of ``# key = value`` comment lines: numbers, or strings in quotes."""
    keys: dict[str, np.ndarray] = {}
    for line in text.splitlines():
        m = _CSV_KEY.match(line)
        if not m:
            continue
        key, raw = m.groups()
        if key in ("force", "response", "freqs"):
            raise RecordingFileError(f"{path}: '{key}' comes from the CSV header and data, not "
                                     "from a '# key = value' line; remove that line")
        if len(raw) >= 2 and raw[0] == raw[-1] == '"':
            keys[key] = np.str_(raw[1:-1])
            continue
        if raw.startswith("[") and raw.endswith("]"):        # a list of integers
            try:
                keys[key] = np.array([int(v) for v in raw[1:-1].split(",")])
                continue
            except ValueError:
                pass
        for cast in (int, float):
            try:
                keys[key] = np.asarray(cast(raw))
                break
            except ValueError:
                pass
        else:
            keys[key] = np.str_(raw)
    return keys


def _csv_fs(t: np.ndarray, keys: dict, path: Path) -> float:
    """Sample rate of a uniform time column (the ``fs`` key when given, checked)."""
    span = t[-1] - t[0]
    fs = (len(t) - 1) / span if np.isfinite(span) and span > 0 else np.nan
    if "fs" in keys:
        given = _scalar(keys, "fs", float, path)
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
    if rec.excitation == "stepped-sine":
        raise RecordingFileError("CSV holds random and swept-sine recordings; write stepped "
                                 "sine as NPZ")
    drop = ("force_dofs", "force", "response", "monitor") + (
        ("excitation",) if rec.excitation == "random" else ())
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


def load_recordings(path: str | os.PathLike) -> list[Recording | StepTable]:
    """Recordings of any supported file: run ``.h5`` (one per level), ``.npz`` or ``.csv``
    (stepped-sine tables as `StepTable`)."""
    # the store (h5py) loads on use: every command line imports this room
    from ..store import StoreError, open_run

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".h5", ".hdf5"):
        return open_run(path).recordings()
    if suffix == ".npz":
        return [read_npz(path)]
    if suffix == ".csv":
        return [read_csv(path)]
    raise StoreError(f"{path}: unknown recording type '{suffix}'; use .h5, .npz or .csv")
