"""``nlid-lab import REC.npz|REC.csv --out RUN.h5``: store a recording as a run file."""

from __future__ import annotations

import argparse
from pathlib import Path

from analysis.errors import InputError
from analysis.recording import RESPONSE_KINDS

from .. import recordings_io, store
from ..outputs import add_force_option, refuse_overwrite, write_json


def run(args: argparse.Namespace) -> int:
    src, out = Path(args.recording), Path(args.out)
    if out.suffix.lower() not in (".h5", ".hdf5"):
        raise InputError(f"--out {out}: a run file must end in .h5")
    refuse_overwrite(args.force, out, args.json)
    suffix = src.suffix.lower()
    if suffix == ".npz":
        rec = recordings_io.read_npz(src)
    elif suffix == ".csv":
        cols = [c.strip() for c in args.force_cols.split(",")] if args.force_cols else None
        rec = recordings_io.read_csv(src, force_cols=cols, response_kind=args.response_kind)
    else:
        raise InputError(f"{src}: unknown recording type '{suffix}'; import .npz or .csv")
    if args.level is not None:
        rec.level = args.level
    store.save_recording(out, rec, source="import", settings={"imported_from": str(src)})
    result = {"out": str(out), "source": str(src), "excitation": rec.excitation,
              "fs": rec.fs, "force_dofs": rec.force_dofs, "n_dof": rec.n_dof,
              "n_samples": int(rec.force.shape[-2]), "response_kind": rec.response_kind}
    if args.json != "-":
        print(f"imported {src} ({rec.excitation}, fs {rec.fs:g} Hz, {rec.n_dof} DOF) -> {out}")
    write_json(result, args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("import", help="store an NPZ or CSV recording as an HDF5 run")
    p.add_argument("recording", metavar="REC", help="recording .npz (contracts section 3) or "
                   ".csv (docs/recording-formats.md)")
    p.add_argument("--out", required=True, metavar="RUN.h5", help="run file to write")
    p.add_argument("--force-cols", metavar="A,B", help="CSV: names of the force columns "
                   "(default: columns whose name starts with 'f')")
    p.add_argument("--response-kind", choices=RESPONSE_KINDS, default="displacement",
                   help="CSV: what the response columns measure (default displacement)")
    p.add_argument("--level", type=float, help="nominal level (force rms or amplitude), N")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
