"""Stepped-sine tables (contracts section 6) in and out of NPZ, CSV and MAT files.

A table recording holds per step the frequency and the fundamental phasors (``freqs``,
``force_phasor``, ``response_phasor``, ``force_dofs``, ``control``, ``control_dof``, ``level``,
optional ``harmonics`` with ``force_harmonics`` / ``response_harmonics``); no ``fs``,
``force``, ``response``. NPZ and MAT files hold the keys as they are; CSV writes the scalar
keys as ``# key = value`` lines and every complex array as ``KEY[i].re`` / ``KEY[i].im``
columns (``KEY[h][i]`` for the harmonics) beside ``freqs``. Keys no `StepTable` field holds are
kept in ``extra`` and written back.

A controller's own export (a MATLAB struct array, one element per level, with amplitude and
phase fields) is read through a table map (`TableMap`, ``--map table=...``).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from analysis.documents import MatTree
from analysis.errors import InputError
from analysis.recordings import (KIND_ORDER, KEYS as SENSOR_KEYS, STEP_TABLE_KEYS, Control,
                                 Excitation, Recording, RecordingKeys, SensorMap, StepTable)

from ._mat_io import map_items, map_value
from ._units import lookup

#: complex (n_steps, ...) keys of a table, written as ``.re``/``.im`` columns in CSV
COMPLEX_KEYS = ("force_phasor", "response_phasor", "force_harmonics", "response_harmonics")
_COLUMN = re.compile(r"^(?P<key>[a-z_]+)(?P<index>(\[\d+\])+)\.(?P<part>re|im)$")


class TableFileError(InputError):
    """A table recording or its map does not give what an import needs."""


def is_table(data: RecordingKeys) -> bool:
    """True if recording keys describe a table (they hold a phasor)."""
    return "force_phasor" in data or "response_phasor" in data


def _scalar(data: RecordingKeys, key: str, path: Path) -> Any:
    arr = np.asarray(data[key])
    if arr.size != 1:
        raise TableFileError(f"{path}: '{key}' must be one value, got shape {arr.shape}")
    return arr.reshape(()).item()


def table_from_keys(data: RecordingKeys, path: str | os.PathLike) -> StepTable:
    """A `StepTable` from NPZ-style keys; ``path`` names the source in messages."""
    path = Path(path)
    missing = {"freqs", "force_phasor", "response_phasor", "control", "level"} - set(data)
    if "force_dofs" not in data and "force_points" not in data:
        missing.add("force_dofs")
    if missing:
        raise TableFileError(f"{path}: a stepped-sine table needs {sorted(missing)} "
                             "(contracts section 6)")
    stray = {"fs", "force", "response"} & set(data)
    if stray:
        raise TableFileError(f"{path}: a table holds phasors, not samples: drop "
                             f"{sorted(stray)} or the phasor keys")
    try:
        excitation = str(_scalar(data, "excitation", path)) if "excitation" in data \
            else "stepped-sine"
        if excitation != Excitation.STEPPED_SINE:
            raise TableFileError(f"{path}: a table is a stepped sine, not {excitation}")
        response = np.asarray(data["response_phasor"])
        n_out = response.shape[-1] if response.ndim == 2 else 1
        kind = str(_scalar(data, "response_kind", path)) if "response_kind" in data else None
        dofs = np.atleast_1d(data["force_dofs"]) if "force_dofs" in data else np.array([], int)
        sensors = SensorMap.from_keys(data, n_out, dofs, kind)
        if sensors is not None and "force_dofs" not in data:
            dofs = np.asarray(sensors.force_channels)
        harmonics = tuple(np.atleast_1d(data["harmonics"]).astype(int).tolist()) \
            if "harmonics" in data else ()
        cdof = int(_scalar(data, "control_dof", path)) if "control_dof" in data else None
        return StepTable(
            freqs=data["freqs"], force_phasor=data["force_phasor"], response_phasor=response,
            force_dofs=dofs, control=str(_scalar(data, "control", path)),
            level=float(_scalar(data, "level", path)), response_kind=kind or "displacement",
            control_dof=cdof, harmonics=harmonics,
            force_harmonics=data.get("force_harmonics"),
            response_harmonics=data.get("response_harmonics"), sensors=sensors,
            extra={k: np.asarray(v) for k, v in data.items()
                   if k not in STEP_TABLE_KEYS and k not in SENSOR_KEYS},
            meta={"source": str(path)})
    except (TypeError, ValueError) as exc:    # RecordingError included: name the file
        raise TableFileError(f"{path}: {exc}") from None


#: keys of what a stepped-sine controller held, in tables and in time-block recordings alike
CONTROL_KEYS = ("control", "control_dof")


class ControlFields(NamedTuple):
    """What a stepped-sine controller held, as `Recording` fields (``_asdict()``)."""

    control: Control = Control.FORCE
    control_dof: int | None = None


def control_fields(data: RecordingKeys, path: Path) -> ControlFields:
    """``control`` and ``control_dof`` of a stepped-sine time-block recording's keys (the
    defaults when the file does not say: force control)."""
    return ControlFields(
        Control(str(_scalar(data, "control", path))) if "control" in data else Control.FORCE,
        int(_scalar(data, "control_dof", path)) if "control_dof" in data else None)


def control_keys(rec: Recording) -> dict[str, np.ndarray]:
    """The keys of what a stepped-sine time-block recording's controller held (written for
    every stepped-sine recording, as a table's are)."""
    if rec.excitation != Excitation.STEPPED_SINE:
        return {}
    out = {"control": np.str_(rec.control)}
    if rec.control_dof is not None:
        out["control_dof"] = np.int64(rec.control_dof)
    return out


def step_table_keys(table: StepTable) -> RecordingKeys:
    """Every key of ``table`` as written to NPZ (contracts section 6, then ``extra``)."""
    out = {k: np.asarray(v) for k, v in table.extra.items()}
    out.update({"excitation": np.str_("stepped-sine"), "freqs": table.freqs,
                "force_phasor": table.force_phasor, "response_phasor": table.response_phasor,
                "force_dofs": table.force_dofs, "response_kind": np.str_(table.response_kind),
                "control": np.str_(table.control), "level": np.float64(table.level)})
    if table.control_dof is not None:
        out["control_dof"] = np.int64(table.control_dof)
    if table.harmonics:
        out.update(harmonics=np.asarray(table.harmonics, dtype=np.int64),
                   force_harmonics=table.force_harmonics,
                   response_harmonics=table.response_harmonics)
    if table.sensors is not None:
        out.update(table.sensors.to_keys())
    return out


def csv_text(table: StepTable) -> str:
    """A table as CSV text (module docstring): ``# key = value`` lines, header, rows."""
    keys = step_table_keys(table)
    lines = []
    for key, value in keys.items():
        if key in COMPLEX_KEYS or key == "freqs":
            continue
        arr = np.asarray(value)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.dtype.kind not in "iu"
                            and key not in SENSOR_KEYS):
            raise TableFileError(f"key '{key}' (shape {arr.shape}) cannot be written to CSV; "
                                 "export as NPZ or MAT")
        lines.append(f"# {key} = {_csv_value(arr)}")
    names, cols = ["freqs"], [table.freqs]
    for key in COMPLEX_KEYS:
        if key not in keys:
            continue
        arr = keys[key].reshape(table.n_steps, -1)
        shape = keys[key].shape[1:]
        for flat, index in enumerate(np.ndindex(*shape)):
            label = "][".join(str(i) for i in index)
            names += [f"{key}[{label}].re", f"{key}[{label}].im"]
            cols += [arr[:, flat].real, arr[:, flat].imag]
    rows = [",".join(repr(float(v)) for v in row) for row in np.column_stack(cols)]
    return "\n".join(lines + [",".join(names)] + rows) + "\n"


def _csv_value(arr: np.ndarray) -> str:
    if arr.dtype.kind in "US":
        return (f'"{arr.item()}"' if arr.ndim == 0 else
                '"' + ",".join(str(v) for v in arr.tolist()) + '"')
    if arr.ndim == 1:
        return "[" + ", ".join(str(int(v)) for v in arr) + "]"
    return str(int(arr)) if arr.dtype.kind in "iu" else repr(float(arr))


def table_from_csv(keys: RecordingKeys, names: list[str], data: np.ndarray,
                   path: Path) -> StepTable:
    """A table from a CSV's ``# key`` lines, header names and rows (`csv_text`'s layout)."""
    found: dict[str, dict[tuple[int, ...], np.ndarray]] = {}
    out = dict(keys)
    for j, name in enumerate(names):
        name = name.strip()
        if name == "freqs":
            out["freqs"] = data[:, j]
            continue
        m = _COLUMN.match(name)
        if not m or m["key"] not in COMPLEX_KEYS:
            raise TableFileError(f"{path}: column '{name}' is not freqs or KEY[i].re / "
                                 f"KEY[i].im with KEY one of {', '.join(COMPLEX_KEYS)}")
        index = tuple(int(i) for i in m["index"][1:-1].split("]["))
        cell = found.setdefault(m["key"], {})
        cell[index] = cell.get(index, 0) + (data[:, j] if m["part"] == "re" else 1j * data[:, j])
    for key, cells in found.items():
        shape = tuple(max(i[a] for i in cells) + 1 for a in range(len(next(iter(cells)))))
        if len(cells) != int(np.prod(shape)):
            raise TableFileError(f"{path}: the {key}[...] columns do not fill a {shape} array")
        arr = np.empty((data.shape[0],) + shape, complex)
        for index, values in cells.items():
            arr[(slice(None),) + index] = values
        out[key] = arr
    for key in SENSOR_KEYS:
        if key in out:
            out[key] = np.array(str(out[key]).split(","))
    return table_from_keys(out, path)


# --- controller exports through a table map ---------------------------------------------------

#: phase conventions of a map's ``*_phase=FIELD:CONVENTION`` (docs/recording-formats.md)
PHASE_CONVENTIONS = ("lead", "lag", "receptance", "receptance-lag")
#: map keys that read a field of each element (the others are literal recording keys)
FIELD_KEYS = ("freqs", "force_phasor", "response_phasor", "force_amplitude", "force_phase",
              "response_amplitude", "response_phase")


@dataclass(frozen=True)
class FieldSpec:
    """One ``KEY=FIELD[cols]:MOD:MOD`` item of a table map."""

    field: str
    mods: tuple[str, ...] = ()

    @classmethod
    def parse(cls, text: str) -> "FieldSpec":
        """``FIELD:MOD:MOD`` -> the field and its modifiers."""
        name, *mods = str(text).split(":")
        return cls(name.strip(), tuple(m.strip() for m in mods if m.strip()))


@dataclass(frozen=True)
class TableMap:
    """Where a controller export holds its table: one struct-array element per level.

    ``table`` names the struct array; the ``FIELD_KEYS`` name fields of each element
    (amplitude with an optional ``:UNIT``, phase with ``:CONVENTION`` and an optional
    ``:deg``); every other item is a recording key, a literal or a field of the element.
    """

    table: str
    fields: dict[str, FieldSpec]
    keys: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_items(cls, items: list[str]) -> "TableMap":
        """From ``KEY=VALUE`` words (``--map table=FRdata.ResponseControl freqs=frequency``)."""
        data = dict(map_items(items, "table map", "freqs=frequency", TableFileError))
        fields = {k: FieldSpec.parse(data.pop(k)) for k in FIELD_KEYS if k in data}
        if "freqs" not in fields:
            raise TableFileError("table map: name the frequency field, e.g. freqs=frequency")
        for role in ("force", "response"):
            if f"{role}_phasor" not in fields and f"{role}_amplitude" not in fields:
                raise TableFileError(f"table map: give {role}_phasor=FIELD (complex) or "
                                     f"{role}_amplitude=FIELD[:UNIT] (with {role}_phase="
                                     "FIELD:CONVENTION, else phase 0)")
        if "control" not in data:
            raise TableFileError("table map: say what the controller held: control=response "
                                 "or control=force")
        return cls(data.pop("table"), fields, {k: map_value(v) for k, v in data.items()})

    def tables(self, tree: MatTree, source: str) -> list[StepTable]:
        """One `StepTable` per element of the struct array ``table`` names in ``tree``
        (`nlid_lab.formats.read_mat_tree`)."""
        elements = _elements(tree, self.table, source)
        out = []
        for k, element in enumerate(elements):
            where = f"{source} {self.table}({k + 1})"
            out.append(table_from_keys(self._keys(element, where), where))
        return out

    def _keys(self, element: MatTree, where: str) -> RecordingKeys:
        freqs = np.asarray(_field(element, self.fields["freqs"].field, where),
                           dtype=float).ravel()
        keys: RecordingKeys = {"excitation": "stepped-sine", "freqs": freqs,
                                "force_dofs": 0}
        kind = self.keys.get("response_kind")
        for key, value in self.keys.items():
            keys[key] = element[value] if isinstance(value, str) and value in element else value
        for role in ("force", "response"):
            keys[f"{role}_phasor"], unit_kind = self._phasor(element, role, freqs.size,
                                                              keys.get("response_kind"), where)
            if role == "response" and unit_kind:
                if kind not in (None, unit_kind):
                    raise TableFileError(f"{where}: response_kind = {kind} but the unit "
                                         f"says {unit_kind}; drop one of them")
                keys["response_kind"] = unit_kind
        if "level" not in keys:     # the controller's target is not in the export
            probe = table_from_keys({**keys, "level": 1.0}, where)
            keys["level"] = float(np.median(probe.held()))
        return keys

    def _phasor(self, element: MatTree, role: str, n: int, kind: str | None,
                where: str) -> tuple[np.ndarray, str | None]:
        """A role's phasors from a complex field, or amplitude and phase fields."""
        if f"{role}_phasor" in self.fields:
            return _steps(_field(element, self.fields[f"{role}_phasor"].field, where), n,
                          where, complex), None
        spec = self.fields[f"{role}_amplitude"]
        amp = _steps(_field(element, spec.field, where), n, where, float)
        unit_kind = None
        if spec.mods:
            factor, quantity = lookup(spec.mods[0], f"{where}: {role}_amplitude")
            if (quantity == "force") != (role == "force"):
                raise TableFileError(f"{where}: {role}_amplitude is in {spec.mods[0]}, a "
                                     f"{quantity} unit")
            amp = amp * factor
            unit_kind = None if role == "force" else quantity
        phase = np.zeros_like(amp)
        if f"{role}_phase" in self.fields:
            p = self.fields[f"{role}_phase"]
            phase = _steps(_field(element, p.field, where), n, where, float)
            kind_order = 0 if role == "force" else KIND_ORDER.get(unit_kind or kind or
                                                                  "displacement", 0)
            phase = convert_phase(phase, p.mods, kind_order, f"{where}: {role}_phase")
        return amp * np.exp(1j * phase), unit_kind


def convert_phase(phase: np.ndarray, mods: tuple[str, ...], kind_order: int,
                  where: str) -> np.ndarray:
    """The phase (rad) of ``exp(+i w t)`` phasors from a field's phase in its convention.

    ``lead`` (default): the response's own phase relative to the force; ``lag``: how far it
    lags the force (phasor ``A exp(-i p)``); ``receptance``: the phase of the displacement it
    stands for (0 below a resonance, -90 deg at it, whatever the kind: phasor
    ``A exp(i (p + k pi/2))``, ``k`` = 0, 1, 2 for displacement, velocity, acceleration);
    ``receptance-lag``: that phase's lag. A ``deg`` modifier reads degrees.
    """
    conv = [m for m in mods if m in PHASE_CONVENTIONS]
    units = [m for m in mods if m in ("deg", "rad")]
    other = [m for m in mods if m not in PHASE_CONVENTIONS + ("deg", "rad")]
    if other or len(conv) > 1 or len(units) > 1:
        raise TableFileError(f"{where}: phase modifiers {list(mods)}: give one convention of "
                             f"{', '.join(PHASE_CONVENTIONS)} and optionally deg or rad")
    p = np.deg2rad(phase) if units == ["deg"] else phase
    conv_name = conv[0] if conv else "lead"
    if conv_name.endswith("lag"):
        p = -p
    if conv_name.startswith("receptance"):
        p = p + kind_order * np.pi / 2
    return p


def _elements(tree: MatTree, name: str, source: str) -> list[MatTree]:
    """The elements of the struct array ``name`` (a 1x1 struct: one element)."""
    if name in tree and isinstance(tree[name], (list, tuple, np.ndarray)):
        items = list(np.ravel(np.asarray(tree[name], dtype=object)))
        if items and all(isinstance(e, dict) for e in items):
            return items
    prefix = name + "."
    one = {k[len(prefix):]: v for k, v in tree.items() if k.startswith(prefix)}
    if one:
        return [one]
    tables = sorted(k for k, v in tree.items() if isinstance(v, (list, np.ndarray))
                    and len(v) and all(isinstance(e, dict) for e in np.ravel(
                        np.asarray(v, dtype=object))))
    raise TableFileError(f"{source}: no struct array '{name}'"
                         + (f"; struct arrays in the file: {', '.join(tables)}" if tables
                            else f"; the file holds {', '.join(sorted(tree)) or 'nothing'}"))


def _field(element: MatTree, name: str, where: str) -> Any:
    if name not in element:
        raise TableFileError(f"{where}: no field '{name}' (the element has "
                             f"{', '.join(sorted(element))})")
    return element[name]


def _steps(value: Any, n: int, where: str, dtype: type) -> np.ndarray:
    """A field as (n_steps, channels), transposed when it is channel-major."""
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        raise TableFileError(f"{where}: a field is not numeric") from None
    arr = arr.reshape(-1, 1) if arr.ndim <= 1 else arr
    if arr.shape[0] != n and arr.shape[-1] == n:
        arr = arr.T
    if arr.ndim != 2 or arr.shape[0] != n:
        raise TableFileError(f"{where}: a field has shape {np.shape(value)}, not one value per "
                             f"step ({n} steps)")
    return arr
