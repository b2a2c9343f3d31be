"""HDF5 run store: one file per run, schema in docs/run-format.md (the only h5py importer).

Crash safety: after its header is built (in a temporary file renamed into place) a run file
is only ever modified in HDF5 SWMR mode, and each block is written data first, flushed, then
indexed in ``/segments`` and flushed again. SWMR orders metadata writes so that the file on
disk is always readable, hence a writer killed at any moment (SIGKILL included) leaves a file
holding every block whose index row was flushed. Such a file still carries the "open by a
SWMR writer" superblock flag: `open_run` reads it in SWMR mode, and ``mode="resume"`` rebuilds
it into a clean file (temporary file + atomic rename) before appending again.
"""

from __future__ import annotations

import json
import os
import time
import zlib
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np

from analysis.errors import InputError
from analysis.recording import EXCITATIONS, RESPONSE_KINDS, Recording

from . import __version__

SCHEMA_VERSION = 1
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


def _crc(force: np.ndarray, response: np.ndarray) -> int:
    return zlib.crc32(response.tobytes(), zlib.crc32(force.tobytes()))


def _default_channels(force_dofs: np.ndarray, n_dof: int, response_kind: str) -> list[dict]:
    chans = [{"name": f"force{i}", "unit": "N", "dof": int(d), "kind": "force"}
             for i, d in enumerate(force_dofs)]
    chans += [{"name": f"{response_kind[0]}{j}", "unit": RESPONSE_UNITS[response_kind],
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


class LevelWriter:
    """Appends blocks (random) or steps (stepped sine) of one level of a run."""

    def __init__(self, run: "RunWriter", index: int) -> None:
        self._run = run
        self.index = index
        seg = run._file["segments"][:]
        mine = seg[seg["level"] == index]
        self.n_segments = len(mine)
        self.n_samples = int(mine["length"].sum())
        self.next_seq = int(mine["seq"].max()) + 1 if len(mine) else 0

    def append_block(self, force: np.ndarray, response: np.ndarray, seq: int | None = None,
                     t: float | None = None) -> int:
        """Append one random-excitation block; returns its sequence number."""
        return self._append(force, response, seq, t, np.nan, np.nan, None)

    def append_step(self, freq: float, force: np.ndarray, response: np.ndarray,
                    amplitude: float | None = None, extra: dict | None = None,
                    seq: int | None = None, t: float | None = None) -> int:
        """Append one stepped-sine step (steady-state samples at ``freq``)."""
        if not np.isfinite(freq) or freq <= 0:
            raise StoreError(f"step frequency must be a positive number, got {freq}")
        amp = np.nan if amplitude is None else float(amplitude)
        return self._append(force, response, seq, t, float(freq), amp, extra)

    def complete(self) -> None:
        """Mark this level as fully measured."""
        ds = self._run._file["levels"]
        pos = int(np.nonzero(ds["index"] == self.index)[0][0])
        row = ds[pos]
        row["complete"] = 1
        ds[pos] = row
        self._run._file.flush()

    def _append(self, force, response, seq, t, freq, amp, extra) -> int:
        run = self._run
        force = np.ascontiguousarray(force, dtype="<f8")
        response = np.ascontiguousarray(response, dtype="<f8")
        n_in, n_dof = run.force_dofs.size, run.n_dof
        force = force[:, None] if force.ndim == 1 and n_in == 1 else force
        response = response[:, None] if response.ndim == 1 and n_dof == 1 else response
        if force.ndim != 2 or force.shape[1] != n_in or response.shape != (len(force), n_dof):
            raise StoreError(f"block shapes force {force.shape}, response {response.shape}; "
                             f"expected (n, {n_in}) and (n, {n_dof})")
        if len(force) == 0:
            raise StoreError("empty block; append at least one sample")
        seq = self.next_seq if seq is None else int(seq)
        f = run._file
        start = f["data/force"].shape[0]
        for name, block in (("force", force), ("response", response)):
            f[f"data/{name}"].resize((start + len(block), block.shape[1]))
            f[f"data/{name}"][start:] = block
        f.flush()  # data on disk before the index row that makes them visible
        ex_start, ex_len = _write_text(f, extra) if extra is not None else (0, 0)
        _append_row(f, "segments", (self.index, seq, time.time() if t is None else float(t),
                                    start, len(force), freq, amp, _crc(force, response),
                                    ex_start, ex_len))
        f.flush()
        self.n_segments += 1
        self.n_samples += len(force)
        self.next_seq = seq + 1
        return seq


class RunWriter:
    """Writes one run file; a context manager.

    Parameters
    ----------
    path : path-like
        The run file (``.h5``).
    fs : float
        Sample rate, Hz.
    excitation : str or dict
        ``"random"`` or ``"stepped-sine"``, or a settings dict whose ``"kind"`` is one of them
        (stored whole as the ``excitation_settings`` JSON attribute).
    force_dofs : sequence of int
        DOF (0-based) each force channel acts on.
    n_dof : int
        Number of response DOFs (one response channel each).
    response_kind : {"displacement", "velocity", "acceleration"}
    channels : list of dict, optional
        ``{"name", "unit", "dof", "kind": "force"|"response", "sensitivity"}``; defaults
        derived from ``force_dofs`` and ``n_dof``. Data are stored in physical units.
    settings : dict, optional
        Free-form run settings (campaign, backend), stored as JSON.
    model_toml : str, optional
        Text of the model file when the run is simulated.
    source : str
        Where the data come from (``"sim"``, ``"serial"``, ``"can"``, ``"import"``...).
    mode : {"create", "overwrite", "resume"}
        ``create`` refuses an existing file; ``resume`` continues one (a crashed file is
        rebuilt first) after checking it matches fs, excitation, force_dofs and n_dof.
    """

    def __init__(self, path: str | os.PathLike, *, fs: float, excitation: str | dict,
                 force_dofs, n_dof: int, response_kind: str = "displacement",
                 channels: list[dict] | None = None, settings: dict | None = None,
                 model_toml: str | None = None, source: str = "sim",
                 mode: str = "create") -> None:
        self.path = Path(path)
        exc_settings = dict(excitation) if isinstance(excitation, dict) else {"kind": excitation}
        self.excitation = exc_settings.get("kind")
        self.fs = float(fs)
        self.force_dofs = np.atleast_1d(np.asarray(force_dofs, dtype=int))
        self.n_dof = int(n_dof)
        self._check_args(response_kind, mode)
        attrs = {
            "format": FORMAT, "schema_version": SCHEMA_VERSION,
            "software": f"nlid-lab {__version__}", "created_utc": utc_now(),
            "source": source, "fs": self.fs, "excitation": self.excitation,
            "excitation_settings": json.dumps(exc_settings, default=_json_default),
            "settings": json.dumps(settings or {}, default=_json_default),
            "force_dofs": self.force_dofs, "n_dof": self.n_dof,
            "response_kind": response_kind, "model_toml": model_toml or "",
        }
        chans = channels or _default_channels(self.force_dofs, self.n_dof, response_kind)
        table = _channel_table(chans, self.force_dofs, self.n_dof)
        if mode == "resume" and self.path.exists():
            self._file = self._resume(attrs)
        else:
            if mode == "create" and self.path.exists():
                raise StoreError(f"{self.path} already exists; resume it or choose a new name")
            _create(self.path, attrs, table)
            self._file = _open(self.path, "r+")
            self._file.swmr_mode = True
        self.set_status("running")

    def _check_args(self, response_kind: str, mode: str) -> None:
        for what, value, allowed in (("excitation kind", self.excitation, EXCITATIONS),
                                     ("response_kind", response_kind, RESPONSE_KINDS),
                                     ("mode", mode, ("create", "overwrite", "resume"))):
            if value not in allowed:
                raise StoreError(f"{what} {value!r} is not one of {', '.join(allowed)}")
        if not np.isfinite(self.fs) or self.fs <= 0 or self.n_dof < 1:
            raise StoreError("fs must be > 0 and n_dof >= 1")
        if self.force_dofs.size == 0 or self.force_dofs.min() < 0 \
                or self.force_dofs.max() >= self.n_dof:
            raise StoreError(f"force_dofs {self.force_dofs.tolist()} must be 0-based DOFs "
                             f"below n_dof={self.n_dof}")

    def _resume(self, attrs: dict) -> h5py.File:
        rebuilt = _repair(self.path)
        f = _open(self.path, "r+")
        for key in ("fs", "excitation", "n_dof", "force_dofs"):
            have = f.attrs[key]
            if not np.array_equal(have, attrs[key]):
                f.close()
                raise StoreError(f"cannot resume {self.path}: its {key} is {have!r}, not "
                                 f"{attrs[key]!r}; use the same settings or a new file")
        f.swmr_mode = True
        self._file = f
        self.log("resume", {"rebuilt_after_crash": rebuilt})
        return f

    # --- public API ------------------------------------------------------------------------
    def level(self, index: int, nominal: float) -> LevelWriter:
        """Writer for level ``index`` (created, or continued when resuming)."""
        levels = self._file["levels"][:]
        hit = levels[levels["index"] == index]
        if len(hit):
            if not np.isclose(hit["nominal"][0], nominal, equal_nan=True):
                raise StoreError(f"level {index} exists with nominal {hit['nominal'][0]}, "
                                 f"not {nominal}")
        else:
            _append_row(self._file, "levels", (int(index), float(nominal), 0))
            self._file.flush()
        return LevelWriter(self, int(index))

    def count_loss(self, frames: int = 0, samples: int = 0, note: str = "",
                   level: int | None = None) -> None:
        """Add lost/dropped frames and samples to the run's counters (and log them)."""
        counts = self._file["state/losses"]
        counts[...] = counts[...] + np.array([frames, samples])
        self.log("loss", {"frames": frames, "samples": samples, "note": note, "level": level})

    def set_status(self, status: str, reason: str = "") -> None:
        """Set the run status (one of `STATUSES`)."""
        if status not in STATUSES:
            raise StoreError(f"status {status!r} is not one of {', '.join(STATUSES)}")
        state = self._file["state"]
        state["status"][()] = status.encode()
        state["reason"][()] = reason.encode()[:256]
        state["updated_utc"][()] = utc_now().encode()
        self.status = status
        self.log("status", {"status": status, "reason": reason})

    def save_result(self, name: str, result: dict) -> None:
        """Store an analysis result (JSON-able dict) under ``name``; later saves win."""
        self.log("result", {"name": name, "value": result})

    def log(self, kind: str, payload: dict) -> None:
        """Append an event to the run's log."""
        _append_log(self._file, kind, payload)

    def close(self) -> None:
        if self._file.id.valid:
            self._file.close()

    def __enter__(self) -> "RunWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self._file.id.valid:
            if exc_type is KeyboardInterrupt:
                self.set_status("interrupted", "interrupted by the user")
            elif exc_type is not None:
                self.set_status("aborted", f"{exc_type.__name__}: {exc}")
            elif self.status == "running":
                self.set_status("complete")
        self.close()



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
    start, length = _write_text(f, payload)
    _append_row(f, "log", (time.time(), kind.encode()[:16], start, length))
    f.flush()


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


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
            for name, width in (("force", n_in), ("response", n_dof)):
                f.create_dataset(f"data/{name}", shape=(0, width), maxshape=(None, width),
                                 chunks=(CHUNK_ROWS, width), dtype="<f8")
            if fill:
                fill(f)
    except OSError as exc:
        raise StoreError(f"cannot write {path}: {' '.join(str(exc).split())}") from None
    os.replace(tmp, path)


def _repair(path: Path) -> bool:
    """Make a crashed run file writable again; returns True if it had to be rebuilt.

    The file is read in SWMR mode, its valid content (every indexed, checksum-correct segment
    and complete log entry) copied into a fresh file, which then replaces the original.
    """
    try:
        h5py.File(path, "r+", libver="latest", locking="best-effort").close()
        return False
    except OSError as exc:
        if "already open for write" not in str(exc):
            raise StoreError(f"cannot resume {path}: {' '.join(str(exc).split())}") from None
    with _open(path, "r") as old:
        seg_ok = _valid_segments(old)
        end = int((seg_ok["start"] + seg_ok["length"]).max()) if len(seg_ok) else 0
        log = old["log"][:]
        text_n = old["text"].shape[0]
        log = log[log["start"] + log["length"] <= text_n]

        def copy(f: h5py.File) -> None:
            st = f["state"]
            for key in ("status", "reason", "updated_utc", "losses"):
                st[key][()] = old["state"][key][()]
            for name, rows in (("levels", old["levels"][:]), ("segments", seg_ok), ("log", log)):
                f[name].resize((len(rows),))
                f[name][:] = rows
            f["text"].resize((text_n,))
            f["text"][:] = old["text"][:text_n]
            for name in ("force", "response"):
                src, dst = old[f"data/{name}"], f[f"data/{name}"]
                dst.resize((end, src.shape[1]))
                for i in range(0, end, 1 << 20):
                    dst[i:i + (1 << 20)] = src[i:min(end, i + (1 << 20))]
        _create(path, dict(old.attrs), old["channels"][:], copy)
    return True


def _valid_segments(f: h5py.File) -> np.ndarray:
    """Index rows whose samples are on disk (checksums are verified when data are read)."""
    seg = f["segments"][:]
    n = min(f["data/force"].shape[0], f["data/response"].shape[0])
    return seg[seg["start"] + seg["length"] <= n]


def _json_at(text, start: int, length: int) -> Any:
    """JSON payload at ``text[start:start + length]`` (None when length is 0)."""
    return json.loads(np.asarray(text[start:start + length]).tobytes()) if length else None


def _read_status(f: h5py.File) -> tuple[str, str, str]:
    st = f["state"]
    return tuple(st[k][()].decode() for k in ("status", "reason", "updated_utc"))


# --- read side -------------------------------------------------------------------------------
@dataclass
class Level:
    """One level of a run as stored."""

    index: int
    nominal: float
    complete: bool
    n_segments: int
    n_samples: int


@dataclass
class Run:
    """A run file's metadata and index; data are read on demand by `recording`.

    ``status`` is as last written: ``"running"`` in a file no process writes any more means
    the writer was killed; every indexed block is still readable.
    """

    path: Path
    meta: dict[str, Any]
    channels: list[dict[str, Any]]
    status: str
    reason: str
    updated_utc: str
    losses: dict[str, int]
    levels: list[Level]
    segments: np.ndarray
    log: list[dict[str, Any]]
    results: dict[str, Any]
    warnings: list[str] = field(default_factory=list)

    def level_index(self, level: int | None) -> int:
        """Resolve ``level`` (None: the only level with data) to a stored level index."""
        with_data = [lv.index for lv in self.levels if lv.n_segments]
        if level is None:
            if len(with_data) != 1:
                raise StoreError(f"{self.path} holds levels {with_data}; choose one")
            return with_data[0]
        if level not in with_data:
            raise StoreError(f"{self.path} has no data for level {level}; levels with data: "
                             f"{with_data}")
        return level

    def recording(self, level: int | None = None) -> Recording:
        """The data of one level as a `Recording` (blocks concatenated in sequence order).

        Stepped-sine steps of different lengths are cut to the shortest, keeping each step's
        last samples (the most settled ones).
        """
        index = self.level_index(level)
        seg = np.sort(self.segments[self.segments["level"] == index], order="seq")
        lo, hi = seg["start"].min(), (seg["start"] + seg["length"]).max()
        with _open(self.path, "r") as f:  # one read per dataset, sliced in memory
            force, response, text = f["data/force"][lo:hi], f["data/response"][lo:hi], f["text"]
            extra = [_json_at(text, s["extra_start"], s["extra_length"]) for s in seg]
        parts = [(force[s - lo:s - lo + n], response[s - lo:s - lo + n])
                 for s, n in zip(seg["start"], seg["length"])]
        keep = [i for i, (fo, re) in enumerate(parts) if _crc(fo, re) == seg["crc"][i]]
        if len(keep) < len(seg):
            self.warnings.append(f"level {index}: {len(seg) - len(keep)} block(s) failed their "
                                 "checksum and were skipped")
        seg, parts, extra = seg[keep], [parts[i] for i in keep], [extra[i] for i in keep]
        if not parts:
            raise StoreError(f"{self.path} level {index}: no intact block")
        nominal = next(lv.nominal for lv in self.levels if lv.index == index)
        meta = {"run": str(self.path), "level_index": index, "source": self.meta.get("source"),
                "status": self.status, "seq": seg["seq"], "t": seg["t"],
                "channels": self.channels, "excitation_settings":
                self.meta.get("excitation_settings", {}), "settings": self.meta.get("settings")}
        hold = (self.meta.get("settings") or {}).get("force_hold")
        if hold:
            meta["force_hold"] = hold
        common = dict(fs=self.meta["fs"], excitation=self.meta["excitation"],
                      force_dofs=self.meta["force_dofs"],
                      response_kind=self.meta["response_kind"],
                      level=None if np.isnan(nominal) else nominal)
        if self.meta["excitation"] == "random":
            meta["block_starts"] = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
            meta["seq_gaps"] = int(np.count_nonzero(np.diff(seg["seq"]) != 1))
            return Recording(force=np.concatenate([p[0] for p in parts]),
                             response=np.concatenate([p[1] for p in parts]), meta=meta,
                             **common)
        n = min(len(p[0]) for p in parts)
        meta.update(step_amplitude=seg["amplitude"], step_extra=extra,
                    step_lengths=seg["length"])
        return Recording(force=np.stack([p[0][-n:] for p in parts]),
                         response=np.stack([p[1][-n:] for p in parts]), freqs=seg["freq"],
                         meta=meta, **common)

    def recordings(self) -> list[Recording]:
        """One `Recording` per level holding data, in level order."""
        return [self.recording(lv.index) for lv in self.levels if lv.n_segments]


def open_run(path: str | os.PathLike) -> Run:
    """Read a run file's metadata and block index (works on crashed files too)."""
    path = Path(path)
    with _open(path, "r") as f:
        if f.attrs.get("format") != FORMAT:
            raise StoreError(f"{path} is an HDF5 file but not an nlid-lab run")
        version = int(f.attrs["schema_version"])
        if version > SCHEMA_VERSION:
            raise StoreError(f"{path} has run schema {version}; this nlid-lab reads up to "
                             f"{SCHEMA_VERSION}: upgrade nlid-lab")
        meta = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f.attrs.items()}
        for key in ("excitation_settings", "settings"):
            meta[key] = json.loads(meta[key])
        meta["force_dofs"] = np.asarray(meta["force_dofs"], dtype=int)
        channels = [{"name": c["name"].decode(), "unit": c["unit"].decode(),
                     "dof": int(c["dof"]), "sensitivity": float(c["sensitivity"]),
                     "kind": c["kind"].decode()} for c in f["channels"][:]]
        status, reason, updated = _read_status(f)
        lost = f["state/losses"][:]
        segments = _valid_segments(f)
        text = f["text"][:]
        log = [{"t": float(row["t"]), "kind": row["kind"].decode(),
                **_json_at(text, row["start"], row["length"])}
               for row in f["log"][:] if row["start"] + row["length"] <= text.size]
        levels = [Level(int(lv["index"]), float(lv["nominal"]), bool(lv["complete"]),
                        int(np.count_nonzero(segments["level"] == lv["index"])),
                        int(segments["length"][segments["level"] == lv["index"]].sum()))
                  for lv in np.sort(f["levels"][:], order="index")]
    results = {e["name"]: e["value"] for e in log if e["kind"] == "result"}
    return Run(path, meta, channels, status, reason, updated,
               {"frames": int(lost[0]), "samples": int(lost[1])}, levels, segments, log,
               results)


def save_result(path: str | os.PathLike, name: str, result: dict) -> None:
    """Add an analysis result to an existing run file (crash-safely, in SWMR mode)."""
    path = Path(path)
    _repair(path)
    with _open(path, "r+") as f:
        f.swmr_mode = True
        _append_log(f, "result", {"name": name, "value": result})


def save_recording(path: str | os.PathLike, rec: Recording, **meta: Any) -> None:
    """Write one `Recording` as a complete single-level run file (overwriting ``path``).

    ``meta`` goes to `RunWriter` (``source``, ``model_toml``, ``settings``, ``channels``).
    """
    excitation = meta.pop("excitation_settings", None) or {"kind": rec.excitation}
    with RunWriter(path, fs=rec.fs, excitation=excitation, force_dofs=rec.force_dofs,
                   n_dof=rec.n_dof, response_kind=rec.response_kind, mode="overwrite",
                   **meta) as run:
        lv = run.level(0, np.nan if rec.level is None else rec.level)
        if rec.excitation == "random":
            lv.append_block(rec.force, rec.response)
        else:
            for freq, force, response in zip(rec.freqs, rec.force, rec.response):
                lv.append_step(freq, force, response, amplitude=rec.level)
        lv.complete()


def load_recordings(path: str | os.PathLike) -> list[Recording]:
    """Recordings of any supported file: run ``.h5`` (one per level), ``.npz`` or ``.csv``."""
    from . import recordings_io

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".h5", ".hdf5"):
        return open_run(path).recordings()
    if suffix == ".npz":
        return [recordings_io.read_npz(path)]
    if suffix == ".csv":
        return [recordings_io.read_csv(path)]
    raise StoreError(f"{path}: unknown recording type '{suffix}'; use .h5, .npz or .csv")
