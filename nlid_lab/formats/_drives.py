"""Drive files of ``nlid-lab simulate --drive DRIVE.npz`` (docs/recording-formats.md): the
forces to play, with their sample rate, DOFs or points, and an optional stepped, swept or
periodic layout."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from analysis.recordings import KEYS as SENSOR_KEYS
from analysis.recordings import (MAX_FS, MAX_SAMPLE, MIN_FS, Excitation, PeriodicLayout, Sweep,
                                 names)

from ._recording_keys import (RecordingFileError, array_key, extra_keys, layout_of, level_of,
                              load_npz_file, scalar_key)
from ._sweep_keys import sweep_fields


@dataclass(frozen=True)
class Drive:
    """The forces to play (a drive file, parsed).

    ``force`` is (n, n_in) (random, swept) or (n_steps, n, n_in) (stepped sine, one step
    per ``freqs`` entry); ``level`` the nominal one (or None); ``layout`` the periodic layout
    of the ``period``... keys (or None); ``sweep`` a swept-sine drive's `Sweep`, from its keys
    or estimated from its force; ``extra`` the file's other keys, carried to the simulated
    recording; ``sensors`` its sensor-map keys (`analysis.recordings.KEYS`, lists of names;
    ``force_points`` then name the model points the forces act on).
    """

    fs: float
    force: np.ndarray
    force_dofs: np.ndarray
    excitation: str = "random"
    freqs: np.ndarray | None = None
    level: float | None = None
    layout: PeriodicLayout | None = None
    sweep: Sweep | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    sensors: dict[str, list[str]] = field(default_factory=dict)


def read_drive(path: str | os.PathLike) -> Drive:
    """Read a drive NPZ (keys fs, force, force_dofs; freqs for stepped sine) into a `Drive`.

    A recording used as a drive gives its force: its ``response``, ``response_kind`` and
    ``force_hold`` are not carried.
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
        fs, force = scalar_key(data, "fs", float, path), array_key(data, "force", path)
        dofs = (array_key(data, "force_dofs", path, integer=True) if "force_dofs" in data
                else np.arange(len(points)))
        freqs = array_key(data, "freqs", path) if "freqs" in data else None
        # sensor-map keys: where the forces act and what the channels measure
        sensors = {k: names(data[k], k) for k in SENSOR_KEYS if k in data}
        swept = freqs is None and "excitation" in data \
            and scalar_key(data, "excitation", str, path) == Excitation.SWEPT_SINE
        excitation = "stepped-sine" if freqs is not None else "swept-sine" if swept \
            else "random"
        level, level_from = level_of(data, path, excitation)
        extra = extra_keys(data, excitation, level_from)
    except (TypeError, ValueError) as exc:
        raise RecordingFileError(f"{path}: {exc}") from None
    if force.ndim == 1 and dofs.size == 1 and freqs is None:
        force = force[:, None]
    _check(path, fs, force, dofs.size, freqs, level)
    try:
        layout = None if freqs is not None else layout_of(data, path, force.shape[0])
        sweep = None
        if swept:                                   # a sweep drive plays from its first sample
            sweep, force, _, amplitude = sweep_fields(data, force, force, fs)
            level = level or amplitude
    except ValueError as exc:
        raise RecordingFileError(f"{path}: {exc}") from None
    return Drive(fs, force, dofs, excitation, freqs, level, layout, sweep, extra, sensors)


def _check(path: Path, fs: float, force: np.ndarray, n_in: int, freqs: np.ndarray | None,
           level: float | None) -> None:
    """Refuse a drive whose force, rate, frequencies or level cannot be played."""
    stepped = freqs is not None
    if force.ndim != (3 if stepped else 2) or force.shape[-1] != n_in:
        raise RecordingFileError(f"{path}: force has shape {force.shape}; expected "
                                 f"{'(n_steps, n, n_in)' if stepped else '(n, n_in)'} with "
                                 f"n_in = {n_in} (one column per force_dofs entry)")
    if stepped and freqs.shape != (force.shape[0],):
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
    if not MIN_FS <= fs <= MAX_FS:
        raise RecordingFileError(f"{path}: fs must be a number in {MIN_FS:g}..{MAX_FS:g} Hz")
    if stepped and not np.all((freqs > 0) & (freqs < fs / 2)):
        raise RecordingFileError(f"{path}: freqs must lie between 0 and fs/2")
    if level is not None and not 0 < level <= MAX_SAMPLE:
        raise RecordingFileError(f"{path}: the level (force_rms/force_amplitude) must be a "
                                 f"number in (0, {MAX_SAMPLE:g}] N")
