"""``nlid-lab analyze reverse-path``: load runs, estimate, print a table, write JSON."""

from __future__ import annotations

import argparse

from analysis.errors import InputError
from analysis.model import Model
from analysis.reverse_path import reverse_path

from .cli import write_json
from .store import load_recordings


def run(args: argparse.Namespace) -> int:
    if getattr(args, "screen", False):
        raise InputError("--screen (candidate ranking) is not available yet; run without it")
    model = Model.load(args.model)
    recs = [rec for path in args.runs for rec in load_recordings(path)]
    result = reverse_path(recs, model, band=tuple(args.band) if args.band else None,
                          nperseg=args.nperseg)
    print(f"reverse path: {len(recs)} record(s), band {result.band[0]:.1f}-"
          f"{result.band[1]:.1f} Hz, min multiple coherence "
          f"{result.coherence_nonlinear.min():.4f} (linear only "
          f"{result.coherence_linear.min():.4f})")
    print(f"{'element':>7}  {'kind':<18} {'param':<5} {'estimate':>12}  {'95 % interval':>27}")
    for c in result.coefficients:
        print(f"{c.element:>7}  {c.kind:<18} {c.param:<5} {c.value:12.5g}  "
              f"[{c.ci95[0]:12.5g}, {c.ci95[1]:12.5g}]")
    for w in result.warnings:
        print(f"warning: {w}")
    write_json(result.to_json(), args.json)
    return 0
