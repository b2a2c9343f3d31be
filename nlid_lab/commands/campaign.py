"""``nlid-lab campaign run CAMPAIGN.toml --out RUN.h5 [--resume]`` and ``campaign check``."""

from __future__ import annotations

import argparse
import sys


def _run(args: argparse.Namespace) -> int:
    from ..campaign import run_campaign
    from ..campaign_config import load_campaign
    from ..cli import write_json

    campaign = load_campaign(args.campaign)
    result = run_campaign(campaign, args.out, resume=args.resume)
    write_json(result.as_dict(), args.json)
    lost = (f", lost {result.lost_samples} samples in {result.lost_frames} frames (counted in "
            "the run)" if result.lost_samples or result.lost_frames else "")
    print(f"campaign '{campaign.name}' {result.status}: "
          f"{sum(result.segments.values())} {'blocks' if campaign.kind == 'random' else 'steps'}"
          f" in {len(result.segments)} level(s) -> {args.out}{lost}", file=sys.stderr)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    return 0


def _check(args: argparse.Namespace) -> int:
    from ..campaign_config import load_campaign

    c = load_campaign(args.campaign)
    n = c.plan.averages if c.kind == "random" else len(c.plan.freqs)
    print(f"{args.campaign}: valid {c.kind} campaign, {len(c.levels)} level(s) x {n} "
          f"{'blocks' if c.kind == 'random' else 'steps'}, shaker {c.shaker_url}, "
          f"DAQ {c.daq_url}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("campaign", help="run a test campaign (shaker + DAQ -> HDF5 run)")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    run = actions.add_parser("run", help="run a campaign file")
    run.add_argument("campaign", metavar="CAMPAIGN.toml")
    run.add_argument("--out", required=True, metavar="RUN.h5", help="run file to write")
    run.add_argument("--resume", action="store_true",
                     help="continue an interrupted run at its first incomplete block/step")
    run.add_argument("--json", metavar="FILE", help="write the summary as JSON ('-': stdout)")
    run.set_defaults(func=_run)
    check = actions.add_parser("check", help="validate a campaign file without running it")
    check.add_argument("campaign", metavar="CAMPAIGN.toml")
    check.set_defaults(func=_check)
