"""``nlid-lab analyze reverse-path|hbm RUN... --model CANDIDATE.toml --json OUT.json``."""

from __future__ import annotations

import argparse
import importlib
from pathlib import Path

from ..outputs import add_force_option, refuse_overwrite


def _delegate(module: str):
    def run(args: argparse.Namespace) -> int:
        figure = getattr(args, "figure", None)
        loop_png = Path(figure).with_name(Path(figure).stem + "-loop.png") if figure else None
        refuse_overwrite(args.force, args.json, figure, loop_png)
        return importlib.import_module(f"nlid_lab.{module}").run(args)
    return run


def _store_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--store", metavar="RUN.h5",
                   help="also save the result into this HDF5 run (as 'analyze-<method>'), where "
                   "`nlid-lab report` and `view` show it (earlier results stay in the run's "
                   "log, the latest is shown)")
    add_force_option(p)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("analyze", help="estimate nonlinear parameters from stored runs")
    kinds = p.add_subparsers(dest="method", metavar="METHOD")
    kinds.required = True

    rp = kinds.add_parser("reverse-path", help="random excitation: reverse path / NIFO")
    rp.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs or NPZ recordings")
    rp.add_argument("--model", required=True, help="candidate model TOML (unknown parameters "
                    "omitted)")
    rp.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    rp.add_argument("--band", type=float, nargs=2, metavar=("LO", "HI"),
                    help="analysis band in Hz (default: chosen from coherence and excitation)")
    rp.add_argument("--nperseg", type=int, help="Welch segment length in samples")
    rp.add_argument("--force-hold", choices=("none", "linear"),
                    help="how the applied force behaves between samples: 'linear' for a "
                    "first-order-hold drive such as the simulated plant's, 'none' for a force "
                    "transducer behind an anti-alias filter (default: what the run declares, "
                    "else none)")
    rp.add_argument("--screen", action="store_true",
                    help="also rank the candidate basis library by conditioned coherence")
    rp.add_argument("--refine", choices=("joint", "sequential"), default="joint",
                    help="'sequential': re-estimate each coefficient with the elements on "
                    "forced DOFs fixed at their joint estimates (narrower intervals when two "
                    "bases share a deformation, e.g. v|v| next to x^3; docs/reverse-path.md)")
    _store_option(rp)
    rp.set_defaults(func=_delegate("analyze_reverse_path"))

    hb = kinds.add_parser("hbm", help="stepped sine: multi-harmonic balance fit")
    hb.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs or NPZ recordings")
    hb.add_argument("--model", required=True, help="candidate model TOML")
    hb.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    hb.add_argument("--harmonics", default="1,3,5,7",
                    help="comma-separated harmonic orders (default 1,3,5,7)")
    hb.add_argument("--linear-from", metavar="RUN",
                    help="take the underlying linear FRF from this run instead of the model")
    hb.add_argument("--optimizer", choices=("least-squares", "nelder-mead"),
                    default="least-squares")
    hb.add_argument("--figure", metavar="PNG", help="write measured vs fitted FRFs here (and "
                    "the hysteresis loop to PNG's stem + '-loop.png')")
    hb.add_argument("--starts", type=int, default=4, metavar="N",
                    help="multi-start count of the least-squares fit (default 4)")
    hb.add_argument("--reference", metavar="MODEL",
                    help="reference model whose element loop is drawn next to the estimate")
    _store_option(hb)
    hb.set_defaults(func=_delegate("analyze_hbm"))
