"""``nlid-lab diagnose MODEL.toml RUN... --json OUT.json --model-out FIXED.toml``.

Locates the mismatch between a model and recordings, names and estimates the missing
physics and reports the fit before/after on a held-back level (docs/diagnose.md);
``--report DIR`` writes FRF overlays and time residuals, ``--store RUN.h5`` saves the result
into a run for ``nlid-lab report``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..outputs import (add_quiet_option, atomic_dir, atomic_path, refuse_overwrite,
                       summary_stream, with_checks, write_json)
from .repair import check_runs

if TYPE_CHECKING:
    from analysis.diagnose import Diagnosis, LocationRow


def _holdout(text: str) -> float | str:
    if text == "segment":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a level or 'segment'") from None


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``diagnose`` subcommand and its options."""
    p = sub.add_parser("diagnose", help="find what a model lacks to explain recordings")
    p.add_argument("model", metavar="MODEL.toml", help="starting model (complete)")
    p.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs, NPZ or CSV recordings "
                   "(one level each, or runs holding several levels)")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    p.add_argument("--model-out", metavar="FIXED.toml", help="write the corrected model here")
    p.add_argument("--holdout", type=_holdout, metavar="LEVEL",
                   help="level held back from fitting, or 'segment' (default: middle level)")
    p.add_argument("--band", type=float, nargs=2, metavar=("LO", "HI"),
                   help="analysis band in Hz (default: the excited band)")
    p.add_argument("--nperseg", type=int, help="Welch segment length in samples")
    p.add_argument("--period", type=float, metavar="SECONDS",
                   help="period of a periodic (multisine) drive: transients dropped, periods "
                   "averaged")
    p.add_argument("--report", metavar="DIR",
                   help="write before/after FRF overlays and time residuals (PNG) and "
                   "report.md here")
    p.add_argument("--store", metavar="RUN.h5",
                   help="also save the result into this HDF5 run (shown by 'nlid-lab report')")
    p.add_argument("--force", action="store_true",
                   help="replace existing --json / --model-out files and write into a "
                   "non-empty --report directory (default: refuse)")
    add_quiet_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Diagnose the runs against the model; write JSON, corrected model and report."""
    from analysis.diagnose import RESULT_NAME, DiagnoseInputError, diagnose
    from analysis.models import Model
    from analysis.recordings import Excitation, at_points, model_at_sensors, one_kind

    from nlid_lab.progress import progress
    from nlid_lab.formats import load_recordings
    from nlid_lab.store import open_run, save_result

    refuse_overwrite(args.force, args.json, args.model_out, directories=(args.report,))
    if args.store:
        if Path(args.store).suffix.lower() not in (".h5", ".hdf5"):
            raise DiagnoseInputError(f"--store {args.store}: the result can only be stored in "
                                     "an HDF5 run (.h5); pass one of the runs")
        open_run(args.store)     # fails early (exit 2) when it is not a run file
    model = Model.load(args.model)
    checks = check_runs(args.runs)
    recs = [one_kind(r) for path in args.runs for r in load_recordings(path)]
    if any(r.excitation == Excitation.SWEPT_SINE for r in recs):
        raise DiagnoseInputError("diagnose takes random, multisine or stepped-sine runs, "
                                 "not swept sine; test a sweep with `nlid-lab detect` and "
                                 "fit it with `nlid-lab analyze hbm`")
    full, model = model, model_at_sensors(model, recs, "diagnose (it compares the model with "
                                          "the data at the measured points)")
    period = None
    if args.period is not None:
        if args.period <= 0:
            raise DiagnoseInputError("--period must be a positive number of seconds")
        period = int(round(args.period * recs[0].fs))
    if args.nperseg is not None and args.nperseg < 16:
        raise DiagnoseInputError("--nperseg must be at least 16 samples")
    with progress(total=1, desc="diagnose", unit="step") as bar:
        d = diagnose(model, recs, holdout=args.holdout,
                     band=tuple(args.band) if args.band else None, nperseg=args.nperseg,
                     period=period, progress=lambda done, total, stage: _show(bar, done, total,
                                                                              stage))
    if args.model_out:
        with atomic_path(args.model_out) as tmp:
            at_points(d.model, full).save(tmp)
    if args.report:
        with atomic_dir(args.report) as tmp:
            write_report(d, tmp)
    result = with_checks(d.to_json(), checks)   # stored too: which blocks it used
    if args.store:
        save_result(args.store, RESULT_NAME, result)
    write_json(result, args.json)
    stream = summary_stream(args.json, args.quiet)
    print(f"{d.verdict}: {d.explanation}", file=stream)
    rows = d.evidence.locations or ()
    if rows:
        print("\nwhere (best candidate per location, first search pass):", file=stream)
        for r in rows[:5]:
            print(f"  {' - '.join(r.points):<24} {r.kind:<18} misfit -"
                  f"{100 * r.chi2_reduction:.3g} %, BIC {r.delta_bic:+.3g}{_beside(r)}",
                  file=stream)
    return 0


def _beside(r: LocationRow) -> str:
    """A location row's other side: a pair's relative motion and best grounded end, a
    point's best joint (support and joint shown side by side)."""
    end, joint = r.best_grounded_end, r.best_joint
    if end is not None:
        return (f"; relative motion {100 * r.relative_motion:.2g} %; grounded at "
                f"{end.points[0]} alone: {100 * end.chi2_reduction:.3g} %")
    if joint is not None:
        return (f"; best joint {' - '.join(joint.points)} ({joint.kind}, relative motion "
                f"{100 * joint.relative_motion:.2g} %): {100 * joint.chi2_reduction:.3g} %")
    return ""


def _show(bar, done: int, total: int, stage: str) -> None:
    """Move the progress bar to ``done`` of ``total`` steps, naming the stage."""
    bar.total = total
    bar.n = done
    bar.set_postfix_str(stage)


def write_report(d: Diagnosis, out: Path) -> None:
    """Before/after FRF overlays and time residuals per level, plus a markdown report."""
    from ..reports import diagnosis_overlay

    out.mkdir(parents=True, exist_ok=True)
    lines = ["# Model-mismatch diagnosis", "", f"**Verdict:** {d.verdict}", "",
             d.explanation, "", "| level | held back | FRF error before | FRF error after | "
             "floor | time residual before | time residual after |",
             "|---|---|---|---|---|---|---|"]
    figs = []
    for i, c in enumerate(d.curves):
        res = c.residuals()
        tb, ta = ((f"{np.mean(res.time_before):.4g}", f"{np.mean(res.time_after):.4g}")
                  if res.time_before is not None else ("-", "-"))
        lines.append(f"| {c.level:g} | {'yes' if c.held_back else 'no'} | "
                     f"{c.error_before:.4g} | {c.error_after:.4g} | "
                     f"{f'{c.floor.limit:.4g}' if c.floor else '-'} | {tb} | {ta} |")
        title = f"{c.label}{' (held back)' if c.held_back else ''}"
        name = f"frf-level-{i}.png"
        diagnosis_overlay(c, title).savefig(out / name)
        figs += ["", f"![{c.label}]({name})"]
    lines += figs
    lines += ["", "## Where", "", "| location | best kind | misfit reduction | BIC gain | "
              "beside it (a pair's relative motion and grounded end, a point's best joint) |",
              "|---|---|---|---|---|"]
    for r in d.evidence.locations or ():
        lines.append(f"| {' - '.join(r.points)} | {r.kind} | "
                     f"{100 * r.chi2_reduction:.3g} % | {r.delta_bic:.4g} | "
                     f"{_beside(r).removeprefix('; ') or '-'} |")
    lines += ["", "## Candidate ranking", "", "| kind | DOFs | params | BIC gain |",
              "|---|---|---|---|"]
    for r in d.ranking:
        params = ", ".join(f"{k}={v:.4g}" for k, v in r.params.items())
        lines.append(f"| {r.kind} | {list(r.dofs)} | {params} | {r.delta_bic:.4g} |")
    (out / "report.md").write_text("\n".join(lines) + "\n")
