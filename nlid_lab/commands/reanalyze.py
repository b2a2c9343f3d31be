"""``nlid-lab reanalyze RUN... --model CANDIDATE.toml [--out RESULTS.h5]`` on Dask.

Exit codes: 0 every run analysed; 1 some runs or levels failed (the table is still written
and names each failure); 2 bad input (model, paths, method, scheduler address).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def run(args: argparse.Namespace) -> int:
    from analysis.hbm import parse_harmonics
    from analysis.model import Model
    from nlid_lab.outputs import refuse_overwrite, write_json
    from nlid_lab.reanalyze import (ReanalysisError, check_request, dask_client,
                                    expand_runs, reanalyze, write_results)

    refuse_overwrite(args.force, args.out, args.json)
    model = Model.load(args.model)  # bad input: exit 2 before any cluster starts
    check_request(model, args.method, args.run_timeout)
    if args.harmonics:
        parse_harmonics(args.harmonics)
    runs = expand_runs(args.runs)
    if args.out and not Path(args.out).resolve().parent.is_dir():
        raise ReanalysisError(f"--out {args.out}: its directory does not exist; create it "
                              "first (checked before the runs are analysed)")
    options = {"band": tuple(args.band) if args.band else None, "nperseg": args.nperseg,
               "refine": args.refine, "harmonics": args.harmonics}
    with dask_client(args.workers, args.scheduler) as client:
        result = reanalyze(runs, model, client, args.method, options,
                           progress=not args.no_progress, run_timeout_s=args.run_timeout)
    to = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON then
    print(result.summary(), file=to)
    if args.out:
        write_results(result, args.out)
        print(f"results: {args.out}", file=to)
    write_json({"out": args.out, **result.to_json()}, args.json)
    return 0 if result.n_failed == 0 else 1


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("reanalyze", help="re-estimate many stored runs in parallel on Dask",
                       description="Re-estimate a candidate model on every level of many "
                       "stored runs, in parallel on Dask (docs/reanalysis.md).",
                       epilog="exit status: 0 all runs analysed, 1 some failed (table still "
                       "written), 2 bad input")
    p.add_argument("runs", nargs="+", metavar="RUN",
                   help="HDF5 runs / NPZ recordings, or directories holding them")
    p.add_argument("--model", required=True, help="candidate model TOML (unknown parameters "
                   "omitted)")
    p.add_argument("--method", choices=("reverse-path", "hbm", "auto"), default="reverse-path",
                   help="estimator (auto: reverse path for random, hbm for stepped-sine levels)")
    p.add_argument("--workers", type=int, help="local process workers (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDR",
                   help="use the existing Dask cluster at tcp://host:port instead of a local one")
    p.add_argument("--out", metavar="RESULTS.h5",
                   help="write the HDF5 results table here (one row per run and level)")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--band", type=float, nargs=2, metavar=("LO", "HI"),
                   help="reverse path analysis band in Hz")
    p.add_argument("--nperseg", type=int, help="reverse path Welch segment length")
    p.add_argument("--refine", choices=("joint", "sequential"),
                   help="reverse path: 'sequential' re-estimates each coefficient with the "
                   "others fixed (see `analyze reverse-path --refine`)")
    p.add_argument("--harmonics", help="hbm harmonic orders, e.g. 1,3,5,7")
    p.add_argument("--run-timeout", type=float, metavar="S",
                   help="time limit per run: a worker stuck longer on one run is restarted "
                   "and the run reported as failed")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    p.add_argument("--force", action="store_true",
                   help="replace existing --out / --json files (default: refuse)")
    p.set_defaults(func=run)
