"""``nlid-lab diagnose MODEL.toml RUN... --json OUT.json --model-out FIXED.toml``.

Locates the mismatch between a model and recordings, names and estimates the missing
physics and reports the fit before/after on a held-back level (docs/diagnose.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from analysis.diagnose import DiagnoseInputError, Diagnosis, diagnose
from analysis.model import Model


def _holdout(text: str) -> float | str:
    if text == "segment":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a level or 'segment'") from None


def register(sub: argparse._SubParsersAction) -> None:
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
                   help="write before/after FRF overlays (PNG) and report.md here")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from nlid_lab.cli import write_json
    from nlid_lab.store import load_recordings

    model = Model.load(args.model)
    recs = [r for path in args.runs for r in load_recordings(path)]
    period = None
    if args.period is not None:
        if args.period <= 0:
            raise DiagnoseInputError("--period must be a positive number of seconds")
        period = int(round(args.period * recs[0].fs))
    if args.nperseg is not None and args.nperseg < 16:
        raise DiagnoseInputError("--nperseg must be at least 16 samples")
    d = diagnose(model, recs, holdout=args.holdout,
                 band=tuple(args.band) if args.band else None, nperseg=args.nperseg,
                 period=period)
    if args.model_out:
        d.model.save(args.model_out)
    if args.report:
        write_report(d, Path(args.report))
    write_json(d.to_json(), args.json)
    if not args.json:
        print(f"{d.verdict}: {d.explanation}")
    return 0


def write_report(d: Diagnosis, out: Path) -> None:
    """Before/after FRF overlays per level and DOF, plus a short markdown report."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    out.mkdir(parents=True, exist_ok=True)
    lines = ["# Model-mismatch diagnosis", "", f"**Verdict:** {d.verdict}", "",
             d.explanation, "", "| level | held back | error before | error after |",
             "|---|---|---|---|"]
    for i, c in enumerate(d.curves):
        lines.append(f"| {c.level:g} | {'yes' if c.held_back else 'no'} | "
                     f"{c.error_before:.4g} | {c.error_after:.4g} |")
        n_dof = c.measured.shape[1]
        fig, axes = plt.subplots(n_dof, 1, figsize=(7, 2.2 * n_dof), sharex=True,
                                 squeeze=False)
        for dof, ax in enumerate(axes[:, 0]):
            ax.semilogy(c.freqs, np.abs(c.measured[:, dof, 0]), "k", lw=1.2, label="measured")
            ax.semilogy(c.freqs, np.abs(c.before[:, dof, 0]), "C3--", lw=1, label="model before")
            ax.semilogy(c.freqs, np.abs(c.after[:, dof, 0]), "C0", lw=1, label="model after")
            ax.set_ylabel(f"|H| DOF {dof} (m/N)")
        axes[0, 0].set_title(f"{c.label}{' (held back)' if c.held_back else ''}")
        axes[0, 0].legend(fontsize=8)
        axes[-1, 0].set_xlabel("frequency (Hz)")
        fig.tight_layout()
        name = f"frf-level-{i}.png"
        fig.savefig(out / name, dpi=90)
        plt.close(fig)
        lines.append("")
        lines.append(f"![{c.label}]({name})")
    lines += ["", "## Candidate ranking", "", "| kind | DOFs | params | BIC gain |", "|---|---|---|---|"]
    for r in d.ranking:
        params = ", ".join(f"{k}={v:.4g}" for k, v in r["params"].items())
        lines.append(f"| {r['kind']} | {r['dofs']} | {params} | {r['delta_bic']:.4g} |")
    (out / "report.md").write_text("\n".join(lines) + "\n")
