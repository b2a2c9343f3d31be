"""Drive files of ``nlid-lab simulate --drive DRIVE.npz`` (docs/recording-formats.md): the
forces to play, with their sample rate, DOFs or points, and an optional stepped, swept or
periodic layout."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from analysis.recordings import KEYS as SENSOR_KEYS
from analysis.recordings import MAX_FS, MAX_SAMPLE, MIN_FS, names

from ._recording_keys import (RecordingFileError, array_key, extra_keys, layout_of, level_of,
                              load_npz_file, scalar_key)
from ._sweep_keys import sweep_fields


def read_drive(path: str | os.PathLike) -> dict:
    """Read a drive NPZ (keys fs, force, force_dofs; freqs for stepped sine).

    Returns a dict with ``fs``, ``force`` (random (n, n_in); stepped (n_steps, n, n_in)),
    ``force_dofs``, ``excitation``, ``freqs`` (or None), ``level`` (or None), ``layout``
    (a `PeriodicLayout` from the drive's ``period``... keys, or None), ``sweep`` (an
    ``excitation = "swept-sine"`` drive's `Sweep`, from its keys or estimated from its
    force; else None) and ``extra`` (the
    drive's other keys, for the simulated recording). A recording used as a drive gives
    its force: its ``response``, ``response_kind`` and ``force_hold`` are not carried.
    ``sensors`` holds the drive's sensor-map keys (`analysis.recordings.KEYS`, lists of names;
    ``force_points`` then name the model points the forces act on).
    """
    path = Path(path)
    data = load_npz_file(path, "drive")
    missing = {"fs", "force", "force_dofs"} - set(data)
    if missing == {"force_dofs"} and "force_points" in data:
        missing = set()
    if missing:
        raise RecordingFileError(f"{path}: missing key(s) {sorted(missing)}; a drive NPZ "
                                 "needs fs, force and force_dofs (or force_points)")
    try:
        points = names(data["force_points"], "force_points") if "force_points" in data \
            else None
        drive = {"fs": scalar_key(data, "fs", float, path),
                 "force": array_key(data, "force", path),
                 "force_dofs": (array_key(data, "force_dofs", path, integer=True)
                                if "force_dofs" in data else np.arange(len(points))),
                 "freqs": array_key(data, "freqs", path) if "freqs" in data else None,
                 # sensor-map keys: where the forces act and what the channels measure
                 "sensors": {k: names(data[k], k) for k in SENSOR_KEYS if k in data}}
        stepped = drive["freqs"] is not None
        swept = not stepped and "excitation" in data \
            and scalar_key(data, "excitation", str, path) == "swept-sine"
        drive["excitation"] = "stepped-sine" if stepped else "swept-sine" if swept else "random"
        drive["level"], level_from = level_of(data, path, drive["excitation"])
        drive["extra"] = extra_keys(data, drive["excitation"], level_from)
    except (TypeError, ValueError) as exc:
        raise RecordingFileError(f"{path}: {exc}") from None
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
    try:
        drive["layout"] = None if stepped else layout_of(data, path, force.shape[0])
        drive["sweep"] = None
        if drive["excitation"] == "swept-sine":     # a sweep drive plays from its first sample
            drive["sweep"], drive["force"], _, level = sweep_fields(data, force, force,
                                                                    drive["fs"])
            drive["level"] = drive["level"] or level
    except ValueError as exc:
        raise RecordingFileError(f"{path}: {exc}") from None
    return drive
