"""``nlid-lab export RUN.h5 --out REC.npz|REC.csv|REC.mat``: one level of a run as a recording
file."""

from __future__ import annotations

import argparse
from pathlib import Path

from analysis.errors import InputError

from ..formats import format_of, recording_keys, suffix_list
from ..outputs import add_force_option, atomic_path, refuse_overwrite, with_checks, write_json
from .repair import check_runs


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab export`` on the parsed ``args``; returns the exit code."""
    from ..store import open_run

    out = Path(args.out)
    fmt = format_of(out)
    if fmt is None or fmt.write is None:
        raise InputError(f"--out {out}: export to a {suffix_list('write')} recording")
    refuse_overwrite(args.force, out, args.json)
    checks = check_runs([args.run])
    stored = open_run(args.run)
    level = stored.level_index(args.level)      # --level, or the only level with data
    rec = stored.recording(level)
    with atomic_path(out) as tmp:
        fmt.write(tmp, rec)
    if args.json != "-":
        print(f"exported level {level} of {args.run} ({rec.excitation}) -> {out}")
    write_json(with_checks({"out": str(out), "run": str(args.run), "level": level,
                            "keys": sorted(recording_keys(rec))}, checks),
               args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``export`` sub-command and its options to ``sub``."""
    p = sub.add_parser("export", help="write one level of a run as an NPZ, CSV or MAT recording")
    p.add_argument("run", metavar="RUN.h5", help="run file")
    p.add_argument("--out", required=True, metavar="REC", help="recording .npz, .csv or .mat "
                   "(docs/recording-formats.md; CSV for random and swept-sine data)")
    p.add_argument("--level", type=int, help="level index (default: the only level with data)")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
