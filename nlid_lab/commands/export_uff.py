"""``nlid-lab export-uff RUN.h5 --out FILE.uff``: FRFs and coherences as UFF58 datasets."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..outputs import (add_force_option, atomic_path, refuse_overwrite, with_checks,
                       write_json)
from ..progress import progress
from .repair import check_runs


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab export-uff`` on the parsed ``args``; returns the exit code."""
    refuse_overwrite(args.force, args.out, args.json)
    from ..reports import (FUNC_COHERENCE, FUNC_FRF, all_level_frfs, load_run, uff_datasets,
                           write_uff)
    checks = check_runs([args.run])
    data = load_run(args.run)
    with progress(total=len(data.recordings), desc="export-uff: FRFs", unit="level") as bar:
        frfs = all_level_frfs(data, bar.update)
    sets = uff_datasets(frfs, data.name)
    with progress(total=len(sets), desc="export-uff: write", unit="set") as bar:
        with atomic_path(args.out) as tmp:
            write_uff(tmp, sets, bar.update)
    kinds = {FUNC_FRF: "frf", FUNC_COHERENCE: "coherence"}
    counts = {name: sum(s["func_type"] == t for s in sets) for t, name in kinds.items()}
    if args.json != "-":
        print(f"wrote {len(sets)} UFF58 datasets ({counts['frf']} FRF, {counts['coherence']} "
              f"coherence) to {args.out}")
    write_json(with_checks({"uff": str(Path(args.out)), "datasets": len(sets), **counts},
                           checks), args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``export-uff`` sub-command and its options to ``sub``."""
    p = sub.add_parser("export-uff", help="export FRFs and coherences as UFF58 (pyuff)")
    p.add_argument("run", metavar="RUN", help="run file (.h5) or recording (.npz, .csv)")
    p.add_argument("--out", required=True, metavar="FILE.uff", help="UFF file to write")
    p.add_argument("--json", metavar="FILE", help="write a summary as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
