"""``nlid-lab analyze hbm``: stepped-sine runs -> harmonic-balance fit -> table, JSON, figures."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from analysis.errors import InputError
from analysis.hbm import HBMSystem, loop, parse_harmonics
from analysis.hbm_fit import FitResult, MeasuredReceptance, fit_hbm
from analysis.model import Model
from analysis.recording import Recording
from analysis.sine_fit import SteppedSineFRF, stepped_sine_frf

from .outputs import write_json
from .store import check_result_target, load_recordings, save_result


def _stepped(paths: list[str]) -> list[Recording]:
    recs = [rec for path in paths for rec in load_recordings(path)]
    bad = [rec.excitation for rec in recs if rec.excitation != "stepped-sine"]
    if bad:
        raise InputError(f"analyze hbm needs stepped-sine runs, got {bad[0]} data; use "
                         "analyze reverse-path for random excitation")
    return recs


def linear_from_run(path: str, model: Model, harmonics: np.ndarray) -> MeasuredReceptance:
    """Underlying receptance from the highest-level stepped-sine run in ``path`` (paper 4.2:
    at high level a stick-slip joint slips throughout and the FRF is the linear one)."""
    if model.n_dof != 1:
        raise InputError("--linear-from needs the full FRF matrix for more than one DOF; "
                         "take the underlying linear system from the model instead")
    frfs = [stepped_sine_frf(rec, harmonics[harmonics > 0]) for rec in _stepped([path])]
    top = max(frfs, key=lambda lv: lv.level)
    order = np.argsort(top.freqs)
    return MeasuredReceptance(top.freqs[order], top.frf[order, 0])


def element_json(model: Model, result: FitResult) -> list[dict]:
    out = []
    for e, el in enumerate(result.model.elements):
        ci = {name: list(result.ci95[(e, name)]) for (i, name) in result.ci95 if i == e}
        out.append({"kind": el.kind, "w": el.w.tolist(), "params": dict(el.params),
                    "ci95": ci, "estimated": sorted(ci)})
    return out


def run(args: argparse.Namespace) -> int:
    if getattr(args, "store", None):
        check_result_target(args.store)      # before the work: a bad target exits 2 at once
    model = Model.load(args.model)
    harmonics = parse_harmonics(args.harmonics)
    levels = [stepped_sine_frf(rec, harmonics[harmonics > 0]) for rec in _stepped(args.runs)]
    receptance = linear_from_run(args.linear_from, model, harmonics) if args.linear_from \
        else None
    result = fit_hbm(model, levels, harmonics, receptance=receptance, method=args.optimizer,
                     n_starts=args.starts)
    print(f"harmonic balance fit ({result.method}, harmonics {harmonics.tolist()}): "
          f"{len(levels)} level(s), cost (eq 33) {result.cost:.4g}, "
          f"{result.n_evaluations} evaluations")
    print(f"{'element':>7}  {'kind':<12} {'param':<5} {'estimate':>12}  {'95 % interval':>27}")
    for (e, name), value in result.params.items():
        lo, hi = result.ci95[(e, name)]
        print(f"{e:>7}  {model.elements[e].kind:<12} {name:<5} {value:12.5g}  "
              f"[{lo:12.5g}, {hi:12.5g}]")
    for w in result.warnings:
        print(f"warning: {w}")
    out = {"elements": element_json(model, result), "warnings": result.warnings,
           "cost": result.cost, "method": result.method,
           "harmonics": harmonics.tolist(),
           "levels": [lv.level for lv in levels],
           "linear_from": args.linear_from or "model",
           "starts": result.starts, "n_evaluations": result.n_evaluations}
    write_json(out, args.json)
    if getattr(args, "store", None):
        save_result(args.store, "analyze-hbm", out)
    if args.figure:
        reference = Model.load(args.reference) if args.reference else None
        figures(result, levels, harmonics, receptance, reference, Path(args.figure))
    return 0


def figures(result: FitResult, levels: list[SteppedSineFRF], harmonics: np.ndarray,
            receptance, reference: Model | None, dest: Path) -> list[Path]:
    """Measured vs fitted FRFs per level (paper fig 4.8) to ``dest``; hysteresis loops of the
    estimated (and reference) elements (fig 4.7) to ``<dest stem>-loop.png``."""
    system = HBMSystem(result.model, [levels[0].force_dof], harmonics, receptance=receptance)
    fig = Figure(figsize=(8, 6), layout="constrained")
    mag, ph = fig.subplots(2, 1, sharex=True)
    amp = 0.0
    for lv, colour in zip(levels, _colours(len(levels))):
        order = np.argsort(lv.freqs)
        res = system.sweep(lv.freqs, lv.force[:, None])
        h = res.frf(lv.force_dof, 1.0) / lv.force
        amp = max(amp, float(np.abs(res.U[:, 0]).max()) if res.U.size else 0.0)
        f, hm = lv.freqs[order], lv.frf[order, lv.force_dof]
        mag.semilogy(f, np.abs(hm), "o", ms=3, color=colour, label=f"{lv.level:g} N")
        mag.semilogy(f, np.abs(h[order]), "-", color=colour)
        ph.plot(f, np.degrees(np.angle(hm)), "o", ms=3, color=colour)
        ph.plot(f, np.degrees(np.angle(h[order])), "-", color=colour)
    mag.set_title("Measured (markers) vs fitted harmonic balance (lines)")
    mag.set_ylabel("|X1/F| [m/N]")
    ph.set_ylabel("phase [deg]")
    ph.set_xlabel("frequency [Hz]")
    mag.legend(title="force level", fontsize="small")
    dest.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(dest, dpi=110)
    written = [dest]
    loops = {}
    for label, model in (("estimated", result.model), ("reference", reference)):
        for e, el in enumerate(model.elements if model else []):
            loops[f"{label} element {e} ({el.kind})"] = loop(el.kind, el.params, amp)
    if loops and amp > 0:
        fig = Figure(figsize=(6.4, 5), layout="constrained")
        ax = fig.subplots()
        for (label, (u, g)), style in zip(loops.items(), ["-", "--", ":", "-."] * 4):
            ax.plot(u, g, style, label=label)
        ax.set_xlabel("deformation u [m]")
        ax.set_ylabel("restoring force g [N]")
        ax.set_title("Hysteresis loop at the largest fitted amplitude")
        ax.legend(fontsize="small")
        loop_path = dest.with_name(dest.stem + "-loop.png")
        fig.savefig(loop_path, dpi=110)
        written.append(loop_path)
    return written


def _colours(n: int):
    from matplotlib import colormaps
    return [colormaps["viridis"](x) for x in np.linspace(0.0, 0.85, max(n, 1))]
