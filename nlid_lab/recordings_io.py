"""NPZ and CSV recordings <-> `analysis.Recording` (docs/recording-formats.md).

NPZ follows contracts section 3. CSV holds random recordings: a header row naming a time
column (``t`` or ``time``, seconds) and one column per channel written ``NAME@DOF``; names
starting with ``f`` are forces, the others responses (override with ``force_cols``).
"""

from __future__ import annotations

import csv
import io
import os
import re
import zipfile
from pathlib import Path

import numpy as np

from analysis.errors import InputError, RecordingError
from analysis.recording import MAX_FS, MAX_SAMPLE, MIN_FS, Recording
from analysis.textfile import read_text

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


def read_npz(path: str | os.PathLike) -> Recording:
    """Read an NPZ recording (keys of contracts section 3)."""
    path = Path(path)
    data = _load_npz(path, "recording")
    missing = {"fs", "force", "response", "force_dofs"} - set(data)
    if missing:
        raise RecordingFileError(f"{path}: missing key(s) {sorted(missing)}; an NPZ "
                                 "recording needs fs, force_dofs, force and response")
    excitation = (_scalar(data, "excitation", str, path) if "excitation" in data
                  else ("stepped-sine" if "freqs" in data else "random"))
    try:
        return Recording(
            fs=_scalar(data, "fs", float, path), excitation=excitation,
            force_dofs=_array(data, "force_dofs", path, integer=True),
            force=_array(data, "force", path), response=_array(data, "response", path),
            response_kind=(_scalar(data, "response_kind", str, path)
                           if "response_kind" in data else "displacement"),
            freqs=_array(data, "freqs", path) if "freqs" in data else None,
            level=_level(data, path), meta=_meta(data, path))
    except (TypeError, ValueError) as exc:  # RecordingError included: name the file
        raise RecordingFileError(f"{path}: {exc}") from None


def _meta(data: dict, path: Path) -> dict:
    meta = {"source": str(path)}
    if "force_hold" in data:
        hold = _scalar(data, "force_hold", str, path)
        if hold not in ("none", "linear"):
            raise RecordingFileError(f"{path}: force_hold '{hold}' must be none or linear")
        meta["force_hold"] = hold
    return meta


def _level(data: dict, path: Path) -> float | None:
    for key in ("force_rms", "force_amplitude", "level"):
        if key in data:
            return _scalar(data, key, float, path)
    return None


def write_npz(path: str | os.PathLike, rec: Recording) -> None:
    """Write ``rec`` as an NPZ recording (contracts section 3)."""
    out = {"fs": np.float64(rec.fs), "excitation": np.str_(rec.excitation),
           "force_dofs": rec.force_dofs, "force": rec.force, "response": rec.response,
           "response_kind": np.str_(rec.response_kind)}
    if rec.freqs is not None:
        out["freqs"] = rec.freqs
    if rec.meta.get("force_hold"):
        out["force_hold"] = np.str_(rec.meta["force_hold"])
    if rec.level is not None:
        key = "force_rms" if rec.excitation == "random" else "force_amplitude"
        out[key] = np.float64(rec.level)
    with open(path, "wb") as fh:  # np.savez would append ".npz" to other names
        np.savez(fh, **out)


def parse_header(names: list[str], force_cols: list[str] | None = None
                 ) -> tuple[int, list[tuple[int, str, int]]]:
    """Return the time column index and ``(column, name, dof)`` of each channel column."""
    time_col = [i for i, n in enumerate(names) if n.strip().lower() in ("t", "time", "t [s]")]
    if len(time_col) != 1:
        raise RecordingFileError("CSV header needs exactly one time column named 't' or "
                                 f"'time'; got {names}")
    chans = []
    for i, name in enumerate(names):
        if i == time_col[0]:
            continue
        m = _COLUMN.match(name)
        if not m:
            raise RecordingFileError(f"CSV column '{name.strip()}' is not NAME@DOF (e.g. "
                                     "f0@0, x1@1); name every channel with its 0-based DOF")
        chans.append((i, m.group(1), int(m.group(2))))
    if force_cols is not None:
        unknown = set(force_cols) - {c[1] for c in chans}
        if unknown:
            raise RecordingFileError(f"--force-cols names {sorted(unknown)} not in the header")
    return time_col[0], chans


def read_csv(path: str | os.PathLike, force_cols: list[str] | None = None,
             response_kind: str = "displacement", level: float | None = None) -> Recording:
    """Read a random recording from CSV (see the module docstring for the header)."""
    path = Path(path)
    text = read_text(path, "recording", RecordingFileError, max_bytes=MAX_CSV_BYTES)
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 3:
        raise RecordingFileError(f"{path}: needs a header row and at least two data rows")
    names = next(csv.reader([lines[0]]))
    time_col, chans = parse_header(names, force_cols)
    try:
        data = np.loadtxt(io.StringIO("\n".join(lines[1:])), delimiter=",", ndmin=2)
    except ValueError as exc:
        raise RecordingFileError(f"{path}: bad number in the data ({exc})") from None
    if data.shape[1] != len(names):
        raise RecordingFileError(f"{path}: {data.shape[1]} data columns but {len(names)} "
                                 "header names")
    t = data[:, time_col]
    span = t[-1] - t[0]
    fs = (len(t) - 1) / span if np.isfinite(span) and span > 0 else np.nan
    grid = t[0] + np.arange(len(t)) / fs
    if not np.isfinite(fs) or np.max(np.abs(t - grid)) > 0.01 / fs:
        raise RecordingFileError(f"{path}: the time column must increase in equal steps "
                                 "(uniform sampling, jitter below 1 % of a sample)")
    is_force = [(n in force_cols) if force_cols is not None else n.lower().startswith("f")
                for _, n, _ in chans]
    forces = [c for c, f in zip(chans, is_force) if f]
    responses = sorted((c for c, f in zip(chans, is_force) if not f), key=lambda c: c[2])
    if not forces or not responses:
        raise RecordingFileError(f"{path}: need at least one force and one response column "
                                 "(forces are named f...@DOF unless --force-cols is given)")
    dofs = [c[2] for c in responses]
    if dofs != list(range(len(dofs))):
        raise RecordingFileError(f"{path}: response columns must cover DOFs 0..n-1 once each, "
                                 f"got DOFs {dofs}")
    try:
        return Recording(
            fs=fs, excitation="random", force_dofs=[c[2] for c in forces],
            force=data[:, [c[0] for c in forces]], response=data[:, [c[0] for c in responses]],
            response_kind=response_kind, level=level,
            meta={"source": str(path), "channels": [c[1] for c in forces + responses]})
    except RecordingError as exc:
        raise RecordingFileError(f"{path}: {exc}") from None


def write_csv(path: str | os.PathLike, rec: Recording) -> None:
    """Write a random ``rec`` as CSV with header ``t,f0@DOF,...,x0@0,...``."""
    if rec.excitation != "random":
        raise RecordingFileError("CSV holds random recordings only; write stepped sine as NPZ")
    prefix = rec.response_kind[0]
    names = (["t"] + [f"f{i}@{d}" for i, d in enumerate(rec.force_dofs)]
             + [f"{prefix}{j}@{j}" for j in range(rec.n_dof)])
    t = np.arange(rec.force.shape[0]) / rec.fs
    np.savetxt(path, np.column_stack([t, rec.force, rec.response]), delimiter=",",
               header=",".join(names), comments="", fmt="%.17g")


def read_drive(path: str | os.PathLike) -> dict:
    """Read a drive NPZ (keys fs, force, force_dofs; freqs for stepped sine).

    Returns a dict with ``fs``, ``force`` (random (n, n_in); stepped (n_steps, n, n_in)),
    ``force_dofs``, ``excitation``, ``freqs`` (or None) and ``level`` (or None).
    """
    path = Path(path)
    data = _load_npz(path, "drive")
    missing = {"fs", "force", "force_dofs"} - set(data)
    if missing:
        raise RecordingFileError(f"{path}: missing key(s) {sorted(missing)}; a drive NPZ "
                                 "needs fs, force and force_dofs")
    try:
        drive = {"fs": _scalar(data, "fs", float, path),
                 "force": _array(data, "force", path),
                 "force_dofs": _array(data, "force_dofs", path, integer=True),
                 "freqs": _array(data, "freqs", path) if "freqs" in data else None,
                 "level": _level(data, path)}
    except (TypeError, ValueError) as exc:
        raise RecordingFileError(f"{path}: {exc}") from None
    stepped = drive["freqs"] is not None
    drive["excitation"] = "stepped-sine" if stepped else "random"
    force, n_in = drive["force"], drive["force_dofs"].size
    if force.ndim == 1 and n_in == 1 and not stepped:
        force = drive["force"] = force[:, None]
    want = 3 if stepped else 2
    if force.ndim != want or force.shape[-1] != n_in:
        raise RecordingFileError(f"{path}: force has shape {force.shape}; expected "
                                 f"{'(n_steps, n, n_in)' if stepped else '(n, n_in)'} with "
                                 f"n_in = {n_in} (one column per force_dofs entry)")
    if stepped and drive["freqs"].shape != (force.shape[0],):
        raise RecordingFileError(f"{path}: freqs must hold one frequency per step "
                                 f"({force.shape[0]})")
    if not np.all(np.isfinite(force)):
        raise RecordingFileError(f"{path}: force holds NaN/infinite samples; repair the drive")
    if force.size == 0 or force.shape[-2] < 2:
        raise RecordingFileError(f"{path}: force of shape {force.shape} needs at least 2 "
                                 "samples")
    if np.abs(force).max() > MAX_SAMPLE:
        raise RecordingFileError(f"{path}: force holds samples beyond +-{MAX_SAMPLE:g} N; "
                                 "check the units and scaling")
    if not MIN_FS <= drive["fs"] <= MAX_FS:
        raise RecordingFileError(f"{path}: fs must be a number in {MIN_FS:g}..{MAX_FS:g} Hz")
    if stepped and not np.all((drive["freqs"] > 0) & (drive["freqs"] < drive["fs"] / 2)):
        raise RecordingFileError(f"{path}: freqs must lie between 0 and fs/2")
    if drive["level"] is not None and not 0 < drive["level"] <= MAX_SAMPLE:
        raise RecordingFileError(f"{path}: the level (force_rms/force_amplitude) must be a "
                                 f"number in (0, {MAX_SAMPLE:g}] N")
    return drive
