"""``nlid-lab predict MODEL.toml --force-dof D --amplitude A... --band LO HI``: what the
model predicts a sine test shows, through the folds (harmonic balance + arc-length continuation).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from analysis.errors import InputError

from ..outputs import (add_force_option, add_quiet_option, atomic_path, refuse_overwrite,
                       summary_stream, write_json)

if TYPE_CHECKING:
    from analysis.hbm import Branch


def _curve(branch: Branch, amplitude: float, f_end: float, dofs: list[int]) -> dict[str, Any]:
    reached = bool((branch.freqs[-1] - f_end) * np.sign(f_end - branch.freqs[0]) >= 0)
    return {
        "force_amplitude": amplitude,
        "freqs": branch.freqs,
        "amplitude": {str(d): branch.amplitude(d) for d in dofs},
        "stable": branch.stable,
        "folds": [{"freq": float(branch.freqs[i]),
                   "amplitude": {str(d): float(branch.amplitude(d)[i]) for d in dofs}}
                  for i in branch.folds],
        "complete": reached,
    }


def _summary(curves: list[dict[str, Any]], dof: int) -> str:
    lines = []
    for c in curves:
        amp = np.asarray(c["amplitude"][str(dof)])
        peak = int(np.argmax(amp))
        text = (f"{c['force_amplitude']:g} N: peak {amp[peak]:.4g} m at "
                f"{c['freqs'][peak]:.3f} Hz (DOF {dof})")
        if c["folds"]:
            text += "; folds at " + ", ".join(f"{f['freq']:.3f}" for f in c["folds"]) + " Hz" \
                    " (jump between them in a sweep; the branch between is unstable)"
        if not c["complete"]:
            text += f"; stopped at {c['freqs'][-1]:.3f} Hz (continuation step underflow)"
        lines.append(text)
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab predict`` on the parsed ``args``; returns the exit code."""
    from analysis.hbm import response_curves
    from analysis.hbm import HBMSystem
    from analysis.models import Model

    lo, hi = args.band
    if not (0 < lo and 0 < hi and lo != hi):
        raise InputError(f"--band {lo:g} {hi:g}: give two different positive frequencies (Hz)")
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise InputError(f"--plot {args.plot}: the figure is written as PNG; name it *.png")
    refuse_overwrite(args.force, args.plot, args.json)
    model = Model.load(args.model)
    model.require_complete("a prediction")
    dofs = args.dof if args.dof is not None else list(range(model.n_dof))
    bad = [d for d in dofs + [args.force_dof] if not 0 <= d < model.n_dof]
    if bad:
        raise InputError(f"DOF {bad[0]} outside the model's DOFs 0..{model.n_dof - 1} "
                         "(0-based)")
    system = HBMSystem(model, [args.force_dof], args.harmonics)
    branches = response_curves(system, lo, hi, args.amplitude)
    curves = [_curve(b, a, hi, dofs) for b, a in zip(branches, args.amplitude)]
    result = {"model": model.name, "force_dof": args.force_dof,
              "harmonics": system.harmonics, "band_hz": [lo, hi], "curves": curves}
    shown = dofs[0] if args.dof is not None else args.force_dof
    out = summary_stream(args.json, args.quiet)
    print(_summary(curves, shown), file=out)
    if args.plot:
        from ..reports import response_curves as figure
        with atomic_path(args.plot) as tmp:
            figure(branches, args.amplitude, shown, model.name, (lo, hi)).savefig(tmp)
        print(f"figure: {args.plot}", file=out)
    write_json(result, args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``predict`` sub-command and its options to ``sub``."""
    p = sub.add_parser("predict", help="model's forced-response curves through folds, with "
                       "stability (harmonic balance + continuation)")
    p.add_argument("model", metavar="MODEL.toml", help="complete model (every parameter given)")
    p.add_argument("--force-dof", type=int, default=0, help="DOF of the sine force (default 0)")
    p.add_argument("--amplitude", type=float, nargs="+", required=True, metavar="N",
                   help="force amplitude(s), N: one curve each")
    p.add_argument("--band", type=float, nargs=2, required=True, metavar=("LO", "HI"),
                   help="sweep from LO to HI Hz (start off resonance, on a stable branch)")
    p.add_argument("--dof", type=int, nargs="+", help="response DOFs to report (default all)")
    p.add_argument("--harmonics", default="1,3,5,7", help="harmonic orders (default 1,3,5,7)")
    p.add_argument("--plot", metavar="FILE.png", help="draw the curves (unstable dashed)")
    p.add_argument("--json", metavar="FILE", help="write the curves as JSON ('-' for stdout)")
    add_force_option(p)
    add_quiet_option(p)
    p.set_defaults(func=run)
