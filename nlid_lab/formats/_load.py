"""Recordings of any supported file by its suffix: a run (``.h5``) or a format of `FORMATS`
that commands read directly (NPZ, CSV)."""

from __future__ import annotations

import os
from pathlib import Path

from analysis.recordings import Recording, StepTable

from ._formats import ReadOptions, format_of, suffix_list


def load_recordings(path: str | os.PathLike) -> list[Recording | StepTable]:
    """Recordings of any supported file: run ``.h5`` (one per level), ``.npz`` or ``.csv``
    (stepped-sine tables as `StepTable`)."""
    # the store (h5py) loads on use: every command line imports this room
    from ..store import StoreError, open_run

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".h5", ".hdf5"):
        return open_run(path).recordings()
    fmt = format_of(path)
    if fmt is not None and fmt.direct and fmt.read is not None:
        return [fmt.read(path, ReadOptions())]
    raise StoreError(f"{path}: unknown recording type '{suffix}'; use "
                     f"{suffix_list('direct', ('.h5',))}")
