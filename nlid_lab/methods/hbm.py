"""Harmonic balance fit (stepped sine): ``analyze hbm`` and its registry entry.

The JSON holds ``"estimator": "hbm"`` and the keys of docs/hbm.md (``method`` there is the
optimizer, as documented).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from analysis.errors import InputError

from .registry import ESTIMATOR_KEY, Method, option, register

if TYPE_CHECKING:
    from analysis.frf import LevelFRF
    from analysis.hbm_fit import FitResult, MeasuredReceptance
    from analysis.model import Model
    from analysis.recording import Recording
    from analysis.sine_fit import SteppedSineFRF

    from ..rundata import RunData, Section

NAME = "hbm"


@dataclass
class HbmOptions:
    """Settings of the harmonic-balance fit (``analyze hbm`` flags; harmonics also for
    ``reanalyze``)."""

    harmonics: str = option("--harmonics", default="1,3,5,7", batch=True,
                            help="comma-separated harmonic orders (default 1,3,5,7)")
    linear_from: str | None = option(
        "--linear-from", metavar="RUN",
        help="take the underlying linear FRF from this run instead of the model")
    optimizer: str = option("--optimizer", default="least-squares",
                            choices=("least-squares", "nelder-mead"))
    figure: str | None = option(
        "--figure", metavar="PNG", help="write measured vs fitted FRFs here (and the "
        "hysteresis loop to PNG's stem + '-loop.png')")
    starts: int = option("--starts", default=4, type=int, metavar="N",
                         help="multi-start count of the least-squares fit (default 4)")
    reference: str | None = option(
        "--reference", metavar="MODEL",
        help="reference model whose element loop is drawn next to the estimate")
    force_hold: str | None = option(
        "--force-hold", choices=("none", "linear"),
        help="how the applied force behaves between samples; scales each step's force "
        "amplitude by sinc^2(f/fs) for 'linear' (default: what the run declares; docs/hbm.md)")

    def __post_init__(self) -> None:
        from analysis.hbm import parse_harmonics
        parse_harmonics(self.harmonics)        # bad orders: InputError before any work


def _stepped(recs: Sequence[Recording], force_hold: str | None = None) -> list[Recording]:
    """The stepped-sine ``recs``; ``force_hold`` overrides what they declare."""
    bad = [rec.excitation for rec in recs if rec.excitation != "stepped-sine"]
    if bad:
        raise InputError(f"analyze hbm needs stepped-sine runs, got {bad[0]} data; use "
                         "analyze reverse-path for random excitation")
    if force_hold is not None:
        for rec in recs:
            rec.force_hold = force_hold
    return list(recs)


def linear_from_run(path: str, model: Model, harmonics: np.ndarray,
                    force_hold: str | None = None) -> MeasuredReceptance:
    """Underlying receptance from the highest-level stepped-sine run in ``path`` (paper 4.2:
    at high level a stick-slip joint slips throughout and the FRF is the linear one)."""
    from analysis.hbm_fit import MeasuredReceptance
    from analysis.sine_fit import stepped_sine_frf

    from ..recordings_io import load_recordings

    if model.n_dof != 1:
        raise InputError("--linear-from needs the full FRF matrix for more than one DOF; "
                         "take the underlying linear system from the model instead")
    frfs = [stepped_sine_frf(rec, harmonics[harmonics > 0])
            for rec in _stepped(load_recordings(path), force_hold)]
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


@dataclass
class HbmEstimate:
    """A harmonic-balance fit with what it was fitted to (the `Estimate` of this method)."""

    model: Model
    fit: FitResult
    levels: list[SteppedSineFRF]
    harmonics: np.ndarray
    receptance: MeasuredReceptance | None
    options: HbmOptions
    recordings: list[Recording]

    def to_json(self) -> dict[str, Any]:
        fit = self.fit
        return {ESTIMATOR_KEY: NAME, "elements": element_json(self.model, fit),
                "warnings": fit.warnings, "cost": fit.cost, "method": fit.method,
                "harmonics": self.harmonics.tolist(),
                "levels": [lv.level for lv in self.levels],
                "force_hold": [rec.force_hold for rec in self.recordings],   # per level
                "linear_from": self.options.linear_from or "model",
                "starts": fit.starts, "n_evaluations": fit.n_evaluations}

    def table(self) -> str:
        fit = self.fit
        lines = [f"harmonic balance fit ({fit.method}, harmonics {self.harmonics.tolist()}): "
                 f"{len(self.levels)} level(s), cost (eq 33) {fit.cost:.4g}, "
                 f"{fit.n_evaluations} evaluations",
                 f"{'element':>7}  {'kind':<12} {'param':<5} {'estimate':>12}  "
                 f"{'95 % interval':>27}"]
        for (e, name), value in fit.params.items():
            lo, hi = fit.ci95[(e, name)]
            lines.append(f"{e:>7}  {self.model.elements[e].kind:<12} {name:<5} "
                         f"{value:12.5g}  [{lo:12.5g}, {hi:12.5g}]")
        lines += [f"warning: {w}" for w in fit.warnings]
        return "\n".join(lines)

    def write_files(self) -> list[str]:
        if not self.options.figure:
            return []
        from analysis.model import Model
        reference = Model.load(self.options.reference) if self.options.reference else None
        return [str(p) for p in figures(self.fit, self.levels, self.harmonics,
                                        self.receptance, reference, Path(self.options.figure))]


def estimate(recs: Sequence[Recording], model: Model, options: HbmOptions | None = None
             ) -> HbmEstimate:
    """Fit the candidate's unknown parameters to all stepped-sine ``recs`` together."""
    from analysis.hbm import parse_harmonics
    from analysis.hbm_fit import fit_hbm
    from analysis.sine_fit import stepped_sine_frf

    options = options or HbmOptions()
    harmonics = parse_harmonics(options.harmonics)
    recs = _stepped(recs, options.force_hold)
    levels = [stepped_sine_frf(rec, harmonics[harmonics > 0]) for rec in recs]
    receptance = linear_from_run(options.linear_from, model, harmonics, options.force_hold) \
        if options.linear_from else None
    fit = fit_hbm(model, levels, harmonics, receptance=receptance, method=options.optimizer,
                  n_starts=options.starts)
    return HbmEstimate(model, fit, levels, harmonics, receptance, options, recs)


def figures(result: FitResult, levels: list[SteppedSineFRF], harmonics: np.ndarray,
            receptance, reference: Model | None, dest: Path) -> list[Path]:
    """Measured vs fitted FRFs per level (paper fig 4.8) to ``dest``; hysteresis loops of the
    estimated (and reference) elements (fig 4.7) to ``<dest stem>-loop.png``."""
    from matplotlib.figure import Figure

    from analysis.hbm import HBMSystem, loop

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


# --- report --------------------------------------------------------------------------------
def _estimated_elements(res: dict) -> list:
    from analysis.model import Element
    return [Element(e["kind"], np.asarray(e["w"], float), dict(e["params"]))
            for e in res.get("elements", []) if e.get("params")]


def report_sections(run: RunData, frfs: list[LevelFRF], found: tuple[str, dict] | None,
                    candidate: Model | None = None) -> list[Section]:
    """Hysteresis loops (fig 4.7) and measured vs estimated-model FRFs (fig 4.8) from the
    stored harmonic-balance result ``found``; the reference model of a simulated run is drawn
    for comparison."""
    from analysis.elements import KINDS
    from analysis.hbm import loop

    from .. import figures as report_figures
    from ..rundata import Section, reference_model

    if found is None:
        return []
    name, res = found
    est = _estimated_elements(res)
    ref = reference_model(run)
    out = []
    loops = {}
    for i, el in enumerate(est):
        if not KINDS[el.kind].memory:
            continue
        amp = _loop_amplitude(el, ref)
        loops[f"estimated {el.kind} (element {i})"] = loop(el.kind, el.params, amp)
        twin = _same_position(el, ref)
        if twin is not None:
            loops[f"reference {twin.kind}"] = loop(twin.kind, twin.params, amp)
    if loops:
        sec = Section("Hysteresis loop", f"Restoring force over one steady cycle of the "
                      f"estimated element (stored result '{name}') against the reference "
                      "element when the run holds its model (paper fig 4.7).")
        sec.figures.append(("hysteresis_loops", report_figures.hysteresis_loops(loops)))
        out.append(sec)
    stepped = [(f, r) for f, r in zip(frfs, run.recordings) if f.excitation == "stepped-sine"]
    if est and ref is not None and stepped:
        fitted = [_hbm_frf(ref.with_elements(est), f, r) for f, r in stepped]
        sec = Section("Measured vs estimated model", "Stepped-sine FRFs at every level "
                      "(markers) and the harmonic-balance FRFs of the estimated model (lines), "
                      "paper fig 4.8.")
        sec.figures = [(f"hbm_fit_out{q}", report_figures.fitted_frfs(
                           [f for f, _ in stepped], fitted, q))
                       for q in range(stepped[0][0].H.shape[1])]
        out.append(sec)
    return out


def _loop_amplitude(el, ref) -> float:
    """Deformation amplitude showing a full loop: three times the slip displacement fd/kd."""
    p = el.params
    if "kd" in p and "fd" in p and p["kd"] > 0:
        return 3.0 * p["fd"] / p["kd"]
    return 1e-3


def _same_position(el, ref):
    if ref is None:
        return None
    for other in ref.elements:
        if np.allclose(np.abs(other.w), np.abs(el.w)):
            return other
    return None


def _hbm_frf(model, frf: LevelFRF, rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """Fundamental FRF of ``model`` at the level's drive amplitude (same response kind)."""
    from analysis.hbm import HBMSystem
    from analysis.sine_fit import sine_fit

    amp = rec.level if rec.level else float(np.median(np.abs(
        [sine_fit(rec.force[i, :, 0], rec.fs, f)[0]
         for i, f in enumerate(rec.freqs)])))
    system = HBMSystem(model, force_dofs=rec.force_dofs[:1])
    sweep = system.sweep(rec.freqs, [amp])
    H = np.stack([sweep.frf(q, amp) for q in range(model.n_dof)], axis=1)
    jw = 2j * np.pi * rec.freqs[:, None]
    H = H * {"displacement": 1, "velocity": jw, "acceleration": jw ** 2}[rec.response_kind]
    return rec.freqs, H


def output_files(options: HbmOptions) -> list[str]:
    """``--figure`` and the loop figure beside it."""
    if not options.figure:
        return []
    dest = Path(options.figure)
    return [str(dest), str(dest.with_name(dest.stem + "-loop.png"))]


register(Method(NAME, "stepped sine: multi-harmonic balance fit", HbmOptions, "stepped-sine",
                estimate, sections=report_sections, legacy_keys=("elements", "cost"),
                output_files=output_files))
