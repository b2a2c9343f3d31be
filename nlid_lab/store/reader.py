"""Reading run files (`open_run`, `Run`) and one-shot helpers for whole recordings."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from analysis.recordings import PeriodicLayout, Recording, SensorMap, StepTable, Sweep

from ._common import (FORMAT, StoreError, _append_log, _crc,
                      _json_at, _open, _open_swmr_write, _read_extra, _read_status, _valid_segments,
                      writer_left_open)
from .writer import RunWriter, _repair
from ._steptables import TABLES_SCHEMA_VERSION, is_table_run, read_table, save_tables, table_steps

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
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    left_open: bool = False
    """The file still carries its writer's "open for write" flag: the writer is running or
    was killed. Plain HDF5 tools cannot open it until `repair_run` rebuilds it."""

    @property
    def sensors(self) -> SensorMap | None:
        """The run's sensor map (the ``sensors`` attribute), None for the identity map."""
        text = self.meta.get("sensors")
        return SensorMap(**json.loads(text)) if text else None

    @property
    def monitor_units(self) -> dict[str, str]:
        """The run's monitor channels, name -> unit (``""``: none), in column order of
        ``/data/monitor``; empty for runs without monitors."""
        return dict(json.loads(self.meta.get("monitors") or "[]"))

    @property
    def force_hold(self) -> str:
        """The run's force hold; runs written before it was an attribute kept it in
        ``settings``."""
        return self.meta.get("force_hold") or (self.meta.get("settings") or {}).get(
            "force_hold") or "none"

    @property
    def incomplete(self) -> str:
        """Why the run is incomplete, in a few words; ``""`` for a complete run."""
        done = sum(lv.complete for lv in self.levels)
        levels = f"{done} of {len(self.levels)} level(s) complete, {len(self.segments)} blocks"
        if self.status == "running":
            how = ("its writer is still running or was killed" if self.left_open else
                   "its writer stopped without closing it")
            return f"incomplete ({how}; {levels})"
        if self.status != "complete":
            return f"incomplete ({self.status}: {self.reason or 'no reason given'}; {levels})"
        return ""

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

    def recording(self, level: int | None = None) -> Recording | StepTable:
        """The data of one level as a `Recording` (blocks concatenated in sequence order), or
        as a `StepTable` in a table run.

        Stepped-sine steps of different lengths are cut to the shortest, keeping each step's
        last samples (the most settled ones).
        """
        index = self.level_index(level)
        if is_table_run(self.meta):
            with _open(self.path, "r") as f:
                return read_table(f, index, self.meta, self.sensors)
        seg = np.sort(self.segments[self.segments["level"] == index], order="seq")
        lo, hi = seg["start"].min(), (seg["start"] + seg["length"]).max()
        units = self.monitor_units
        with _open(self.path, "r") as f:  # one read per dataset, sliced in memory
            force, response, text = f["data/force"][lo:hi], f["data/response"][lo:hi], f["text"]
            monitor = f["data/monitor"][lo:hi] if units else None
            extra = [_json_at(text, s["extra_start"], s["extra_length"]) for s in seg]
        parts = [(force[s - lo:s - lo + n], response[s - lo:s - lo + n],
                  None if monitor is None else monitor[s - lo:s - lo + n])
                 for s, n in zip(seg["start"], seg["length"])]
        keep = [i for i, p in enumerate(parts) if _crc(*p) == seg["crc"][i]]
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
        common = dict(fs=self.meta["fs"], excitation=self.meta["excitation"],
                      force_dofs=self.meta["force_dofs"],
                      response_kind=self.meta["response_kind"],
                      level=None if np.isnan(nominal) else nominal,
                      force_hold=self.force_hold, extra=dict(self.extra), meta=meta,
                      sensors=self.sensors, monitor_units={k: u for k, u in units.items() if u})

        def monitors(stack) -> dict[str, np.ndarray]:
            """Each monitor's samples, the blocks joined by ``stack``."""
            return {} if not units else {name: stack([p[2][:, j] for p in parts])
                                         for j, name in enumerate(units)}
        if self.meta["excitation"] == "swept-sine":
            keys = next((e for e in extra if e), None)
            if keys is None:
                raise StoreError(f"{self.path} level {index}: a swept-sine level without its "
                                 "sweep keys")
            meta["block_starts"] = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
            return Recording(force=np.concatenate([p[0] for p in parts]),
                             response=np.concatenate([p[1] for p in parts]),
                             sweep=Sweep.from_keys(keys), monitors=monitors(np.concatenate),
                             **common)
        if self.meta["excitation"] == "random":
            meta["block_starts"] = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
            meta["seq_gaps"] = int(np.count_nonzero(np.diff(seg["seq"]) != 1))
            layout = self._layout(parts)
            if layout is False:
                self.warnings.append(f"level {index}: periodic-random blocks of unequal "
                                     "length; the level is analysed as plain random data")
            return Recording(force=np.concatenate([p[0] for p in parts]),
                             response=np.concatenate([p[1] for p in parts]),
                             layout=layout or None, monitors=monitors(np.concatenate),
                             **common)
        n = min(len(p[0]) for p in parts)
        meta.update(step_amplitude=seg["amplitude"], step_extra=extra,
                    step_lengths=seg["length"])
        return Recording(force=np.stack([p[0][-n:] for p in parts]),
                         response=np.stack([p[1][-n:] for p in parts]), freqs=seg["freq"],
                         monitors=monitors(lambda cols: np.stack([c[-n:] for c in cols])),
                         **common)

    def _layout(self, parts: list) -> PeriodicLayout | None | bool:
        """Periodic layout of a level, one block per realization (the reverse path splits
        the record into periods); None for plain random runs, False when a block does not
        hold one whole realization. Runs written before the layout attributes kept it in
        ``excitation_settings``."""
        if "period" in self.meta:
            m = self.meta
            keys = (m["period"], m["transient_periods"], m["periods"])
        elif self.meta.get("excitation_settings", {}).get("periodic"):
            s = self.meta["excitation_settings"]
            keys = (s["block_size"], s["transient_periods"], s["periods"])
        else:
            return None
        period, transient, periods = (int(k) for k in keys)
        layout = PeriodicLayout(period, transient, periods, len(parts))
        if any(len(p[0]) != layout.realization_samples for p in parts):
            return False
        return layout

    def recordings(self) -> list[Recording | StepTable]:
        """One `Recording` per level holding data, in level order."""
        return [self.recording(lv.index) for lv in self.levels if lv.n_segments]


def open_run(path: str | os.PathLike) -> Run:
    """Read a run file's metadata and block index (works on crashed files too)."""
    path = Path(path)
    with _open(path, "r") as f:
        if f.attrs.get("format") != FORMAT:
            raise StoreError(f"{path} is an HDF5 file but not an nlid-lab run")
        version = int(f.attrs["schema_version"])
        if version > TABLES_SCHEMA_VERSION:
            raise StoreError(f"{path} has run schema {version}; this nlid-lab reads up to "
                             f"{TABLES_SCHEMA_VERSION}: upgrade nlid-lab")
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
        extra = _read_extra(f)
        steps = table_steps(f)      # a table run's levels count their steps
        levels = [Level(int(lv["index"]), float(lv["nominal"]), bool(lv["complete"]),
                        steps.get(int(lv["index"]),
                                  int(np.count_nonzero(segments["level"] == lv["index"]))),
                        int(segments["length"][segments["level"] == lv["index"]].sum()))
                  for lv in np.sort(f["levels"][:], order="index")]
    results = {e["name"]: e["value"] for e in log if e["kind"] == "result"}
    return Run(path, meta, channels, status, reason, updated,
               {"frames": int(lost[0]), "samples": int(lost[1])}, levels, segments, log,
               results, extra=extra, left_open=writer_left_open(path))


def repair_run(path: str | os.PathLike) -> bool:
    """Clear the "open for write" flag a killed writer left on ``path``, so that any HDF5
    tool opens it; returns False if there was nothing to repair.

    Every block is checked (index row flushed, checksum correct) and only those are kept, in a
    fresh file that atomically replaces the original. A file still open in a live writer is
    refused (`StoreError`).
    """
    return _repair(Path(path))


def check_result_target(path: str | os.PathLike) -> None:
    """Raise `StoreError` unless ``path`` is a run file a result can be saved into."""
    if Path(path).suffix.lower() not in (".h5", ".hdf5"):
        raise StoreError(f"{path}: results can only be stored in an HDF5 run file (.h5); "
                         "give a run written by nlid-lab")
    open_run(path)


def save_result(path: str | os.PathLike, name: str, result: dict) -> None:
    """Add an analysis result to an existing run file (crash-safely, in SWMR mode)."""
    path = Path(path)
    _repair(path)
    with _open_swmr_write(path) as f:
        _append_log(f, "result", {"name": name, "value": result})


def save_recording(path: str | os.PathLike,
                   rec: Recording | StepTable | Sequence[Recording | StepTable],
                   **meta: Any) -> None:
    """Write recordings as the levels of one complete run file (overwriting ``path``);
    stepped-sine tables as a table run (`nlid_lab.store._steptables`).

    Levels in separate files (one recording each) become one run: they must agree on what a
    run file holds once (sample rate, excitation, force DOFs, channels, response kind, force
    hold, periodic layout, extra keys, monitor channel names and units; each level keeps its
    own monitor samples). ``meta`` goes to `RunWriter` (``source``,
    ``model_toml``, ``settings``, ``channels``).
    """
    recs = [rec] if isinstance(rec, (Recording, StepTable)) else list(rec)
    tables = [isinstance(r, StepTable) for r in recs]
    if any(tables):
        if not all(tables):
            raise StoreError("stepped-sine tables and time records cannot be levels of one "
                             "run; import them as separate runs")
        save_tables(path, recs, **meta)
        return
    first = recs[0]
    for i, other in enumerate(recs[1:], 1):
        _check_same_run(first, other, i)
    excitation = meta.pop("excitation_settings", None) or {"kind": first.excitation}
    with RunWriter(path, fs=first.fs, excitation=excitation, force_dofs=first.force_dofs,
                   n_dof=first.n_dof, response_kind=first.response_kind, mode="overwrite",
                   force_hold=first.force_hold, layout=first.layout, extra=first.extra,
                   sensors=first.sensors, monitors={k: first.monitor_units.get(k, "")
                                                    for k in first.monitors},
                   **meta) as run:
        for index, r in enumerate(recs):
            lv = run.level(index, np.nan if r.level is None else r.level)
            mon = (np.stack(list(r.monitors.values()), axis=-1) if r.monitors
                   else np.zeros(r.force.shape[:-1] + (0,)))
            if r.excitation == "swept-sine":
                lv.append_block(r.force, r.response, extra=r.sweep.keys(), monitor=mon)
            elif r.excitation == "random":
                n = r.layout.realization_samples if r.layout else len(r.force)
                for i in range(0, len(r.force), n):
                    lv.append_block(r.force[i:i + n], r.response[i:i + n],
                                    monitor=mon[i:i + n])
            else:
                for freq, force, response, m in zip(r.freqs, r.force, r.response, mon):
                    lv.append_step(freq, force, response, amplitude=r.level, monitor=m)
            lv.complete()


def _check_same_run(a: Recording, b: Recording, index: int) -> None:
    """Raise `StoreError` naming the first run-wide property in which ``b`` differs."""
    same = {
        "fs": a.fs == b.fs, "excitation": a.excitation == b.excitation,
        "force_dofs": np.array_equal(a.force_dofs, b.force_dofs),
        "response channels": a.n_dof == b.n_dof, "response_kind": a.response_kind
        == b.response_kind, "force_hold": a.force_hold == b.force_hold,
        "periodic layout": a.layout == b.layout, "sensor map": a.sensors == b.sensors,
        "monitor channels (names and units)": list(a.monitors) == list(b.monitors)
        and a.monitor_units == b.monitor_units,
        "extra keys": a.extra.keys() == b.extra.keys() and all(
            np.array_equal(np.asarray(a.extra[k]), np.asarray(b.extra[k])) for k in a.extra),
    }
    for what, ok in same.items():
        if what.startswith("monitor") and not ok:
            raise StoreError(f"recording {index + 1} has monitor channels {list(b.monitors)} "
                             f"but the first {list(a.monitors)} (units {b.monitor_units} vs "
                             f"{a.monitor_units}); levels of one run share their monitor "
                             "channels: map the same monitor= in every file, or monitor=none")
        if not ok:
            raise StoreError(f"recording {index + 1} differs from the first in its {what}; "
                             "levels of one run share it (import them as separate runs)")
