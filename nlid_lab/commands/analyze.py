"""``nlid-lab analyze METHOD RUN... --model CANDIDATE.toml --json OUT.json``.

One sub-command per registered method (`nlid_lab.methods`), with that method's options.
"""

from __future__ import annotations

import argparse

from .. import methods
from ..outputs import (add_force_option, add_quiet_option, refuse_overwrite, summary_stream,
                       with_checks, write_json)
from .repair import check_runs


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab analyze`` on the parsed ``args``; returns the exit code."""
    from analysis.errors import InputError
    from analysis.models import Model
    from analysis.recordings import model_at_sensors, one_kind

    from ..formats import load_recordings
    from ..store import check_result_target, save_result

    method = methods.get(args.method)
    options = method.make_options(args)
    files = method.output_files(options) if method.output_files else []
    refuse_overwrite(args.force, args.json, *files)
    if args.store:
        check_result_target(args.store)      # before the work: a bad target exits 2 at once
    model = Model.load(args.model)
    if args.store and all(el.known for el in model.elements):
        raise InputError(f"--store saves estimated parameters but {args.model} has none to "
                         "estimate; drop --store (screening results go to --json)")
    checks = check_runs(args.runs)
    recs = [one_kind(rec) for path in args.runs for rec in load_recordings(path)]
    # the model at the measured points, in channel order (sensor maps, analysis.sensors)
    model = model_at_sensors(model, recs, f"analyze {args.method} (it forms each unknown "
                             "element's basis from the measured responses)")
    estimate = method.estimate(recs, model, options)
    out = with_checks(estimate.to_json(), checks)   # stored too: which blocks it used
    # with --json - the table goes to stderr so stdout stays pure JSON
    print(estimate.table(), file=summary_stream(args.json, args.quiet))
    write_json(out, args.json)
    if args.store:
        save_result(args.store, method.result_name, out)
    estimate.write_files()
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``analyze`` sub-command and its options to ``sub``."""

    p = sub.add_parser("analyze", help="estimate nonlinear parameters from stored runs")
    kinds = p.add_subparsers(dest="method", metavar="METHOD")
    kinds.required = True
    for method in methods.methods():
        mp = kinds.add_parser(method.name, help=method.help)
        mp.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs or NPZ recordings")
        mp.add_argument("--model", required=True, help="candidate model TOML (unknown "
                        "parameters omitted)")
        mp.add_argument("--json", metavar="FILE",
                        help="write the result as JSON ('-' for stdout)")
        methods.add_options(mp, method)
        mp.add_argument("--store", metavar="RUN.h5",
                        help="also save the result into this HDF5 run (as "
                        f"'{method.result_name}'), where `nlid-lab report` and `view` show it "
                        "(earlier results stay in the run's log, the latest is shown)")
        add_force_option(mp)
        add_quiet_option(mp)
        mp.set_defaults(func=run)
