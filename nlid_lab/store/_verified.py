"""Verified levels a run check read, kept for the read that follows it: one pass over a run's
samples. `Run.check` reads each block once and verifies its checksum; the intact blocks are
kept here, keyed by the file's identity (device, inode, size, modification time), and
`Run.recording` takes them instead of reading the file again. A file changed since its check
is read afresh; what is kept is bounded (`KEEP_BYTES`, oldest dropped first) and handed out
once."""

from __future__ import annotations

import os
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._integrity import LeftOut

#: samples kept between a check and the read that follows it, at most (bytes)
KEEP_BYTES = 1 << 29


@dataclass(frozen=True)
class VerifiedLevel:
    """One level's blocks as read and verified: the intact ones (index rows in ``seq``
    order, samples ``(force, response, monitor)``, extra JSON) and those left out."""

    segments: np.ndarray
    parts: list
    extra: list
    bad: tuple[LeftOut, ...]

    @property
    def nbytes(self) -> int:
        """Bytes of samples held."""
        return sum(a.nbytes for p in self.parts for a in p if a is not None)


Identity = tuple[str, int, int, int, int]
_kept: OrderedDict[tuple[Identity, int], VerifiedLevel] = OrderedDict()


def identity(path: Path) -> Identity:
    """What tells this file from a changed one: path, device, inode, size, mtime (ns)."""
    st = os.stat(path)
    return (str(Path(path).resolve()), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def keep(ident: Identity, index: int, level: VerifiedLevel) -> None:
    """Keep level ``index`` of the file ``ident`` for the next read (oldest dropped first
    beyond `KEEP_BYTES`; a level larger than that is not kept)."""
    for key in [k for k in _kept if k[0][0] == ident[0] and k[0] != ident]:
        del _kept[key]                  # the file changed: what was kept of it is stale
    if level.nbytes > KEEP_BYTES:
        return
    _kept[(ident, index)] = level
    while sum(v.nbytes for v in _kept.values()) > KEEP_BYTES:
        _kept.popitem(last=False)


def take(ident: Identity, index: int) -> VerifiedLevel | None:
    """Level ``index`` of the file ``ident`` as its check read it (handed out once), or None."""
    return _kept.pop((ident, index), None)


def release_checked() -> None:
    """Drop every verified level kept for a later read (their memory is free at once; the
    next read reads the file again)."""
    _kept.clear()
