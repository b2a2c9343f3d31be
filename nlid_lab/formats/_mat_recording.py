"""Recordings as MAT files: `nlid-lab export RUN.h5 --out REC.mat` and its import back.

Every recording key (`nlid_lab.formats._npz.recording_keys`) is a MATLAB variable of the same name
(``force``, ``response``, ``fs``, ``sweep_start_hz``...), readable in MATLAB as it is. MAT
files know no 1-D arrays, 0-d scalars or NumPy dtypes, so a text variable ``nlid_recording``
(JSON) keeps each key's shape and dtype, and the exact value of text keys (MAT pads char
arrays): `read_mat_recording`
rebuilds every key exactly. A file without it is an acquisition export: import it through a
channel map (`mat_io`).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from analysis.documents import MatTree
from analysis.recordings import Recording

from ._npz import recording_from_keys, recording_keys
from ._recording_keys import RecordingFileError

#: the variable holding the keys' shapes and dtypes (and text values)
INDEX = "nlid_recording"
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,62}$")


def write_mat(path: str | os.PathLike, rec: Recording) -> None:
    """Write ``rec`` as a MAT (v5) file: one variable per key, plus `INDEX`."""
    import scipy.io   # loads on use: every command line imports this room

    index: dict[str, Any] = {}
    variables: dict[str, np.ndarray] = {}
    for key, value in recording_keys(rec).items():
        arr = np.asarray(value)
        if not _NAME.match(key) or key == INDEX:
            raise RecordingFileError(f"key '{key}' is not a MATLAB variable name; export as "
                                     "NPZ")
        if arr.dtype.kind == "U":            # a char array for MATLAB, exact in the index
            index[key] = {"shape": list(arr.shape), "dtype": arr.dtype.str,
                          "text": arr.tolist()}
            variables[key] = arr
            continue
        if arr.dtype.kind not in "biufc":
            raise RecordingFileError(f"key '{key}' ({arr.dtype}) cannot be written to a MAT "
                                     "file (numbers and text only); export as NPZ")
        index[key] = {"shape": list(arr.shape), "dtype": arr.dtype.str}
        variables[key] = arr.astype(np.uint8) if arr.dtype.kind == "b" else arr
    variables[INDEX] = np.str_(json.dumps(index))
    with open(path, "wb") as fh:
        scipy.io.savemat(fh, variables, do_compression=True)


def is_recording(tree: MatTree) -> bool:
    """True if a MAT tree (`mat_io.read_mat_tree`) was written by `write_mat`."""
    return INDEX in tree


def read_mat_recording(path: str | os.PathLike) -> Recording:
    """The recording `write_mat` wrote to ``path``, every key as it was."""
    import scipy.io   # loads on use: every command line imports this room

    path = Path(path)
    try:
        raw = scipy.io.loadmat(path, squeeze_me=False, chars_as_strings=True)
        index = json.loads(str(np.asarray(raw[INDEX]).reshape(-1)[0]))
    except (KeyError, ValueError, OSError, TypeError) as exc:
        raise RecordingFileError(f"{path}: not a recording written by nlid-lab export "
                                 f"({exc}); import it with --map") from None
    keys: dict[str, np.ndarray] = {}
    for key, info in index.items():
        dtype = np.dtype(info["dtype"])
        if "text" in info:
            keys[key] = np.asarray(info["text"], dtype=dtype).reshape(info["shape"])
        elif key not in raw:
            raise RecordingFileError(f"{path}: variable '{key}' listed in {INDEX} is missing")
        else:
            keys[key] = np.asarray(raw[key]).astype(dtype).reshape(info["shape"])
    return recording_from_keys(keys, path)
