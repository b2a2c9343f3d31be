"""``nlid-lab import REC.npz|REC.csv|REC.mat... --out RUN.h5``: store recordings as a run file
(several files: one level each)."""

from __future__ import annotations

import argparse
from pathlib import Path

from analysis.errors import InputError
from analysis.recording import RESPONSE_KINDS

from .. import recordings_io, store
from ..outputs import add_force_option, refuse_overwrite, write_json


def _read(src: Path, args: argparse.Namespace):
    suffix = src.suffix.lower()
    if suffix == ".npz":
        return recordings_io.read_npz(src)
    if suffix == ".csv":
        cols = [c.strip() for c in args.force_cols.split(",")] if args.force_cols else None
        return recordings_io.read_csv(src, force_cols=cols, response_kind=args.response_kind,
                                      force_dofs=args.force_dofs)
    if suffix == ".mat":
        from .. import mat_io
        tree = mat_io.read_mat_tree(src)
        if not args.map:
            raise InputError(f"{src}: a MAT file needs --map (e.g. --map force=Force "
                             "response=Acceleration[0:3]:g fs=Fs force_dofs=0); the file holds "
                             + ", ".join(sorted(tree)))
        cmap = (mat_io.ChannelMap.from_toml(args.map[0])
                if len(args.map) == 1 and args.map[0].endswith(".toml")
                else mat_io.ChannelMap.from_items(args.map))
        keys = mat_io.apply_map(tree, cmap, str(src))
        if args.response_kind:
            keys["response_kind"] = args.response_kind
        return recordings_io.recording_from_keys(keys, src)
    raise InputError(f"{src}: unknown recording type '{suffix}'; import .npz, .csv or .mat")


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab import`` on the parsed ``args``; returns the exit code."""
    sources, out = [Path(p) for p in args.recording], Path(args.out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise InputError(f"--out {out}: a run file must end in .h5")
    refuse_overwrite(args.force, out, args.json)
    if args.level is not None and len(sources) > 1:
        raise InputError("--level names the level of one recording; with several files each "
                         "level comes from its file (a level key, else the force)")
    recs = [_read(src, args) for src in sources]
    if args.level is not None:
        recs[0].level = args.level
    store.save_recording(out, recs, source="import",
                         settings={"imported_from": [str(s) for s in sources]})
    rec = recs[0]
    result = {"out": str(out), "source": [str(s) for s in sources], "levels": len(recs),
              "excitation": rec.excitation, "fs": rec.fs, "force_dofs": rec.force_dofs,
              "n_dof": rec.n_dof, "n_samples": int(rec.force.shape[-2]),
              "response_kind": rec.response_kind}
    if args.json != "-":
        what = sources[0] if len(sources) == 1 else f"{len(sources)} files"
        print(f"imported {what} ({rec.excitation}, fs {rec.fs:g} Hz, {rec.n_dof} channel(s), "
              f"{len(recs)} level(s)) -> {out}")
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
                   help="MAT: channel map, e.g. force=Force response=Acceleration[0:3]:g "
                   "fs=Fs force_dofs=0, or one MAP.toml")
    p.add_argument("--level", type=float, help="nominal level (force rms or amplitude), N")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
