"""``nlid-lab demo --out DIR``: the built-in demo on the simulated plant."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path

from analysis.errors import InputError

from ..outputs import add_force_option, refuse_overwrite, write_json


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab demo`` on the parsed ``args``; returns the exit code."""
    from ..demo import DemoConfig, run_demo  # scipy.signal is slow to import: not at start-up

    if args.duration <= 0 or (args.levels and min(args.levels) <= 0):
        raise InputError("--duration and --levels must be positive")
    refuse_overwrite(args.force, args.json, directories=(args.out,))
    cfg = DemoConfig(Path(args.out), duration=args.duration, seed=args.seed)
    if args.levels:
        cfg.levels = tuple(args.levels)
    # with --json - the progress report goes to stderr so stdout stays pure JSON
    quiet = contextlib.redirect_stdout(sys.stderr) if args.json == "-" else \
        contextlib.nullcontext()
    with quiet:
        summary = run_demo(cfg)
    write_json(summary.to_json(), args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``demo`` sub-command and its options to ``sub``."""
    p = sub.add_parser("demo", help="random test of the paper's SDOF system at several levels: "
                       "run file, FRF overlay, reverse-path estimate and HTML report")
    p.add_argument("--out", default="demo-out", metavar="DIR",
                   help="directory for the run file, figures, estimate JSON and report "
                   "(default demo-out)")
    p.add_argument("--levels", type=float, nargs="+", metavar="N",
                   help="force levels, N rms (default 0.5 5 15 30)")
    p.add_argument("--duration", type=float, default=128.0, help="seconds per level")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--json", metavar="FILE", help="write the summary as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
