"""``nlid-lab repair RUN.h5...``: make a run left open by a killed writer readable by any HDF5
tool; `check_runs` is what ``view``, ``report`` and ``detect`` say about incomplete runs."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

RUN_SUFFIXES = (".h5", ".hdf5")


def repair_option(p: argparse.ArgumentParser) -> None:
    """The ``--repair`` option of a command that reads runs."""
    p.add_argument("--repair", action="store_true",
                   help="first clear the 'open for write' flag a killed writer left on a run "
                   "(same as `nlid-lab repair`), so that other HDF5 tools can open it")


def check_runs(paths: Sequence[str], repair: bool = False) -> None:
    """One line on stderr for every incomplete run among ``paths``; repair (or, at a terminal,
    offer to repair) runs still flagged by a killed writer."""
    from ..store import open_run, repair_run
    for path in (p for p in paths if Path(p).suffix.lower() in RUN_SUFFIXES
                 and Path(p).is_file()):
        run = open_run(path)
        if run.left_open and (repair or _ask(f"{path}: left open by its writer (killed?); "
                                             "repair it now [y/N]? ")):
            repair_run(path)
            print(f"{path}: repaired (every intact block kept); other HDF5 tools can open it "
                  "now", file=sys.stderr)
        elif run.left_open:
            print(f"note: {path}: other HDF5 tools cannot open this run until it is repaired "
                  f"(`nlid-lab repair {path}`, or --repair)", file=sys.stderr)
        if run.incomplete:
            print(f"note: {path}: run {run.incomplete}", file=sys.stderr)


def _ask(question: str) -> bool:
    if not (sys.stdin.isatty() and sys.stderr.isatty()):
        return False
    print(question, end="", file=sys.stderr, flush=True)
    return sys.stdin.readline().strip().lower() in ("y", "yes")


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab repair`` on the parsed ``args``; returns the exit code."""
    from ..store import open_run, repair_run
    for path in args.runs:
        blocks = len(open_run(path).segments)
        if repair_run(path):
            kept = len(open_run(path).segments)
            print(f"{path}: repaired, {kept} of {blocks} indexed blocks intact and kept")
        else:
            print(f"{path}: nothing to repair (closed cleanly)")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``repair`` sub-command and its options to ``sub``."""
    p = sub.add_parser("repair", help="make a run left open by a killed writer readable by "
                       "other HDF5 tools (h5py, HDFView, MATLAB)")
    p.add_argument("runs", nargs="+", metavar="RUN.h5", help="run files")
    p.set_defaults(func=run)
