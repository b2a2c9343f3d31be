"""``nlid-lab warmup``: compile the numeric kernels once (``make`` runs it after installing)."""

from __future__ import annotations

import argparse

from ..warmup import main


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab warmup`` on the parsed ``args``; returns the exit code."""
    return main()


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``warmup`` sub-command and its options to ``sub``."""
    p = sub.add_parser("warmup", help="compile the numeric kernels now, so that the first "
                       "analysis does not wait for them")
    p.set_defaults(func=run)
