"""Reading run files (`open_run`, `Run`) and one-shot helpers for whole recordings."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from analysis.recordings import (Control, Excitation, PeriodicLayout, Recording, SensorMap,
                                 StepTable, Sweep)

from ._common import (FORMAT, StoreError, _append_log, _crc,
                      _json_at, _json_default, _open, _open_swmr_write, _read_extra,
                      _read_status, _valid_segments, writer_left_open)
from ._integrity import (Damage, LeftOut, LeftOutReason, Repaired, RunCheck, json_text,
                         planned_blocks)
from ._rebuild import REBUILT_ATTRS, _repair
from ._space import BLOCK_OVERHEAD, DiskFullError, is_disk_full, require
from ._verified import VerifiedLevel, identity, keep, take
from ._steptables import TABLES_SCHEMA_VERSION, is_table_run, read_table, save_tables, table_steps
from ._writer import RunWriter

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
    left_out: list[LeftOut] = field(default_factory=list)
    """Blocks left out so far: samples not on disk (found when opening), failing their
    checksum (found by `recording`, or by `check` for the whole run)."""
    notes: list[str] = field(default_factory=list)
    """Facts about the file readers say (blocks naming a level ``/levels`` lacks)."""
    _checked: set[int] = field(default_factory=set, repr=False)

    @property
    def sensors(self) -> SensorMap | None:
        """The run's sensor map (the ``sensors`` attribute), None for the identity map."""
        text = self.meta.get("sensors")
        return SensorMap(**json.loads(text)) if text else None

    @property
    def model_toml(self) -> str:
        """The model stored with the run (a simulated run's reference system) as TOML text;
        ``""`` when the run stores none."""
        return self.meta.get("model_toml") or ""

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
    def planned(self) -> int | None:
        """Blocks, steps or sweeps the campaign planned (None when the run does not say)."""
        return planned_blocks(self.meta.get("planned_blocks"),
                              self.meta.get("excitation_settings") or {})

    @property
    def incomplete(self) -> str:
        """Why the run is incomplete, after "run is" (``incomplete: 3 of 8 blocks; ...``);
        ``""`` for a complete run."""
        stored, planned = len(self.segments), self.planned
        count = f"{stored} of {planned} blocks" if planned else f"{stored} blocks"
        done = sum(lv.complete for lv in self.levels)
        levels = f"{done} of {len(self.levels)} level(s) complete"
        if self.status == "running":
            how = ("its writer is still running or was killed" if self.left_open else
                   "its writer stopped without closing it")
            return f"incomplete: {count} ({how}; {levels})"
        if self.status != "complete":
            return (f"incomplete: {count} ({self.status}: {self.reason or 'no reason given'};"
                    f" {levels})")
        return ""

    def check(self) -> RunCheck:
        """Verify every block's checksum (reading each level once) and say what readers
        leave out and how much of its plan the run holds. The intact blocks read are kept
        for the `recording` that follows, of this `Run` or of another opening of the same,
        unchanged file (`nlid_lab.store._verified`): the samples are read once."""
        for lv in self.levels:
            if lv.n_segments and lv.index not in self._checked:
                if is_table_run(self.meta):     # a damaged table raises, naming the fix
                    self.recording(lv.index)
                    self._checked.add(lv.index)
                else:                           # kept for the read that follows: one pass
                    keep(identity(self.path), lv.index, self._verified(lv.index))
        return RunCheck(str(self.path), self.status,
                        len(self.segments) - sum(b.reason is LeftOutReason.CHECKSUM
                                                 for b in self.left_out),
                        self.planned, self.incomplete,
                        tuple(sorted(self.left_out, key=lambda b: (b.level, b.seq))),
                        tuple(self.notes))

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
        as a `StepTable` in a table run (its checksum verified).

        Stepped-sine steps of different lengths are cut to the shortest, keeping each step's
        last samples (the most settled ones).
        """
        index = self.level_index(level)
        if is_table_run(self.meta):
            with _open(self.path, "r") as f:
                return read_table(f, index, self.meta, self.sensors)
        level = take(identity(self.path), index) or self._verified(index)
        self._note(index, level.bad)
        seg, parts, extra = level.segments, level.parts, level.extra
        units = self.monitor_units
        if not parts:
            raise StoreError(f"{self.path} level {index}: no intact block (every block failed "
                             "its checksum)")
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
        if self.meta["excitation"] == Excitation.SWEPT_SINE:
            keys = next((e for e in extra if e), None)
            if keys is None:
                raise StoreError(f"{self.path} level {index}: a swept-sine level without its "
                                 "sweep keys")
            meta["block_starts"] = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
            return Recording(force=np.concatenate([p[0] for p in parts]),
                             response=np.concatenate([p[1] for p in parts]),
                             sweep=Sweep.from_keys(keys), monitors=monitors(np.concatenate),
                             **common)
        if self.meta["excitation"] == Excitation.RANDOM:
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
        held = self.meta.get("excitation_settings", {})   # response-controlled campaigns
        return Recording(force=np.stack([p[0][-n:] for p in parts]),
                         response=np.stack([p[1][-n:] for p in parts]), freqs=seg["freq"],
                         monitors=monitors(lambda cols: np.stack([c[-n:] for c in cols])),
                         control=Control(held.get("control") or Control.FORCE),
                         control_dof=held.get("control_dof"), **common)

    def _verified(self, index: int) -> VerifiedLevel:
        """Level ``index`` read and verified: the segments in ``seq`` order whose checksum
        holds, their samples (force, response, monitor) and extra JSON, and the blocks left
        out (noted in ``left_out`` and ``warnings``, once per level)."""
        seg = np.sort(self.segments[self.segments["level"] == index], order="seq")
        lo, hi = seg["start"].min(), (seg["start"] + seg["length"]).max()
        try:
            with _open(self.path, "r") as f:  # one read per dataset, sliced in memory
                force, response = f["data/force"][lo:hi], f["data/response"][lo:hi]
                monitor = f["data/monitor"][lo:hi] if self.monitor_units else None
                extra = [_extra_json(f["text"], s) for s in seg]
        except (OSError, RuntimeError) as exc:   # HDF5's own structures around the samples
            what = " ".join(str(exc).split())[:120]
            raise DamagedRunError(f"{self.path} is damaged: level {index}'s samples cannot "
                                  f"be read ({type(exc).__name__}: {what}); "
                                  + UNREPAIRABLE.format(path=self.path)) from None
        parts = [(force[s - lo:s - lo + n], response[s - lo:s - lo + n],
                  None if monitor is None else monitor[s - lo:s - lo + n])
                 for s, n in zip(seg["start"], seg["length"])]
        why = [LeftOutReason.CHECKSUM if _crc(*p) != seg["crc"][i] else
               LeftOutReason.TEXT_DAMAGED if extra[i] is Damage else None
               for i, p in enumerate(parts)]
        keep_ = [i for i, w in enumerate(why) if w is None]
        bad = tuple(LeftOut(index, int(seg["seq"][i]), w) for i, w in enumerate(why) if w)
        self._note(index, bad)
        return VerifiedLevel(seg[keep_], [parts[i] for i in keep_], [extra[i] for i in keep_],
                             bad)

    def _note(self, index: int, bad: tuple[LeftOut, ...]) -> None:
        """Note level ``index``'s blocks left out (once per level)."""
        if bad and index not in self._checked:
            self.left_out += bad
            self.warnings += [f"level {index}: block {b.seq} {b.reason}; left out"
                              for b in bad]
        self._checked.add(index)

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


def _extra_json(text, s) -> Any:
    """A segment's extra JSON (None: none), `Damage` (the class) when its text is
    damaged."""
    try:
        return _json_at(text, s["extra_start"], s["extra_length"])
    except ValueError:
        return Damage


class DamagedRunError(StoreError):
    """A run file's structure or metadata is damaged (a table missing, text or JSON that
    does not parse): named with the fix, never an internal error."""


REPAIRABLE = "`nlid-lab repair {path}` rebuilds it without the damaged part, keeping every " \
    "intact block"
UNREPAIRABLE = "no tool can recover its blocks from it: restore the file from a copy or " \
    "record the run again"


def _table(f, name: str):
    """Dataset ``name`` of a run file; `Damage` when it is missing."""
    if name not in f:
        raise Damage(f"its /{name} is missing", name in ("log", "text"))
    return f[name]


def _meta_json(f, path: Path) -> dict[str, Any]:
    """Root attributes, JSON ones parsed; `Damage` naming a damaged one."""
    meta = {}
    for key in f.attrs:
        try:
            value = f.attrs[key]
        except (UnicodeDecodeError, OSError) as exc:
            raise Damage(f"its attribute '{key}' is unreadable ({type(exc).__name__})",
                          key in REBUILT_ATTRS) from None
        meta[key] = value.item() if isinstance(value, np.generic) else value
    missing = [k for k in ("format", "schema_version", "fs", "excitation", "force_dofs",
                           "n_dof", "response_kind") if k not in meta]
    if missing:
        raise Damage(f"its attribute(s) {', '.join(missing)} are missing", False)
    if meta.get("format") != FORMAT:
        raise StoreError(f"{path} is an HDF5 file but not an nlid-lab run")
    for key in ("excitation_settings", "settings", "sensors", "monitors"):
        if key in meta:
            json_text(str(meta[key]).encode(errors="surrogateescape"),
                      f"its attribute '{key}'", key in REBUILT_ATTRS)
    for key in ("excitation_settings", "settings"):
        meta[key] = json.loads(meta.get(key) or "{}")
    meta["force_dofs"] = np.asarray(meta["force_dofs"], dtype=int)
    return meta


def _log_json(f) -> list[dict[str, Any]]:
    """The log's complete entries; `Damage` naming an entry whose text is damaged."""
    text = _table(f, "text")[:]
    out = []
    for i, row in enumerate(_table(f, "log")[:]):
        if row["start"] + row["length"] > text.size:
            continue                # its text never reached the disk: not an entry yet
        payload = json_text(text[row["start"]:row["start"] + row["length"]].tobytes(),
                            f"its log entry {i}")
        if not isinstance(payload, dict):
            raise Damage(f"its log entry {i} is damaged (not a JSON object)", True)
        out.append({"t": float(row["t"]), "kind": row["kind"].decode(errors="replace"),
                    **payload})
    return out


def _levels(f, segments: np.ndarray) -> tuple[list[Level], list[str]]:
    """The run's levels (a table run's count their steps), and a level of unknown nominal for
    each level its segments name that ``/levels`` does not list (with a note saying so)."""
    steps = table_steps(f)
    rows = np.sort(_table(f, "levels")[:], order="index")
    listed = [(int(lv["index"]), float(lv["nominal"]), bool(lv["complete"])) for lv in rows]
    notes = []
    for index in sorted(set(segments["level"].tolist()) - {i for i, _, _ in listed}):
        n = int(np.count_nonzero(segments["level"] == index))
        notes.append(f"{n} block(s) name level {index}, which the run's /levels table does "
                     "not list: read as a level of unknown nominal, marked incomplete")
        listed.append((int(index), np.nan, False))
    levels = [Level(i, nominal, complete,
                    steps.get(i, int(np.count_nonzero(segments["level"] == i))),
                    int(segments["length"][segments["level"] == i].sum()))
              for i, nominal, complete in sorted(listed)]
    return levels, notes


def open_run(path: str | os.PathLike) -> Run:
    """Read a run file's metadata and block index (works on crashed files too). A damaged
    file raises `DamagedRunError` naming what is damaged and the fix."""
    path = Path(path)
    with _open(path, "r") as f:
        try:
            run = _read_run(f, path)
        except StoreError:
            raise
        except (Damage, KeyError, ValueError, TypeError, OSError, RuntimeError) as exc:
            repairable = getattr(exc, "repairable", False)
            what = str(exc) if isinstance(exc, Damage) else \
                f"{type(exc).__name__}: {' '.join(str(exc).split())[:120]}"
            fix = (REPAIRABLE if repairable else UNREPAIRABLE).format(path=path)
            raise DamagedRunError(f"{path} is damaged: {what}; {fix}") from None
    run.left_open = writer_left_open(path)   # once closed here: a plain open tells
    return run


def _read_run(f, path: Path) -> Run:
    meta = _meta_json(f, path)
    version = int(meta["schema_version"])
    if version > TABLES_SCHEMA_VERSION:
        raise StoreError(f"{path} has run schema {version}; this nlid-lab reads up to "
                         f"{TABLES_SCHEMA_VERSION}: upgrade nlid-lab")
    channels = [{"name": c["name"].decode(errors="replace"),
                 "unit": c["unit"].decode(errors="replace"), "dof": int(c["dof"]),
                 "sensitivity": float(c["sensitivity"]), "kind": c["kind"].decode()}
                for c in _table(f, "channels")[:]]
    _table(f, "state")
    status, reason, updated = _read_status(f)
    lost = f["state/losses"][:]
    every = _table(f, "segments")[:]
    rows = min(_table(f, f"data/{k}").shape[0] for k in ("force", "response"))
    on_disk = every["start"] + every["length"] <= rows
    segments = _valid_segments(f)
    missing = [LeftOut(int(s["level"]), int(s["seq"]), LeftOutReason.NOT_ON_DISK)
               for s in every[~on_disk]]
    log = _log_json(f)
    extra = _read_extra(f)
    levels, notes = _levels(f, segments)
    results = {e["name"]: e["value"] for e in log if e["kind"] == "result"}
    return Run(path, meta, channels, status, reason, updated,
               {"frames": int(lost[0]), "samples": int(lost[1])}, levels, segments, log,
               results, warnings=list(notes), extra=extra, left_out=missing, notes=notes)


def repair_run(path: str | os.PathLike, verify: bool = False) -> Repaired:
    """Clear the "open for write" flag a killed writer left on ``path``, so that any HDF5
    tool opens it; with ``verify`` also rebuild a closed run holding damaged blocks, log
    entries or free-form attributes. Returns what was done (false: nothing to repair).

    Every block is checked (index row flushed, checksum correct) and only those are kept, in a
    fresh file that atomically replaces the original. A file still open in a live writer is
    refused (`StoreError`).
    """
    path = Path(path)
    done = _repair(path, verify)
    if done:                    # the reserve a killed writer left (docs/reliability-store.md)
        path.with_name(path.name + ".reserve").unlink(missing_ok=True)
    return done


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
    payload = {"name": name, "value": result}
    require(path, len(json.dumps(payload, default=_json_default)) + BLOCK_OVERHEAD,
            f"the result '{name}' in {path}")
    with _open_swmr_write(path) as f:
        try:
            _append_log(f, "result", payload)
        except (OSError, RuntimeError) as exc:
            if is_disk_full(exc):
                raise DiskFullError(f"disk full while storing the result '{name}' in {path}"
                                    "; free space and store it again") from None
            raise


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
    if first.excitation == Excitation.STEPPED_SINE:   # what the controller held (read back)
        excitation.setdefault("control", str(first.control))
        excitation.setdefault("control_dof", first.control_dof)
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
            if r.excitation == Excitation.SWEPT_SINE:
                lv.append_block(r.force, r.response, extra=r.sweep.keys(), monitor=mon)
            elif r.excitation == Excitation.RANDOM:
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
        "control (what the controller held)": (a.control, a.control_dof)
        == (b.control, b.control_dof),
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
