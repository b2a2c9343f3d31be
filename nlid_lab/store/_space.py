"""Disk space of a run file: the free-space check before and while writing, the reserve a
writer holds, and what a failed write becomes (`DiskFullError`, never a crash).

Why a reserve: HDF5 keeps a block's chunks and its metadata in caches and writes them at the
next flush. When the disk is full that flush fails, the caches stay dirty and closing the file
fails too; h5py then leaves the file open and the interpreter crashes at exit (segmentation
fault) after swallowing the errors of every dataset it deallocates. A writer therefore holds
``RESERVE_BYTES`` of allocated space in ``RUN.h5.reserve`` beside its file: on a failed write
it deletes the reserve, flushes again (the dirty caches then fit), marks the run
``interrupted`` and closes it cleanly. Before each block `require` checks that the block and
its metadata fit, so that in the usual case (our own writes fill the disk) no write fails.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from ._common import StoreError

#: space a writer holds back for its last flush, status and clean close after a failed write
RESERVE_BYTES = 1 << 20
#: metadata written with a block besides its samples (index row, chunk index, log), bounded
BLOCK_OVERHEAD = 64 << 10
#: a run file's header, tables and the rounding of its last data chunk, bounded
HEADER_BYTES = 256 << 10
_FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT)


class DiskFullError(StoreError):
    """The disk holding a run or output file has no room for what is to be written.

    The file is left valid (every stored block intact, marked ``interrupted``)."""


def free_bytes(path: Path) -> int:
    """Bytes free to this user on the file system holding ``path`` (a file or directory)."""
    where = path if path.is_dir() else path.parent
    return shutil.disk_usage(where if str(where) else ".").free


def mb(nbytes: float) -> str:
    """Bytes for people, in MB."""
    return f"{nbytes / 1e6:.3g} MB"


def require(path: Path, nbytes: int, what: str) -> None:
    """Raise `DiskFullError` unless ``nbytes`` fit on the disk of ``path`` (``what`` names
    them in the message)."""
    free = free_bytes(path)
    if free < nbytes:
        raise DiskFullError(f"not enough free space for {what}: {mb(nbytes)} needed, "
                            f"{mb(free)} free on the disk of {path}; free space or write "
                            "to another disk")


def require_room(path: Path, data_bytes: int, what: str) -> None:
    """Raise `DiskFullError` unless a run file that will hold ``data_bytes`` of samples fits
    on the disk of ``path``: with its header, the last chunk's rounding and the writer's
    reserve (``what`` names the data in the message)."""
    require(path, data_bytes + RESERVE_BYTES + HEADER_BYTES,
            f"{what} ({mb(data_bytes)} of data, {mb(RESERVE_BYTES + HEADER_BYTES)} of file "
            "header and reserve)")


def is_disk_full(exc: BaseException) -> bool:
    """True if ``exc`` (an OSError, or the RuntimeError h5py raises from a failed flush) is a
    full disk or quota."""
    if isinstance(exc, OSError) and exc.errno in _FULL_ERRNOS:
        return True
    text = str(exc)
    return any(f"errno = {e}," in text for e in _FULL_ERRNOS) or "No space left" in text


class Reserve:
    """``RESERVE_BYTES`` allocated in ``PATH.reserve`` while a writer has ``PATH`` open;
    `release` gives them back (idempotent). A reserve that cannot be allocated is a
    `DiskFullError` before anything is written."""

    def __init__(self, path: Path, nbytes: int = RESERVE_BYTES) -> None:
        self.held = False
        self.path = path.with_name(path.name + ".reserve")
        try:
            fd = os.open(self.path, os.O_CREAT | os.O_WRONLY | os.O_TRUNC, 0o644)
            try:
                os.posix_fallocate(fd, 0, nbytes)
            finally:
                os.close(fd)
        except OSError as exc:
            self.release()
            if is_disk_full(exc):
                raise DiskFullError(f"no room on the disk of {path} for the writer's "
                                    f"{mb(nbytes)} reserve; free space or write to another "
                                    "disk") from None
            return      # a file system that cannot allocate: write without a reserve
        self.held = True

    def release(self) -> bool:
        """Delete the reserve; returns True if it was held."""
        held, self.held = self.held, False
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass
        return held
