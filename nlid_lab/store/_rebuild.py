"""Building a run file whole in a temporary file and renaming it into place: a new run's
header (`_create`), and a crashed or damaged run rebuilt from its intact content
(`_repair`)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from ._common import (_TABLES, CHUNK_ROWS, StoreError, _crc, _json_at, _open, in_use,
                      writer_left_open)
from ._integrity import LeftOut, LeftOutReason, Repaired
from ._space import DiskFullError, is_disk_full

#: root attributes a repair rebuilds when damaged: (free-form, or derivable from others)
REBUILT_ATTRS = ("settings", "excitation_settings")


def _create(path: Path, attrs: dict, channels: np.ndarray,
            fill: Callable[[h5py.File], None] | None = None) -> None:
    """Build a run file (header, empty tables, then ``fill``) in ``path.tmp``, rename it."""
    tmp = path.with_name(path.name + ".tmp")
    n_in, n_dof = len(attrs["force_dofs"]), int(attrs["n_dof"])
    try:
        with h5py.File(tmp, "w", libver="latest", locking="best-effort") as f:
            f.attrs.update(attrs)
            f.create_dataset("channels", data=channels)
            st = f.create_group("state")
            st.create_dataset("status", data=np.bytes_("running"), dtype="S16")
            st.create_dataset("reason", data=np.bytes_(""), dtype="S256")
            st.create_dataset("updated_utc", data=np.bytes_(attrs["created_utc"]), dtype="S32")
            st.create_dataset("losses", data=np.zeros(2, "<i8"))
            for name, dtype in _TABLES.items():
                f.create_dataset(name, shape=(0,), maxshape=(None,), chunks=(256,), dtype=dtype)
            f.create_dataset("text", shape=(0,), maxshape=(None,), chunks=(65536,), dtype="u1")
            n_mon = len(json.loads(attrs.get("monitors", "[]")))
            for name, width in (("force", n_in), ("response", n_dof), ("monitor", n_mon)):
                if width:
                    f.create_dataset(f"data/{name}", shape=(0, width), maxshape=(None, width),
                                     chunks=(CHUNK_ROWS, width), dtype="<f8")
            if fill:
                fill(f)
    except (OSError, RuntimeError) as exc:
        tmp.unlink(missing_ok=True)
        if is_disk_full(exc):
            raise DiskFullError(f"disk full while writing {path}; nothing was written: free "
                                "space or write to another disk") from None
        if isinstance(exc, RuntimeError):
            raise
        raise StoreError(f"cannot write {path}: {' '.join(str(exc).split())}") from None
    os.replace(tmp, path)


def _repair(path: Path, verify: bool = False) -> Repaired:
    """Rebuild a crashed run file (and with ``verify`` a damaged one) from its intact
    content; returns what was done (false when nothing had to be).

    The file is read (in SWMR mode when a killed writer left it flagged), every indexed,
    on-disk, checksum-correct segment and every readable log entry copied into a fresh file
    (damaged free-form attributes reset), which then replaces the original. ``verify`` checks
    every block of a cleanly closed file too (`RunWriter` resume: a corrupt block is dropped
    so that the campaign records it again). A file a live process still writes is refused.
    """
    if not path.exists():
        raise StoreError(f"run file {path} not found; check the path")
    left_open = writer_left_open(path)
    if not left_open and not verify:
        return Repaired(False, 0)
    if left_open and in_use(path):
        raise StoreError(f"{path} is open in another process (a campaign still writing it?); "
                         "let it finish or stop it first")
    with _open(path, "r") as old:
        for name in ("segments", "levels", "channels", "data/force", "data/response"):
            if name not in old:
                raise StoreError(f"{path} is damaged beyond repair: its /{name} is missing; "
                                 "restore the file from a copy or record the run again")
        seg, dropped = _intact_segments(old)
        log, text_n = _readable_log(old)
        attrs, reset = _readable_attrs(old)
        if not (left_open or dropped or reset or len(log) < old["log"].shape[0]):
            return Repaired(False, len(seg))
        levels = old["levels"][:]
        for b in dropped:                      # a level with a dropped block is not complete
            levels["complete"][levels["index"] == b.level] = 0
        monitor = "data/monitor" in old
        end = int((seg["start"] + seg["length"]).max()) if len(seg) else 0

        def copy(f: h5py.File) -> None:
            st = f["state"]
            for key in ("status", "reason", "updated_utc", "losses"):
                st[key][()] = old["state"][key][()]
            for name, rows in (("levels", levels), ("segments", seg), ("log", log)):
                f[name].resize((len(rows),))
                f[name][:] = rows
            if "extra" in old:
                old.copy("extra", f)
            if text_n:
                f["text"].resize((text_n,))
                f["text"][:] = old["text"][:text_n]
            for name in ("force", "response") + (("monitor",) if monitor else ()):
                src, dst = old[f"data/{name}"], f[f"data/{name}"]
                dst.resize((end, src.shape[1]))
                for i in range(0, end, 1 << 20):
                    dst[i:i + (1 << 20)] = src[i:min(end, i + (1 << 20))]
        _create(path, attrs, old["channels"][:], copy)
        return Repaired(True, len(seg), tuple(dropped), old["log"].shape[0] - len(log),
                        tuple(reset))


def _intact_segments(old: h5py.File) -> tuple[np.ndarray, list[LeftOut]]:
    """Segments whose samples are on disk, checksum holds and extra text parses (read a
    block at a time), and the others."""
    every = old["segments"][:]
    rows = min(old[f"data/{k}"].shape[0] for k in ("force", "response", "monitor")
               if f"data/{k}" in old)
    on_disk = every["start"] + every["length"] <= rows
    force, response = old["data/force"], old["data/response"]
    monitor = old["data/monitor"] if "data/monitor" in old else None
    text = old["text"] if "text" in old else np.zeros(0, np.uint8)
    dropped = [LeftOut(int(s["level"]), int(s["seq"]), LeftOutReason.NOT_ON_DISK)
               for s in every[~on_disk]]
    keep = []
    for s in every[on_disk]:
        a, n = int(s["start"]), int(s["length"])
        if _crc(force[a:a + n], response[a:a + n],
                None if monitor is None else monitor[a:a + n]) != s["crc"]:
            dropped.append(LeftOut(int(s["level"]), int(s["seq"]), LeftOutReason.CHECKSUM))
            continue
        try:
            _json_at(text, s["extra_start"], s["extra_length"])
        except ValueError:
            dropped.append(LeftOut(int(s["level"]), int(s["seq"]),
                                   LeftOutReason.TEXT_DAMAGED))
            continue
        keep.append(s)
    return np.array(keep, dtype=every.dtype), dropped


def _readable_log(old: h5py.File) -> tuple[np.ndarray, int]:
    """Log rows whose text is on disk and parses as a JSON object, and the text's length."""
    if "log" not in old or "text" not in old:
        return np.zeros(0, _TABLES["log"]), 0
    text = old["text"][:]
    rows = old["log"][:]
    ok = []
    for row in rows[rows["start"] + rows["length"] <= text.size]:
        try:
            ok.append(isinstance(_json_at(text, row["start"], row["length"]), dict))
        except ValueError:
            ok.append(False)
    return rows[rows["start"] + rows["length"] <= text.size][np.array(ok, bool)], text.size


def _readable_attrs(old: h5py.File) -> tuple[dict, list[str]]:
    """Root attributes, the damaged ones of `REBUILT_ATTRS` reset (``settings`` to ``{}``,
    ``excitation_settings`` to its kind); another damaged one cannot be rebuilt."""
    attrs, reset = {}, []
    for key in old.attrs:
        try:
            value = old.attrs[key]
            if key in REBUILT_ATTRS:
                json.loads(str(value).encode())
            attrs[key] = value
        except (UnicodeDecodeError, ValueError, OSError):
            if key not in REBUILT_ATTRS:
                raise StoreError(f"{old.filename} is damaged beyond repair: its attribute "
                                 f"'{key}' is unreadable; restore the file from a copy") from None
            reset.append(key)
    for key in reset:
        attrs[key] = json.dumps({"kind": attrs.get("excitation")} if key ==
                                "excitation_settings" else {})
    return attrs, reset
