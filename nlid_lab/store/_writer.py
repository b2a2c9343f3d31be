"""Writing run files: `RunWriter` (one per run) and `LevelWriter` (one per level)."""

from __future__ import annotations

import contextlib
import json
import os
import time
from pathlib import Path
from typing import Iterator

import h5py
import numpy as np

from analysis.recordings import (EXCITATIONS, FORCE_HOLDS, KEYS as SENSOR_KEYS, MIXED,
                                 RESPONSE_KINDS, PeriodicLayout, SensorMap)

from ._common import (FORMAT, MONITORS_SCHEMA_VERSION, SCHEMA_VERSION, SOFTWARE, STATUSES,
                      StoreError, WriterLock, _append_log, _append_row, _channel_table, _crc,
                      _default_channels, _json_default, _open_swmr_write, _write_extra,
                      _write_text, utc_now)
from ._rebuild import _create, _repair
from ._space import BLOCK_OVERHEAD, DiskFullError, Reserve, is_disk_full, require


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
                     t: float | None = None, extra: dict | None = None,
                     amplitude: float | None = None, monitor: np.ndarray | None = None) -> int:
        """Append one random or swept-sine block; returns its sequence number. A swept-sine
        level's first block carries the level's sweep keys in ``extra``
        (`analysis.recordings.Sweep.keys`) and may carry its force ``amplitude``. A run
        with monitor channels takes their samples as ``monitor`` (n, n_monitors)."""
        amp = np.nan if amplitude is None else float(amplitude)
        return self._append(force, response, seq, t, np.nan, amp, extra, monitor)

    def append_step(self, freq: float, force: np.ndarray, response: np.ndarray,
                    amplitude: float | None = None, extra: dict | None = None,
                    seq: int | None = None, t: float | None = None,
                    monitor: np.ndarray | None = None) -> int:
        """Append one stepped-sine step (steady-state samples at ``freq``)."""
        if not np.isfinite(freq) or freq <= 0:
            raise StoreError(f"step frequency must be a positive number, got {freq}")
        amp = np.nan if amplitude is None else float(amplitude)
        return self._append(force, response, seq, t, float(freq), amp, extra, monitor)

    def stored_seqs(self) -> set[int]:
        """Sequence numbers of this level's stored blocks or steps."""
        seg = self._run._file["segments"][:]
        return set(seg["seq"][seg["level"] == self.index].tolist())

    def stored_force(self) -> Iterator[tuple[np.ndarray, float]]:
        """Force samples of each stored block/step of this level in ``seq`` order (read one
        at a time) with the step's force amplitude (NaN for random blocks): what a level
        summary is built from."""
        f = self._run._file
        seg = f["segments"][:]
        for s in np.sort(seg[seg["level"] == self.index], order="seq"):
            yield f["data/force"][s["start"]:s["start"] + s["length"]], float(s["amplitude"])

    def complete(self) -> None:
        """Mark this level as fully measured."""
        with self._run._writing(f"the end of level {self.index}"):
            ds = self._run._file["levels"]
            pos = int(np.nonzero(ds["index"] == self.index)[0][0])
            row = ds[pos]
            row["complete"] = 1
            ds[pos] = row
            self._run._file.flush()

    def _append(self, force, response, seq, t, freq, amp, extra, monitor=None) -> int:
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
        blocks = [("force", force), ("response", response)]
        n_mon = len(run.monitors)
        if n_mon or monitor is not None:
            monitor = np.ascontiguousarray(np.zeros((len(force), 0)) if monitor is None
                                           else monitor, dtype="<f8")
            if monitor.shape != (len(force), n_mon):
                raise StoreError(f"block monitor shape {monitor.shape}; the run has "
                                 f"{n_mon} monitor channel(s): expected ({len(force)}, "
                                 f"{n_mon})")
            if n_mon:
                blocks.append(("monitor", monitor))
        seq = self.next_seq if seq is None else int(seq)
        f = run._file
        nbytes = sum(b.nbytes for _, b in blocks) + BLOCK_OVERHEAD
        require(run.path, nbytes, f"block {seq} of level {self.index} of {run.path}")
        with run._writing(f"block {seq} of level {self.index}"):
            start = f["data/force"].shape[0]
            for name, block in blocks:
                f[f"data/{name}"].resize((start + len(block), block.shape[1]))
                f[f"data/{name}"][start:] = block
            f.flush()  # data on disk before the index row that makes them visible
            ex_start, ex_len = _write_text(f, extra) if extra is not None else (0, 0)
            crc = _crc(force, response, monitor if n_mon else None)
            _append_row(f, "segments", (self.index, seq, time.time() if t is None
                                        else float(t), start, len(force), freq, amp, crc,
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
        ``"random"``, ``"stepped-sine"`` or ``"swept-sine"``, or a settings dict whose
        ``"kind"`` is one of them
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
    force_hold : {"none", "linear"}
        How the recorded force samples acted (`analysis.recordings.Recording.force_hold`).
    layout : PeriodicLayout, optional
        Periodic (multisine) layout of random data; write one block per realization (its
        ``realizations`` is not stored: a level has as many as it has blocks).
    extra : dict of str to array, optional
        Recording keys no field holds (`Recording.extra`), stored under ``/extra``.
    sensors : SensorMap, optional
        Point and kind of each response channel, point of each force
        (`analysis.recordings.SensorMap`), stored as the ``sensors`` JSON attribute;
        ``response_kind`` is then its kind (``"mixed"`` when the channels differ).
    monitors : dict of str to str, optional
        Monitor channels (`analysis.recordings.Recording.monitors`): name -> unit, in column
        order of ``/data/monitor`` (the ``monitors`` JSON attribute); every block then
        carries their samples.
    planned_blocks : int, optional
        Blocks, steps or sweeps the campaign's plan stores over all its levels (the
        ``planned_blocks`` attribute, `Run.planned`); a resumed file keeps its own.
    mode : {"create", "overwrite", "resume"}
        ``create`` refuses an existing file; ``resume`` continues one (a crashed file is
        rebuilt first) after checking it matches fs, excitation, force_dofs and n_dof.
    """

    def __init__(self, path: str | os.PathLike, *, fs: float, excitation: str | dict,
                 force_dofs, n_dof: int, response_kind: str = "displacement",
                 channels: list[dict] | None = None, settings: dict | None = None,
                 model_toml: str | None = None, source: str = "sim",
                 force_hold: str = "none", layout: PeriodicLayout | None = None,
                 extra: dict[str, np.ndarray] | None = None, mode: str = "create",
                 sensors: SensorMap | None = None, monitors: dict[str, str] | None = None,
                 planned_blocks: int | None = None) -> None:
        self.path = Path(path)
        exc_settings = dict(excitation) if isinstance(excitation, dict) else {"kind": excitation}
        kind = exc_settings.get("kind")
        # h5py stores str, not its subclasses: vocabularies (StrEnum) become their values here
        self.excitation = str(kind) if kind is not None else None
        self.fs = float(fs)
        self.force_dofs = np.atleast_1d(np.asarray(force_dofs, dtype=int))
        self.n_dof = int(n_dof)
        response_kind = str(sensors.kind if sensors is not None else response_kind)
        self._check_args(response_kind if response_kind != MIXED or sensors is None
                         else sensors.response_kinds[0], force_hold, mode)
        attrs = {
            "format": FORMAT, "schema_version": SCHEMA_VERSION,
            "software": SOFTWARE, "created_utc": utc_now(),
            "source": source, "fs": self.fs, "excitation": self.excitation,
            "excitation_settings": json.dumps(exc_settings, default=_json_default),
            "settings": json.dumps(settings or {}, default=_json_default),
            "force_dofs": self.force_dofs, "n_dof": self.n_dof,
            "response_kind": response_kind, "model_toml": model_toml or "",
            "force_hold": force_hold,
        }
        if sensors is not None:
            attrs["sensors"] = json.dumps({k: list(getattr(sensors, k)) for k in SENSOR_KEYS})
        self.monitors = dict(monitors or {})
        self.dropped: tuple = ()   # damaged blocks a resume dropped (`LeftOut`)
        if self.monitors:
            attrs["monitors"] = json.dumps([[k, v] for k, v in self.monitors.items()])
            attrs["schema_version"] = MONITORS_SCHEMA_VERSION
        if planned_blocks is not None:
            attrs["planned_blocks"] = int(planned_blocks)
        if layout is not None:
            attrs.update(period=layout.period, transient_periods=layout.transient_periods,
                         periods=layout.periods)
        chans = channels or _default_channels(self.force_dofs, self.n_dof, response_kind,
                                              sensors)
        table = _channel_table(chans, self.force_dofs, self.n_dof)
        if mode == "create" and self.path.exists():
            raise StoreError(f"{self.path} already exists; resume it or choose a new name")
        self._reserve = Reserve(self.path)
        try:
            if mode == "resume" and self.path.exists():
                self._file = self._resume(attrs)
            else:
                _create(self.path, attrs, table,
                        (lambda f: _write_extra(f, extra)) if extra else None)
                self._file = _open_swmr_write(self.path)
        except BaseException:
            self._reserve.release()
            raise
        # every dataset held open while writing: a chunk cache is then written by the
        # file's flush, which raises on a failed write, never by a dataset handle's
        # deallocation, which h5py reports as "Exception ignored" and goes on
        self._held = [self._file[name] for name in _held_datasets(self._file)]
        self._lock = WriterLock(self.path)
        self.set_status("running")

    def _check_args(self, response_kind: str, force_hold: str, mode: str) -> None:
        for what, value, allowed in (("excitation kind", self.excitation, EXCITATIONS),
                                     ("response_kind", response_kind, RESPONSE_KINDS),
                                     ("force_hold", force_hold, FORCE_HOLDS),
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
        rebuilt = _repair(self.path, verify=True)
        f = _open_swmr_write(self.path)
        if json.loads(f.attrs.get("monitors", "[]")) != json.loads(attrs.get("monitors", "[]")):
            f.close()
            raise StoreError(f"cannot resume {self.path}: its monitor channels differ from "
                             "the ones given; use the same settings or a new file")
        for key in ("fs", "excitation", "n_dof", "force_dofs"):
            have = f.attrs[key]
            if not np.array_equal(have, attrs[key]):
                f.close()
                raise StoreError(f"cannot resume {self.path}: its {key} is {have!r}, not "
                                 f"{attrs[key]!r}; use the same settings or a new file")
        self._file = f
        self.log("resume", {"rebuilt_after_crash": bool(rebuilt),
                            "dropped": [b.to_json() for b in rebuilt.dropped]})
        self.dropped = rebuilt.dropped
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
            with self._writing(f"level {index}"):
                _append_row(self._file, "levels", (int(index), float(nominal), 0))
                self._file.flush()
        return LevelWriter(self, int(index))

    def count_loss(self, frames: int = 0, samples: int = 0, note: str = "",
                   level: int | None = None) -> None:
        """Add lost/dropped frames and samples to the run's counters (and log them)."""
        with self._writing("the loss counters"):
            counts = self._file["state/losses"]
            counts[...] = counts[...] + np.array([frames, samples])
        self.log("loss", {"frames": frames, "samples": samples, "note": note, "level": level})

    def set_status(self, status: str, reason: str = "") -> None:
        """Set the run status (one of `STATUSES`)."""
        if status not in STATUSES:
            raise StoreError(f"status {status!r} is not one of {', '.join(STATUSES)}")
        with self._writing("the run's status"):
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
        with self._writing(f"a {kind} event"):
            _append_log(self._file, kind, payload)

    @contextlib.contextmanager
    def _writing(self, what: str) -> Iterator[None]:
        """Turn a full disk during the writes of the ``with`` body into `DiskFullError`:
        the reserve is given back and the file flushed again, so that the blocks stored so
        far stay intact and the file can be marked and closed."""
        try:
            yield
        except (OSError, RuntimeError) as exc:
            if not is_disk_full(exc):
                raise
            if self._reserve.release():
                with contextlib.suppress(OSError, RuntimeError):
                    self._file.flush()
            raise DiskFullError(f"disk full while writing {what} to {self.path}") from None

    def close(self) -> None:
        """Close the file (flushing it) and give back its reserve and lock."""
        try:
            if self._file.id.valid:
                self._held.clear()
                try:
                    self._file.close()
                except (OSError, RuntimeError) as exc:  # no room for the last flush
                    if not (is_disk_full(exc) and self._reserve.release()):
                        raise
                    self._file.close()
        finally:
            self._reserve.release()
            self._lock.release()

    def __enter__(self) -> "RunWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if self._file.id.valid:
                if exc_type is KeyboardInterrupt:
                    self.set_status("interrupted", "interrupted by the user")
                elif exc_type is not None and issubclass(exc_type, DiskFullError):
                    self._reserve.release()     # room for the status and the close
                    self.set_status("interrupted", str(exc))
                elif exc_type is not None:
                    self.set_status("aborted", f"{exc_type.__name__}: {exc}")
                elif self.status == "running":
                    self.set_status("complete")
        finally:
            self.close()


def _held_datasets(f: h5py.File) -> list[str]:
    """Paths of every dataset of an open run file."""
    names: list[str] = []
    f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset)
                 else None)
    return names
