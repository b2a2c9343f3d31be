"""The keys of a recording file (NPZ, CSV ``# key`` lines, a MAT import's) and their
checks: each key's type and shape, the level, layout, force hold and sensor map they give, and
the keys no `Recording` field holds (kept in ``extra``). Contracts sections 3 and 5,
docs/recording-formats.md.
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import InputError
from analysis.recordings import (FORCE_HOLDS, KEYS as SENSOR_KEYS, SWEEP_KEYS, Excitation,
                                 PeriodicLayout, RecordingKeys, SensorMap)

from ._monitors import MONITOR_KEYS
from ._tables import CONTROL_KEYS


class RecordingFileError(InputError):
    """A recording file is missing, unreadable or does not follow its format."""


def scalar_key(data: RecordingKeys, key: str, cast: Callable[[Any], Any], path: Path
               ) -> Any:
    """The one value of ``data[key]`` as ``cast`` (float: a real number; str: text)."""
    arr = np.asarray(data[key])
    if arr.size != 1:
        raise RecordingFileError(f"{path}: '{key}' must be a scalar, got shape {arr.shape}")
    if cast is float:
        real_array(arr, key, path)
    elif arr.dtype.kind not in "US":
        raise RecordingFileError(f"{path}: '{key}' must be a string, got {arr.dtype} {arr!r}")
    try:
        return cast(arr.reshape(()).item())
    except (TypeError, ValueError):
        raise RecordingFileError(f"{path}: '{key}' = {arr!r} is not a valid {cast.__name__}") \
            from None


def real_array(arr: np.ndarray, key: str, path: Path, integer: bool = False) -> np.ndarray:
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


def array_key(data: RecordingKeys, key: str, path: Path, integer: bool = False
              ) -> np.ndarray:
    """``data[key]`` as a float array (an integer one, at least 1-D, if ``integer``)."""
    arr = real_array(np.asarray(data[key]), key, path, integer)
    return np.atleast_1d(arr).astype(int) if integer else arr.astype(float)


def load_npz_file(path: Path, what: str) -> RecordingKeys:
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
    return "force_rms" if excitation == Excitation.RANDOM else "force_amplitude"



def sensors_of(data: dict, response: np.ndarray, kind: str | None, path: Path
             ) -> tuple[SensorMap | None, np.ndarray]:
    """The sensor map of a file's keys (`analysis.recordings.KEYS`) and the force DOFs (the
    channels measuring ``force_points`` when the file gives no ``force_dofs``)."""
    n = response.shape[-1] if response.ndim else 0
    dofs = array_key(data, "force_dofs", path, integer=True) if "force_dofs" in data else None
    smap = SensorMap.from_keys(data, n, [] if dofs is None else np.atleast_1d(dofs), kind)
    if smap is None:
        return None, dofs
    smap.validate(n, len(smap.force_points))
    return smap, np.asarray(smap.force_channels) if dofs is None else dofs


def force_hold_of(data: dict, path: Path) -> str:
    """The force hold the keys declare (``none`` when they declare none)."""
    if "force_hold" not in data:
        return "none"
    hold = scalar_key(data, "force_hold", str, path)
    if hold not in FORCE_HOLDS:
        raise RecordingFileError(f"{path}: force_hold '{hold}' must be none or linear")
    return hold


def layout_of(data: dict, path: Path, n: int) -> PeriodicLayout | None:
    """The periodic layout the file's keys describe (missing keys completed), else None."""
    given = {k: scalar_key(data, k, float, path) for k in LAYOUT_KEYS if k in data}
    if not given:
        return None
    if "period" not in given:
        raise RecordingFileError(f"{path}: {sorted(given)} given without period (samples per "
                                 "period); add period or remove the layout keys")
    return PeriodicLayout.complete(n, **given)


def level_of(data: dict, path: Path, excitation: str) -> tuple[float | None, str | None]:
    """Nominal level and the key it came from (the excitation's own key first)."""
    own = level_key(excitation)
    for key in (own,) + tuple(k for k in LEVEL_KEYS if k != own):
        if key in data:
            return scalar_key(data, key, float, path), key
    return None, None


def extra_keys(data: RecordingKeys, excitation: str, level_from: str | None) -> dict[str, np.ndarray]:
    """Keys no field holds. A level read from another key than the excitation's own (say
    ``level``) stays here too, so that the file's own key is written back."""
    known = (set(CORE_KEYS) | set(LAYOUT_KEYS) | set(SENSOR_KEYS) | set(MONITOR_KEYS)
             | {"force_hold"})
    if excitation == Excitation.SWEPT_SINE:
        known |= set(SWEEP_KEYS)
    if excitation == Excitation.STEPPED_SINE:
        known |= set(CONTROL_KEYS)
    if level_from == level_key(excitation):
        known.add(level_from)
    return {k: np.asarray(v) for k, v in data.items() if k not in known}
