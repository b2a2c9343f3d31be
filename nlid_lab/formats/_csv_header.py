"""The header of a CSV recording: the time column and each channel column (``NAME@DOF`` or
``NAME (UNIT)``), with its scale to SI and what it measures (docs/recording-formats.md).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ._recording_keys import RecordingFileError
from ._units import lookup, split_label

_COLUMN = re.compile(r"^\s*([A-Za-z_][\w.\-]*)\s*@\s*(?:dof)?(\d+)\s*$")


@dataclass
class Column:
    """One channel column of a CSV recording."""

    index: int
    name: str
    dof: int | None
    factor: float = 1.0              # to SI
    quantity: str | None = None      # from the unit: force, displacement, velocity, ...


def parse_header(names: list[str], force_cols: list[str] | None = None
                 ) -> tuple[int, float, list[Column]]:
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
        chans.append(Column(i, name, dof, factor, quantity))
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


def is_force(c: Column, force_cols: list[str] | None) -> bool:
    """Whether column ``c`` is a force: named in ``force_cols`` when given, else by its unit,
    else by its name starting with ``f``."""
    if force_cols is not None:
        return c.name in force_cols
    if c.quantity is not None:
        return c.quantity == "force"
    return c.name.lower().startswith("f")

