"""Schema constants and low-level HDF5 helpers shared by the run writer and reader."""

from __future__ import annotations

import fcntl
import io
import json
import os
import time
import zlib
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from analysis.errors import InputError

SCHEMA_VERSION = 1
#: runs with monitor channels: their block checksums cover the monitors, which a version-1
#: reader would take for corrupt blocks; runs without stay version 1
MONITORS_SCHEMA_VERSION = 2


def _software() -> str:
    try:
        return f"nlid-lab {metadata.version('nlid-lab')}"
    except metadata.PackageNotFoundError:   # run from a source tree that is not installed
        return "nlid-lab (not installed)"


SOFTWARE = _software()


FORMAT = "nlid-lab run"


STATUSES = ("running", "complete", "aborted", "interrupted")


RESPONSE_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}


CHUNK_ROWS = 4096


CHANNEL_DTYPE = np.dtype([("name", "S64"), ("unit", "S16"), ("dof", "<i4"),
                          ("sensitivity", "<f8"), ("kind", "S16")])


LEVEL_DTYPE = np.dtype([("index", "<i4"), ("nominal", "<f8"), ("complete", "u1")])


SEGMENT_DTYPE = np.dtype([("level", "<i4"), ("seq", "<i8"), ("t", "<f8"), ("start", "<i8"),
                          ("length", "<i8"), ("freq", "<f8"), ("amplitude", "<f8"),
                          ("crc", "<u4"), ("extra_start", "<i8"), ("extra_length", "<i8")])


LOG_DTYPE = np.dtype([("t", "<f8"), ("kind", "S16"), ("start", "<i8"), ("length", "<i8")])


_TABLES = {"levels": LEVEL_DTYPE, "segments": SEGMENT_DTYPE, "log": LOG_DTYPE}


class StoreError(InputError):
    """A run file is missing, unreadable or inconsistent with what is written to it."""


def utc_now() -> str:
    """Current time as an ISO-8601 UTC string."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _open(path: Path, mode: str) -> h5py.File:
    """Open ``path``. Locking is best-effort (file systems without locks work) and the same for
    readers and writers (HDF5 refuses a second open with other flags in one process)."""
    try:
        if mode == "r":
            try:  # plain first: a SWMR reader retries a corrupt file's metadata for minutes
                return h5py.File(path, "r", locking="best-effort")
            except OSError as exc:
                if "open for" not in str(exc) and "consistency" not in str(exc):
                    raise
                # flagged as open by a (live or crashed) SWMR writer: read as SWMR
                return h5py.File(path, "r", swmr=True, locking="best-effort")
        return h5py.File(path, mode, libver="latest", locking="best-effort")
    except FileNotFoundError:
        raise StoreError(f"run file {path} not found; check the path") from None
    except OSError as exc:
        if "already open for write" in str(exc):
            raise
        raise StoreError(f"cannot open {path} as an HDF5 run file ({' '.join(str(exc).split())})"
                         "; is it a run written by nlid-lab?") from None


def _open_swmr_write(path: Path) -> h5py.File:
    """Open an existing run file for appending directly in SWMR-write mode.

    Opening ``r+`` and then switching ``swmr_mode`` on leaves a moment in which the superblock
    says "open for write" without SWMR; a writer killed then leaves a file that even SWMR
    readers refuse. The low-level open with ``ACC_SWMR_WRITE`` has no such moment.
    """
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5py.h5f.LIBVER_LATEST, h5py.h5f.LIBVER_LATEST)
    fapl.set_file_locking(True, True)   # best-effort, as `_open`
    try:
        fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDWR | h5py.h5f.ACC_SWMR_WRITE,
                            fapl=fapl)
    except OSError as exc:
        raise StoreError(f"cannot open {path} for writing ({' '.join(str(exc).split())})"
                         ) from None
    return h5py.File(fid)


class WriterLock:
    """Shared advisory lock a writer holds on its run file while it has it open.

    HDF5 drops its own file lock once SWMR writing starts (so that readers can open the
    file); this lock tells `in_use` that a live process still writes the file (a crashed
    writer's lock is released by the kernel). Readers never take it; file systems without
    locks make it a no-op.
    """

    def __init__(self, path: Path) -> None:
        self._fd: int | None = os.open(path, os.O_RDONLY)
        try:
            fcntl.flock(self._fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            self.release()

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def in_use(path: Path) -> bool:
    """True if a live process holds a `WriterLock` (or an HDF5 lock) on ``path``."""
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return False
    except BlockingIOError:
        return True
    except OSError:
        return False    # no locks on this file system: nothing to tell
    finally:
        os.close(fd)


def writer_left_open(path: Path) -> bool:
    """True if ``path`` still carries the "open for write" superblock flag: its writer is
    running, or was killed (ordinary HDF5 tools cannot open the file until it is repaired)."""
    try:
        h5py.File(path, "r", locking="best-effort").close()
        return False
    except OSError as exc:
        return "open for" in str(exc) or "consistency" in str(exc)


def _crc(force: np.ndarray, response: np.ndarray, monitor: np.ndarray | None = None) -> int:
    """Checksum of a block's samples (its monitor channels' too, when the run has some)."""
    crc = zlib.crc32(response.tobytes(), zlib.crc32(force.tobytes()))
    return crc if monitor is None else zlib.crc32(np.ascontiguousarray(monitor).tobytes(), crc)


def _default_channels(force_dofs: np.ndarray, n_dof: int, response_kind: str,
                      sensors: Any = None) -> list[dict]:
    """Channel table rows; with a sensor map (`analysis.recordings.SensorMap`) the responses
    are named after their points and carry their own kinds' units."""
    chans = [{"name": f"force{i}" if sensors is None else f"force@{sensors.force_points[i]}",
              "unit": "N", "dof": int(d), "kind": "force"} for i, d in enumerate(force_dofs)]
    kinds = [response_kind] * n_dof if sensors is None else sensors.response_kinds
    chans += [{"name": f"{kinds[j][0]}{j}" if sensors is None else
               sensors.response_points[j], "unit": RESPONSE_UNITS[kinds[j]],
               "dof": j, "kind": "response"} for j in range(n_dof)]
    return chans


def _channel_table(channels: list[dict], force_dofs: np.ndarray, n_dof: int) -> np.ndarray:
    table = np.zeros(len(channels), CHANNEL_DTYPE)
    for i, ch in enumerate(channels):
        try:
            table[i] = (str(ch["name"]).encode(), str(ch.get("unit", "")).encode(),
                        int(ch["dof"]), float(ch.get("sensitivity", 1.0)),
                        str(ch["kind"]).encode())
        except (KeyError, ValueError, TypeError) as exc:
            raise StoreError(f"channel {i} {ch!r} is malformed ({exc}); give name, unit, dof, "
                             "kind and optionally sensitivity") from None
    forces = table[table["kind"] == b"force"]["dof"]
    responses = table[table["kind"] == b"response"]["dof"]
    if forces.tolist() != force_dofs.tolist() or sorted(responses.tolist()) != list(range(n_dof)):
        raise StoreError("channels must list one force channel per force DOF (in force_dofs "
                         "order) and one response channel per DOF 0..n_dof-1")
    return table


def _append_row(f: h5py.File, name: str, row: tuple) -> None:
    ds = f[name]
    ds.resize((ds.shape[0] + 1,))
    ds[-1] = np.array(row, dtype=ds.dtype)


def _write_text(f: h5py.File, payload: Any) -> tuple[int, int]:
    """Append ``payload`` as JSON to the ``/text`` byte stream; returns (start, length)."""
    raw = np.frombuffer(json.dumps(payload, default=_json_default).encode(), np.uint8)
    ds = f["text"]
    start = ds.shape[0]
    ds.resize((start + raw.size,))
    ds[start:] = raw
    return start, raw.size


def _append_log(f: h5py.File, kind: str, payload: dict) -> None:
    # both datasets held open until the flush: a chunk that fails to be written (full disk)
    # then raises at the flush, not in a handle's deallocation, where h5py only prints it
    held = (f["text"], f["log"])
    start, length = _write_text(f, payload)
    _append_row(f, "log", (time.time(), kind.encode()[:16], start, length))
    f.flush()
    del held


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _write_extra(f: h5py.File, extra: dict[str, np.ndarray]) -> None:
    """Recording keys no field holds, one dataset each under ``/extra`` (strings as UTF-8,
    other dtypes h5py cannot hold as their ``.npy`` bytes; attribute ``npy_dtype`` names the
    original dtype)."""
    group = f.create_group("extra")
    for key, value in extra.items():
        arr = np.asarray(value)
        if arr.dtype.kind == "U":
            data = np.char.encode(arr, "utf-8").astype(object)
            ds = group.create_dataset(key, data=data, dtype=h5py.string_dtype())
        elif arr.dtype.kind in "biufcS":
            ds = group.create_dataset(key, data=arr)
        else:
            buf = io.BytesIO()
            np.save(buf, arr, allow_pickle=False)
            ds = group.create_dataset(key, data=np.frombuffer(buf.getvalue(), np.uint8))
            ds.attrs["npy_bytes"] = True
        ds.attrs["npy_dtype"] = arr.dtype.str


def _read_extra(f: h5py.File) -> dict[str, np.ndarray]:
    """The ``/extra`` datasets back as the arrays `_write_extra` was given."""
    out = {}
    for key, ds in (f["extra"].items() if "extra" in f else ()):
        dtype = np.dtype(ds.attrs["npy_dtype"])
        if ds.attrs.get("npy_bytes"):
            out[key] = np.load(io.BytesIO(ds[()].tobytes()), allow_pickle=False)
        elif dtype.kind == "U":
            out[key] = np.asarray(ds.asstr()[()], dtype=dtype)
        else:
            out[key] = np.asarray(ds[()], dtype=dtype)
    return out


def _valid_segments(f: h5py.File) -> np.ndarray:
    """Index rows whose samples are on disk (checksums are verified when data are read)."""
    seg = f["segments"][:]
    n = min(f[f"data/{k}"].shape[0] for k in ("force", "response", "monitor")
            if f"data/{k}" in f)
    return seg[seg["start"] + seg["length"] <= n]


def _json_at(text, start: int, length: int) -> Any:
    """JSON payload at ``text[start:start + length]`` (None when length is 0)."""
    return json.loads(np.asarray(text[start:start + length]).tobytes()) if length else None


def _read_status(f: h5py.File) -> tuple[str, str, str]:
    st = f["state"]
    return tuple(st[k][()].decode() for k in ("status", "reason", "updated_utc"))
