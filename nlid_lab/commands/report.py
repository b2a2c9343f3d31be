"""``nlid-lab report RUN.h5 --out DIR``: PNG figures and one HTML page of a run."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from .. import methods
from ..outputs import add_force_option, atomic_dir, refuse_overwrite, with_checks, write_json
from ..progress import progress
from .repair import check_runs, repair_option


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab report`` on the parsed ``args``; returns the exit code."""
    from analysis.models import Model

    from ..reports import all_level_frfs, load_run, write_report
    refuse_overwrite(args.force, args.json, directories=(args.out,))
    checks = check_runs([args.run], args.repair)
    data = load_run(args.run)
    with progress(total=len(data.recordings), desc="report: FRFs", unit="level") as bar:
        frfs = all_level_frfs(data, bar.update)
    candidate = Model.load(args.model) if args.model else None
    with progress(desc="report: figures", unit="fig") as bar, atomic_dir(args.out) as tmp:
        result = write_report(data, tmp, bar.update, frfs=frfs, candidate=candidate,
                              estimators=methods)
    # figures and page moved there whole
    result = replace(result, html=str(Path(args.out) / "index.html"))
    print(result.html)
    write_json(with_checks(result.to_json(), checks), args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``report`` sub-command and its options to ``sub``."""
    p = sub.add_parser("report", help="write a run's figures (PNG) and an HTML report")
    p.add_argument("run", metavar="RUN", help="run file (.h5) or recording (.npz, .csv)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--model", metavar="CANDIDATE.toml",
                   help="candidate model for the reverse-path section (default: the model "
                        "stored with a simulated run, its parameters estimated)")
    p.add_argument("--json", metavar="FILE", help="write what was written as JSON ('-' stdout)")
    add_force_option(p)
    repair_option(p)
    p.set_defaults(func=run)
