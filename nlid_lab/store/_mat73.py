"""MATLAB v7.3 files (HDF5 inside) read into the flat tree `nlid_lab.formats._mat_io` uses.

MATLAB stores arrays column-major, so a dataset's axes come reversed; structs are groups;
text is ``uint16`` with ``MATLAB_class = "char"``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import h5py
import numpy as np

from analysis.documents import MatTree
from analysis.errors import InputError


def read_mat73(path: Path) -> MatTree:
    """Every numeric or text leaf by dotted name (references and sparse arrays skipped)."""
    out: MatTree = {}
    try:
        with h5py.File(path, "r") as f:
            def visit(name: str, obj: Any) -> None:
                if not isinstance(obj, h5py.Dataset) or name.startswith("#refs#"):
                    return
                cls = obj.attrs.get("MATLAB_class", b"double")
                cls = cls.decode() if isinstance(cls, bytes) else str(cls)
                if obj.dtype.kind not in "fiub" or cls in ("cell", "sparse"):
                    return
                value = np.asarray(obj[()]).T
                if cls == "char":
                    value = "".join(map(chr, value.ravel()))
                elif value.size == 1:
                    value = value.reshape(())
                out[name.replace("/", ".")] = value
            f.visititems(visit)
    except OSError as exc:
        raise InputError(f"{path} is not a readable MAT v7.3 file ({exc})") from None
    return out
