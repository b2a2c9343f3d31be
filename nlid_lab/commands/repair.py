"""``nlid-lab repair RUN.h5...``: make a run left open by a killed writer readable by any HDF5
tool, and rebuild a damaged one without its damaged blocks, log entries and free-form
attributes; `check_runs` is what every reader of runs says about incomplete runs and the blocks
it leaves out."""

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


def check_runs(paths: Sequence[str], repair: bool = False, skip_unreadable: bool = False
               ) -> list:
    """What a reader says about the runs among ``paths`` before using them, on stderr: an
    incomplete run ("run is incomplete: 3 of 8 blocks"), the blocks left out and why
    (checksums verified); runs still flagged by a killed writer are repaired (or, at a
    terminal, offered a repair). Returns the `nlid_lab.store.RunCheck` of each run, whose
    ``to_json`` commands add to their JSON (`nlid_lab.outputs.with_checks`). With
    ``skip_unreadable`` a run that cannot be opened is left to the command (reanalysis
    reports it as a failed run) instead of raising."""
    from ..store import StoreError, open_run, repair_run
    checks = []
    for path in (p for p in paths if Path(p).suffix.lower() in RUN_SUFFIXES
                 and Path(p).is_file()):
        try:
            run = open_run(path)
        except StoreError:
            if skip_unreadable:
                continue
            raise
        if run.left_open and (repair or _ask(f"{path}: left open by its writer (killed?); "
                                             "repair it now [y/N]? ")):
            repair_run(path)
            print(f"{path}: repaired (every intact block kept); other HDF5 tools can open it "
                  "now", file=sys.stderr)
            run = open_run(path)
        elif run.left_open:
            print(f"note: {path}: other HDF5 tools cannot open this run until it is repaired "
                  f"(`nlid-lab repair {path}`, or --repair)", file=sys.stderr)
        checks.append(run.check())
        for line in checks[-1].lines():
            print(line, file=sys.stderr)
    return checks


def _ask(question: str) -> bool:
    if not (sys.stdin.isatty() and sys.stderr.isatty()):
        return False
    print(question, end="", file=sys.stderr, flush=True)
    return sys.stdin.readline().strip().lower() in ("y", "yes")


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab repair`` on the parsed ``args``; returns the exit code."""
    from ..store import repair_run
    for path in args.runs:
        done = repair_run(path, verify=True)
        what = f" ({done.text()})" if done.text() else ""
        if done:
            print(f"{path}: repaired, {done.kept} of {done.kept + len(done.dropped)} indexed "
                  f"blocks intact and kept{what}")
        else:
            print(f"{path}: nothing to repair (closed cleanly, every block intact)")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``repair`` sub-command and its options to ``sub``."""
    p = sub.add_parser("repair", help="rebuild a damaged run without its damaged blocks, and "
                       "make a run left open by a killed writer readable by "
                       "other HDF5 tools (h5py, HDFView, MATLAB)")
    p.add_argument("runs", nargs="+", metavar="RUN.h5", help="run files")
    p.set_defaults(func=run)
