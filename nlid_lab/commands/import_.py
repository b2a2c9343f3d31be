"""``nlid-lab import REC.npz|REC.csv|REC.mat... --out RUN.h5``: store recordings as a run file
(several files: one level each)."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from analysis.errors import InputError
from analysis.recordings import (RESPONSE_KINDS, Excitation, PeriodicLayout, StepTable, find_period,
                                 Bursts, find_bursts, flat_ends, looks_like_sweep, recording_clipping, whole_periods)
from analysis.spectral import HELD_UNITS, level_name

from .. import formats
from ..formats import describe, parse_sweep_option
from .. import store
from ..outputs import add_force_option, atomic_path, refuse_overwrite, write_json


def _sweep_keys(args: argparse.Namespace) -> dict:
    """Keys ``--excitation``/``--sweep`` add to (or override in) each file."""
    keys = {} if args.excitation is None else {"excitation": args.excitation}
    if args.sweep:
        if args.excitation not in (None, Excitation.SWEPT_SINE):
            raise InputError(f"--sweep describes a swept sine; drop it or use --excitation "
                             f"swept-sine (not {args.excitation})")
        keys = {"excitation": "swept-sine", **parse_sweep_option(args.sweep).keys()}
    return keys


def _read_levels(src: Path, args: argparse.Namespace, found: dict) -> list:
    """The levels one file holds: one, or a table map's one per struct-array element."""
    if args.map and any(item.startswith("table=") for item in args.map):
        from ..formats import TableMap, read_mat_tree
        if src.suffix.lower() != ".mat":
            raise InputError(f"{src}: a table map (table=...) reads a MATLAB struct array; "
                             "give a .mat file")
        items = args.map + ([f"response_kind={args.response_kind}"] if args.response_kind
                            else [])          # before the phases are read: a convention needs it
        return TableMap.from_items(items).tables(read_mat_tree(src), str(src))
    return [_read(src, args, found)]


def _read(src: Path, args: argparse.Namespace, found: dict):
    """The recording of one file, by its format (`formats.FORMATS`): through the channel
    map when ``--map`` is given and the format takes one, else as the file holds it."""
    given = _sweep_keys(args)
    fmt = formats.format_of(src)
    if fmt is None:
        raise InputError(f"{src}: unknown recording type '{src.suffix.lower()}'; import "
                         f"{formats.suffix_list('read')}")
    if args.map and fmt.mapped is not None:
        return _mapped({**fmt.mapped(src, _channel_map(args.map)), **given}, src, args, found)
    if fmt.read is None:
        raise InputError(f"{src}: a {fmt.name} file needs --map (docs/recording-formats.md)")
    cols = [c.strip() for c in args.force_cols.split(",")] if args.force_cols else None
    rec = fmt.read(src, formats.ReadOptions(given, cols, args.response_kind, args.force_dofs))
    if fmt.name == "CSV" and rec.excitation == Excitation.RANDOM and rec.layout is None:
        return _mapped(formats.recording_keys(rec), src, args, found)   # a DAQ export: as mapped
    return rec


def _channel_map(items: list[str]):
    """The ``--map`` words, or the one MAP.toml they name."""
    if len(items) == 1 and items[0].endswith(".toml"):
        return formats.ChannelMap.from_toml(items[0])
    return formats.ChannelMap.from_items(items)


def _mapped(keys: dict, src: Path, args: argparse.Namespace, found: dict):
    """The recording of the keys a channel map took from ``src``; a random record whose map
    gives no period gets the one its force shows (`analysis.recordings._periodicity`), noted in
    ``found[src]`` (None: none found); one whose map gives only the period (and perhaps the
    transient periods) gets the realizations back to back the force shows, when several, and
    their transient periods unless given (noted in ``args.period_given``)."""
    if args.response_kind:
        keys["response_kind"] = args.response_kind
    random = keys.get("excitation", Excitation.RANDOM) == Excitation.RANDOM and "freqs" not in keys
    delay = keys.pop("response_delay", None)
    if random:
        _trim_flat_ends(keys, src, args)
    if random and not set(formats.LAYOUT_KEYS) & set(keys):
        p = find_period(keys["force"], settle=keys["response"])
        found[src] = p
        if p is None and "excitation" not in keys and _swept(keys):
            keys["excitation"] = Excitation.SWEPT_SINE      # its law estimated from the force
            found[src] = SWEPT
        elif p is None and (b := _bursts(keys)) is not None:
            _cut(keys, b.cut)
            keys.update(period=b.length, transient_periods=0, periods=1,
                        realizations=len(b.starts))
            found[src] = b
        elif p is not None:
            if p.remainder or p.short:
                _cut(keys, lambda x: whole_periods(x, p))
            keys.update(period=p.period, transient_periods=p.transient_periods,
                        realizations=p.realizations)
    elif random and set(formats.LAYOUT_KEYS) & set(keys) <= {"period",
                                                                    "transient_periods"} \
            and _whole(keys.get("period")):
        p = find_period(keys["force"], period=_whole(keys["period"]), settle=keys["response"])
        if p is not None and p.realizations > 1 and not p.remainder:
            keys.setdefault("transient_periods", p.transient_periods)
            keys["realizations"] = p.realizations         # back to back with the given period
            found[src] = dataclasses.replace(p, transient_periods=int(
                keys["transient_periods"]))
            args.period_given.add(src)
    if delay is not None:
        _advance(keys, delay, src)
    return formats.recording_from_keys(keys, src)


#: ``found[src]`` of a record taken as a swept sine (no period; the force sweeps)
SWEPT = "swept"


def _swept(keys: dict) -> bool:
    """Whether a mapped record that names no excitation holds a swept sine in its force (an
    F-16 ``SineSw`` export: no period, the force's frequency rising or falling)."""
    force = np.asarray(keys["force"], dtype=float)
    fs = np.asarray(keys.get("fs", 0.0), dtype=float)
    if force.ndim > 2 or fs.size != 1 or not float(fs.reshape(())) > 0:
        return False                       # the recording's own checks name the problem
    return looks_like_sweep(force.reshape(len(force), -1)[:, 0], float(fs.reshape(())))


def _bursts(keys: dict) -> Bursts | None:
    """The realizations a mapped record holds as bursts between quiet gaps (a Silverbox-like
    export, `analysis.recordings.find_bursts`), or None."""
    force = np.asarray(keys["force"], dtype=float)
    return find_bursts(force) if force.ndim <= 2 else None


def _advance(keys: dict, delay, src: Path) -> None:
    """Responses moved ``delay`` samples earlier (``response_delay=`` of a map: the
    group-delay difference of the channels' anti-alias filters, as `fit-linear` reports it):
    a phase ramp per realization, exact on whole periods of a periodic record, a few samples
    of end effect on a random one."""
    lag = np.asarray(delay, dtype=float)
    if lag.size != 1 or not np.isfinite(lag).all() or abs(float(lag.reshape(()))) > 1e3:
        raise InputError(f"{src}: response_delay must be one number of samples (e.g. "
                         f"response_delay=1), got {delay!r}")
    n = len(keys["force"])
    resp = _samples_first(np.asarray(keys["response"], dtype=float), n)
    m = _whole(keys.get("realizations", 1)) or 1
    blocks = np.split(resp, m if resp.shape[0] % m == 0 else 1)
    ramps = [np.exp(2j * np.pi * np.fft.rfftfreq(len(b)) * float(lag.reshape(())))
             for b in blocks]
    keys["response"] = np.concatenate([
        np.fft.irfft(np.fft.rfft(b, axis=0) * r.reshape((-1,) + (1,) * (b.ndim - 1)),
                     len(b), axis=0) for b, r in zip(blocks, ramps)])


def _cut(keys: dict, cut) -> None:
    """Apply ``cut`` (samples along axis 0) to the force, response and monitor keys."""
    for k in ("force", "response", "monitor"):
        if k in keys:
            keys[k] = cut(_samples_first(np.asarray(keys[k]), len(keys["force"])))


def _samples_first(arr: np.ndarray, n: int) -> np.ndarray:
    """``arr`` with its sample axis first (a map may give channels x samples)."""
    return arr.T if arr.ndim == 2 and arr.shape[0] != n and arr.shape[1] == n else arr


def _trim_flat_ends(keys: dict, src: Path, args: argparse.Namespace) -> None:
    """Drop the lead-in and trailing samples at which every channel stands still (an
    export's padding zeros, `analysis.recordings.flat_ends`), noted in ``args.trimmed``."""
    n = len(np.asarray(keys["force"]).reshape(len(keys["force"]), -1))
    chans = [_samples_first(np.asarray(keys[k]), n) for k in ("force", "response") if k in keys]
    if any(c.shape[0] != n for c in chans):
        return                            # the recording's own checks name the mismatch
    lead, tail = flat_ends(*chans)
    if lead or tail:
        _cut(keys, lambda x: x[lead:x.shape[0] - tail])
        args.trimmed[src] = (lead, tail)


def _whole(value) -> int | None:
    """A ``period=`` the map gives as one whole number >= 2, else None (then the recording's
    own checks name the problem)."""
    arr = np.asarray(value)
    if arr.size != 1 or arr.dtype.kind not in "iuf":
        return None
    v = float(arr.reshape(()))
    return int(v) if v.is_integer() and v >= 2 else None


def _common_transient(recs: list, sources: list[Path], found: dict) -> list:
    """Levels whose layouts were found and differ only in their transient periods all take
    the most any shows (levels of one run share their layout; a higher level often settles
    later); ``found`` is updated to say so."""
    lays = [r.layout for r in recs]
    if len(recs) < 2 or any(not hasattr(found.get(s), "whole") or lay is None
                            for s, lay in zip(sources, lays)):
        return recs
    shape = {(lay.period, lay.realizations, lay.transient_periods + lay.periods)
             for lay in lays}
    t = max(lay.transient_periods for lay in lays)
    if len(shape) != 1 or all(lay.transient_periods == t for lay in lays):
        return recs
    period, m, each = shape.pop()
    layout = PeriodicLayout(period, t, each - t, m)
    for s in sources:
        found[s] = dataclasses.replace(found[s], transient_periods=t)
    return [dataclasses.replace(r, layout=layout, extra=dict(r.extra), meta=dict(r.meta))
            for r in recs]


def _period_lines(found: dict, given: set) -> list[str]:
    """What the import found or assumed about the period, one line per distinct finding
    (``given``: files whose map gave the period, where only the realizations were found)."""
    says: dict[str, list[Path]] = {}
    for src, p in found.items():
        if isinstance(p, Bursts):
            left = "".join(f"; the {n}-sample burst at sample {s} left out (not a realization)"
                           for s, n in p.others)
            text = (f"no period found; {len(p.starts)} bursts of {p.length} samples between "
                    f"quiet gaps taken as realizations of one period each (the gaps "
                    f"dropped){left}; give period= to override")
        elif p == SWEPT:
            text = ("no period found; the force sweeps: imported as swept sine, its law "
                    "estimated (above); give --excitation random to override")
        elif p is None:
            text = ("no period found in the force: imported as plain random, nothing "
                    "assumed; give period= (samples) if it is periodic")
        else:
            first = ("no transient (the first period repeats like the others)"
                     if p.transient_periods == 0 else "the first taken as transient"
                     if p.transient_periods == 1 else
                     f"the first {p.transient_periods} taken as transient")
            each = (f"{p.periods} periods" if p.realizations == 1 else
                    f"{p.realizations} realizations back to back of {p.periods} periods each")
            first += "" if p.realizations == 1 or not p.transient_periods else " in each"
            if p.remainder or p.short:
                each += (f", the record cut {p.remainder} samples into a period"
                         + (f" of its last realization: {p.whole} whole periods of each kept"
                            if p.short else ": those samples dropped"))
            text = (f"periodic: {p.period}-sample period found, {each}, {first}; "
                    "give period= to override") if src not in given else (
                f"periodic: {p.period}-sample period given, {each} found, {first}; give "
                "realizations= to override")
        says.setdefault(text, []).append(src)
    return [text + ("" if len(srcs) == len(found) == 1 else f" ({len(srcs)} of "
                    f"{len(found)} files)" if len(srcs) < len(found) else f" (all "
                    f"{len(found)} files)") for text, srcs in says.items()]


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab import`` on the parsed ``args``; returns the exit code."""
    sources, out = [Path(p) for p in args.recording], Path(args.out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise InputError(f"--out {out}: a run file must end in .h5")
    refuse_overwrite(args.force, out, args.json)
    if args.level is not None and len(sources) > 1:
        raise InputError("--level names the level of one recording; with several files each "
                         "level comes from its file (a level key, else the force)")
    found: dict = {}
    args.period_given = given = set()
    args.trimmed = {}
    levels = [_read_levels(src, args, found) for src in sources]
    if any(len(lv) != 1 for lv in levels):
        if args.sensors or args.level is not None:
            raise InputError("--sensors and --level apply to one-level files; a table map "
                             "gives each struct element's own level")
        return _store_tables(sources, [t for lv in levels for t in lv], out, args)
    if any(isinstance(lv[0], StepTable) for lv in levels):
        return _store_tables(sources, [lv[0] for lv in levels], out, args)
    recs = _common_transient([lv[0] for lv in levels], sources, found)
    if args.sensors:
        keys = formats.read_sensors(args.sensors)
        recs = [formats.with_sensors(r, keys) for r in recs]
    if args.level is not None:
        recs[0].level = args.level
    with atomic_path(out) as tmp:         # no half run on a full disk
        store.save_recording(tmp, recs, source="import",
                             settings={"imported_from": [str(s) for s in sources]})
    rec = recs[0]
    result = {"out": str(out), "source": [str(s) for s in sources], "levels": len(recs),
              "excitation": rec.excitation, "fs": rec.fs, "force_dofs": rec.force_dofs,
              "n_dof": rec.n_dof, "n_samples": int(rec.force.shape[-2]),
              "response_kind": rec.response_kind,
              "sensors": None if rec.sensors is None else {
                  k: v.tolist() for k, v in rec.sensors.to_keys().items()}}
    if rec.monitors:
        result["monitors"] = {k: rec.monitor_units.get(k, "") for k in rec.monitors}
    if rec.sweep is not None:
        result["sweeps"] = [{k: v.item() for k, v in r.sweep.keys().items()} for r in recs]
    if args.trimmed:
        result["trimmed"] = {str(src): {"lead_in": lead, "trailing": tail}
                             for src, (lead, tail) in args.trimmed.items()}
    clipped = {src: c for src, r in zip(sources, recs)
               if (c := recording_clipping(r, level_name(r))) is not None}
    if clipped:
        result["clipped"] = {str(src): [{"kind": ch.kind, "channel": ch.channel,
                                         "samples": int(ch.samples.size), "low": ch.low,
                                         "high": ch.high} for ch in c.channels]
                             for src, c in clipped.items()}
    if found:
        result["period_found"] = {str(src): None if p is None else {
            "period": p.period, "periods": p.periods, "transient_periods": p.transient_periods,
            "realizations": p.realizations, "share": p.share, "remainder": p.remainder,
            "whole_periods": p.whole}
            for src, p in found.items() if p != SWEPT and not isinstance(p, Bursts)}
    if args.json != "-":
        what = sources[0] if len(sources) == 1 else f"{len(sources)} files"
        print(f"imported {what} ({rec.excitation}, fs {rec.fs:g} Hz, {rec.n_dof} "
              f"{rec.response_kind} channel(s), "
              f"{len(recs)} level(s)) -> {out}")
        for src, r in zip(sources, recs):
            if r.sweep is not None:
                print(f"  {src.name}: {describe(r.sweep)}")
        for src, (lead, tail) in args.trimmed.items():
            print(f"  {src.name}: {lead} lead-in and {tail} trailing samples at which no "
                  "channel moves (export padding) dropped")
        for line in _period_lines(found, given):
            print(f"  {line}")
        for src, c in clipped.items():
            print(f"  {src.name}: {c.text('stored as recorded; diagnose leaves them out')}")
        if rec.monitors:
            named = args.map and any(item.startswith("monitor=") for item in args.map)
            chans = ", ".join(f"{k} [{rec.monitor_units[k]}]" if k in rec.monitor_units else k
                              for k in rec.monitors)
            print(f"  monitor channel(s) kept, not used by any estimator: {chans}"
                  + ("" if named or not args.map else " (the channels the map does not "
                     "name; monitor=NAME chooses them, monitor=none drops them)"))
    write_json(result, args.json)
    return 0


def _store_tables(sources: list[Path], tables: list, out: Path,
                  args: argparse.Namespace) -> int:
    """Store stepped-sine tables as the levels of a table run; print and write the summary."""
    if args.sensors:
        keys = formats.read_sensors(args.sensors)
        tables = [formats.with_sensors(t, keys) for t in tables]
    if args.level is not None:
        tables[0] = dataclasses.replace(tables[0], level=args.level)
    store.save_recording(out, tables, source="import",
                         settings={"imported_from": [str(s) for s in sources]})
    t = tables[0]
    unit = HELD_UNITS.get(t.control_kind, "")
    result = {"out": str(out), "source": [str(s) for s in sources], "levels": len(tables),
              "excitation": "stepped-sine", "table": True, "control": str(t.control),
              "control_dof": t.control_dof, "force_dofs": t.force_dofs, "n_dof": t.n_dof,
              "response_kind": t.response_kind,
              "level": [tb.level for tb in tables], "n_steps": [tb.n_steps for tb in tables]}
    if args.json != "-":
        what = sources[0] if len(sources) == 1 else f"{len(sources)} files"
        print(f"imported {what} (stepped-sine table, {t.control}-controlled, {t.n_dof} "
              f"{t.response_kind} channel(s), {len(tables)} level(s)) -> {out}")
        for i, tb in enumerate(tables):
            print(f"  level {i}: held {tb.level:.4g} {unit}, {tb.n_steps} steps "
                  f"{tb.freqs.min():g}-{tb.freqs.max():g} Hz")
    write_json(result, args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``import`` sub-command and its options to ``sub``."""
    p = sub.add_parser("import", help="store NPZ, CSV or MAT recordings as an HDF5 run")
    p.add_argument("recording", metavar="REC", nargs="+",
                   help="recording .npz (contracts section 3), .csv or .mat "
                   "(docs/recording-formats.md); several files become the levels of one run")
    p.add_argument("--out", required=True, metavar="RUN.h5", help="run file to write")
    p.add_argument("--force-cols", metavar="A,B", help="CSV: names of the force columns "
                   "(default: columns whose name starts with 'f')")
    p.add_argument("--response-kind", choices=RESPONSE_KINDS,
                   help="CSV/MAT: what the response columns measure (default: the file's "
                   "response_kind key, else displacement)")
    p.add_argument("--force-dofs", type=int, nargs="+", metavar="K",
                   help="CSV whose header names no DOF: the 0-based response column measured "
                   "where each force acts")
    p.add_argument("--map", nargs="+", metavar="KEY=VALUE",
                   help="MAT or CSV export: channel map, e.g. force=Force "
                   "response=Acceleration[0:3]:g fs=Fs force_dofs=0 (CSV: "
                   "response=Acc1,Acc2 fs=400; NAME[cols]@A,B,C names the model point of "
                   "each column: a sensor map; monitor=Voltage:V names channels kept beside "
                   "force and response, default every channel the map does not use, "
                   "monitor=none drops them), or one MAP.toml; a stepped-sine table "
                   "exported as a MATLAB struct array: table=STRUCT freqs=FIELD "
                   "force_amplitude=FIELD response_amplitude=FIELD:UNIT "
                   "response_phase=FIELD:lead|lag|receptance[:deg] control=response|force "
                   "(one level per element; docs/recording-formats.md)")
    p.add_argument("--sensors", metavar="SENSORS.toml", help="sensor map: the model point "
                   "and kind of each response channel, the point of each force "
                   "(response_points, response_kinds, force_points; docs/model-format.md"
                   "#sensor-maps)")
    p.add_argument("--excitation", choices=("random", "swept-sine"),
                   help="what the files hold when they do not say (exports carry no "
                   "excitation key); swept-sine files without sweep keys get the sweep law "
                   "estimated from the force, lead-in and trailing zeros trimmed")
    p.add_argument("--sweep", metavar="START:STOP[:LAW[:RATE]]",
                   help="swept sine: the sweep as generated (Hz, Hz, linear|log, Hz/s or "
                   "octaves/min); parts left out are estimated from the force")
    p.add_argument("--level", type=float, help="nominal level (force rms or amplitude), N")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
