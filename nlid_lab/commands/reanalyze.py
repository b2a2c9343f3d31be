"""``nlid-lab reanalyze RUN... --model CANDIDATE.toml [--out RESULTS.h5]`` on Dask.

Exit codes: 0 every run analysed; 1 some runs or levels failed (the table is still written
and names each failure); 2 bad input (model, paths, method, scheduler address).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import methods
from ..outputs import (add_quiet_option, atomic_path, refuse_overwrite, summary_stream,
                       with_checks, write_json)
from .repair import check_runs


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab reanalyze`` on the parsed ``args``; returns the exit code."""
    from analysis.models import Model
    from nlid_lab.reanalyze import (ReanalysisError, check_request, dask_client,
                                    expand_runs, reanalyze, write_results)

    refuse_overwrite(args.force, args.out, args.json)
    model = Model.load(args.model)  # bad input: exit 2 before any cluster starts
    check_request(model, args.method, args.run_timeout)
    options = methods.batch_values(args)
    for method in methods.methods():
        method.make_options(options)   # a bad option value: exit 2 before the cluster starts
    runs = expand_runs(args.runs)
    if args.out and not Path(args.out).resolve().parent.is_dir():
        raise ReanalysisError(f"--out {args.out}: its directory does not exist; create it "
                              "first (checked before the runs are analysed)")
    checks = check_runs(runs, skip_unreadable=True)
    with dask_client(args.workers, args.scheduler) as client:
        result = reanalyze(runs, model, client, args.method, options,
                           progress=not (args.no_progress or args.quiet),
                           run_timeout_s=args.run_timeout)
    to = summary_stream(args.json, args.quiet)  # stderr with --json -: stdout stays JSON
    print(result.summary(), file=to)
    if args.out:
        with atomic_path(args.out) as tmp:
            write_results(result, tmp)
        print(f"results: {args.out}", file=to)
    data = result.to_json()          # schema_version first, then where the table went
    write_json(with_checks({"schema_version": data.pop("schema_version"), "out": args.out,
                            **data}, checks), args.json)
    return 0 if result.n_failed == 0 else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``reanalyze`` sub-command and its options to ``sub``."""
    names = [m.name for m in methods.methods()]
    p = sub.add_parser("reanalyze", help="re-estimate many stored runs in parallel on Dask",
                       description="Re-estimate a candidate model on every level of many "
                       "stored runs, in parallel on Dask (docs/reanalysis.md).",
                       epilog="exit status: 0 all runs analysed, 1 some failed (table still "
                       "written), 2 bad input")
    p.add_argument("runs", nargs="+", metavar="RUN",
                   help="HDF5 runs / NPZ recordings, or directories holding them")
    p.add_argument("--model", required=True, help="candidate model TOML (unknown parameters "
                   "omitted)")
    p.add_argument("--method", choices=(*names, "auto"), default=names[0],
                   help="estimator (auto: the first one taking each level's excitation: "
                   "reverse path for random, hbm for stepped-sine levels)")
    p.add_argument("--workers", type=int, help="local process workers (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDR",
                   help="use the existing Dask cluster at tcp://host:port instead of a local one")
    p.add_argument("--out", metavar="RESULTS.h5",
                   help="write the HDF5 results table here (one row per run and level)")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    methods.add_batch_options(p)   # --band --nperseg --refine (reverse-path), --harmonics
    p.add_argument("--run-timeout", type=float, metavar="S",
                   help="time limit per run: a worker stuck longer on one run is restarted "
                   "and the run reported as failed")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--force", action="store_true",
                   help="replace existing --out / --json files (default: refuse)")
    add_quiet_option(p)
    p.set_defaults(func=run)
