"""NPZ recordings <-> `analysis.Recording` (contracts sections 3, 5 and 6,
docs/recording-formats.md): every key of the file kept (those no field holds in
``Recording.extra``, written back on export); a file holding phasors is a `StepTable`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from analysis.recordings import Excitation, Recording, RecordingKeys, StepTable

from ._monitors import monitor_fields, monitor_keys, trimmed
from ._recording_keys import (LAYOUT_KEYS, RecordingFileError, array_key, extra_keys,
                              force_hold_of, layout_of, level_key, level_of, load_npz_file,
                              scalar_key, sensors_of)
from ._sweep_keys import sweep_fields
from ._tables import control_fields, control_keys, is_table, step_table_keys, table_from_keys


def read_npz(path: str | os.PathLike) -> Recording | StepTable:
    """Read an NPZ recording (keys of contracts sections 3, 5 and 6; others kept in
    ``extra``)."""
    path = Path(path)
    return recording_from_keys(load_npz_keys(path), path)


def load_npz_keys(path: str | os.PathLike) -> RecordingKeys:
    """Every key of an NPZ recording, unchecked (`recording_from_keys` checks them)."""
    return load_npz_file(Path(path), "recording")


def _one_channel(response, force) -> bool:
    """Whether a mapped response holds one channel (its samples as long as the force's)."""
    r, n = np.asarray(response), len(np.asarray(force).reshape(len(force), -1))
    return r.ndim == 1 or (r.ndim == 2 and 1 in r.shape and max(r.shape) == n)


def recording_from_keys(data: RecordingKeys, path: str | os.PathLike
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
    if missing == {"force_dofs"} and path.suffix.lower() in (".mat", ".csv") \
            and _one_channel(data["response"], data["force"]):
        data, missing = {**data, "force_dofs": np.array([0])}, set()   # the only choice
    if missing == {"force_dofs"} and path.suffix.lower() in (".mat", ".csv"):
        raise RecordingFileError(f"{path}: which response channel is measured where the "
                                 "force acts? give force_dofs=K in the --map (0-based)")
    if missing:
        raise RecordingFileError(f"{path}: missing key(s) {sorted(missing)}; an NPZ "
                                 "recording needs fs, force_dofs (or force_points), force and "
                                 "response")
    excitation = (scalar_key(data, "excitation", str, path) if "excitation" in data
                  else ("stepped-sine" if "freqs" in data else "random"))
    try:
        force, response = array_key(data, "force", path), array_key(data, "response", path)
        fs = scalar_key(data, "fs", float, path)
        level, level_from = level_of(data, path, excitation)
        kind = scalar_key(data, "response_kind", str, path) if "response_kind" in data else None
        monitors, units = monitor_fields(data, force.shape[:-1], path)
        sweep = None
        if excitation == Excitation.SWEPT_SINE:
            sweep, force, response, amplitude = sweep_fields(data, force, response, fs)
            level = amplitude if level is None else level
            if monitors and len(force) != len(next(iter(monitors.values()))):  # law estimated
                monitors = trimmed(monitors, sweep.trimmed_lead, force.shape[0])
        sensors, force_dofs = sensors_of(data, response, kind, path)
        return Recording(
            fs=fs, excitation=excitation, force_dofs=force_dofs, force=force,
            response=response, response_kind=kind or "displacement", sensors=sensors,
            freqs=array_key(data, "freqs", path) if "freqs" in data else None,
            level=level, force_hold=force_hold_of(data, path),
            layout=layout_of(data, path, force.shape[0] if force.ndim else 0), sweep=sweep,
            extra=extra_keys(data, excitation, level_from), meta={"source": str(path)},
            monitors=monitors, monitor_units=units,
            **(control_fields(data, path)._asdict() if excitation == Excitation.STEPPED_SINE
               else {}))
    except (TypeError, ValueError) as exc:  # RecordingError included: name the file
        raise RecordingFileError(f"{path}: {exc}") from None



def recording_keys(rec: Recording | StepTable) -> RecordingKeys:
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

