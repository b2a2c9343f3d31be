"""Recordings of any supported file by its suffix: a run (``.h5``), NPZ or CSV."""

from __future__ import annotations

import os
from pathlib import Path

from analysis.recordings import Recording, StepTable

from ._csv import read_csv
from ._npz import read_npz


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
