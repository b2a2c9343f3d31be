"""Harmonic balance fit (stepped sine): ``analyze hbm`` and its registry entry.

The JSON holds ``"estimator": "hbm"`` and the keys of docs/hbm.md (``method`` there is the
optimizer, as documented).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from analysis.documents import JsonObject
from analysis.errors import InputError
from analysis.recordings import Excitation, StepTable

from ..outputs import atomic_path
from ._registry import ESTIMATOR_KEY, Method, StoredEstimate, StoredResult, option, register

if TYPE_CHECKING:
    from analysis.spectral import LevelFRF
    from analysis.hbm import FitResult, MeasuredReceptance
    from analysis.models import Model
    from analysis.recordings import Recording
    from analysis.spectral import SteppedSineFRF

    from ..reports import RunData, Section

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
    bad = [rec.excitation for rec in recs
           if rec.excitation not in (Excitation.STEPPED_SINE, Excitation.SWEPT_SINE)]
    if bad:
        raise InputError(f"analyze hbm needs stepped- or swept-sine runs, got {bad[0]} data; "
                         "use analyze reverse-path for random excitation")
    if force_hold is not None:
        for rec in recs:
            if isinstance(rec, StepTable) and force_hold != "none":
                raise InputError("--force-hold: a stepped-sine table's force phasors are the "
                                 "force that acted; drop the option for table runs")
            if not isinstance(rec, StepTable):
                rec.force_hold = force_hold
    return list(recs)


def _sweep_points(rec: Recording, model: Model, harmonics: np.ndarray):
    """A swept-sine level as stepped-sine points: the tracked harmonics where the sweep is
    quasi-steady for the model's modes (`analysis.spectral.quasi_steady`), and the warnings of
    the sweep-rate check."""
    from analysis.spectral import linear_modes, quasi_steady, recording_sweep_frf

    frf = recording_sweep_frf(rec, harmonics=[int(h) for h in harmonics])
    modes = linear_modes(model.mass, model.damping, model.stiffness)
    direction = "up" if rec.sweep.law.direction > 0 else "down"
    points, said = quasi_steady(frf, rec.sweep.law, modes)
    return points, [f"level {rec.level:.3g} N sweep {direction}: {w}" for w in said]


def linear_from_run(path: str, model: Model, harmonics: np.ndarray,
                    force_hold: str | None = None) -> MeasuredReceptance:
    """Underlying receptance from the highest-level stepped-sine run in ``path`` (paper 4.2:
    at high level a stick-slip joint slips throughout and the FRF is the linear one)."""
    from analysis.hbm import MeasuredReceptance
    from analysis.spectral import stepped_sine_frf

    from ..formats import load_recordings

    if model.n_dof != 1:
        raise InputError("--linear-from needs the full FRF matrix for more than one DOF; "
                         "take the underlying linear system from the model instead")
    frfs = [stepped_sine_frf(rec, harmonics[harmonics > 0])
            for rec in _stepped(load_recordings(path), force_hold)]
    top = max(frfs, key=lambda lv: lv.level)
    order = np.argsort(top.freqs)
    return MeasuredReceptance(top.freqs[order], top.frf[order, 0])


def _element_json(model: Model, result: FitResult) -> list[JsonObject]:
    """The fitted elements of ``result`` as JSON (kind, w, params, ci95), those of ``model``
    without unknowns included."""
    out = []
    for e, el in enumerate(result.model.elements):
        ci = {name: list(result.ci95[(e, name)]) for (i, name) in result.ci95 if i == e}
        out.append({"kind": el.kind, "w": el.w.tolist(), "params": dict(el.params),
                    "ci95": ci, "estimated": sorted(ci)})
    return out


@dataclass(frozen=True)
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
        """The stored and printed JSON of the fit."""
        fit = self.fit
        return {ESTIMATOR_KEY: NAME, "elements": _element_json(self.model, fit),
                "warnings": fit.warnings, "cost": fit.cost, "method": fit.method,
                "harmonics": self.harmonics.tolist(),
                "levels": [lv.level for lv in self.levels],
                "force_hold": [rec.force_hold for rec in self.recordings],   # per level
                "linear_from": self.options.linear_from or "model",
                "starts": fit.starts, "n_evaluations": fit.n_evaluations}

    def table(self) -> str:
        """The fit as a table for people."""
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
        """Write the ``--figure`` PNG if asked; returns the paths written."""
        if not self.options.figure:
            return []
        from analysis.models import Model
        reference = Model.load(self.options.reference) if self.options.reference else None
        return [str(p) for p in figures(self.fit, self.levels, self.harmonics,
                                        self.receptance, reference, Path(self.options.figure))]


def estimate(recs: Sequence[Recording], model: Model, options: HbmOptions | None = None
             ) -> HbmEstimate:
    """Fit the candidate's unknown parameters to all stepped-sine ``recs`` together."""
    from analysis.hbm import parse_harmonics
    from analysis.hbm import fit_hbm
    from analysis.spectral import stepped_sine_frf

    options = options or HbmOptions()
    harmonics = parse_harmonics(options.harmonics)
    recs = _stepped(recs, options.force_hold)
    levels, rate_warnings = [], []
    for rec in recs:
        if rec.excitation == Excitation.SWEPT_SINE:
            level, said = _sweep_points(rec, model, harmonics[harmonics > 0])
            levels.append(level)
            rate_warnings += said
        else:
            levels.append(stepped_sine_frf(rec, harmonics[harmonics > 0]))
    receptance = linear_from_run(options.linear_from, model, harmonics, options.force_hold) \
        if options.linear_from else None
    fit = fit_hbm(model, levels, harmonics, receptance=receptance, method=options.optimizer,
                  n_starts=options.starts)
    fit.warnings = rate_warnings + list(fit.warnings)
    return HbmEstimate(model, fit, levels, np.asarray(fit.harmonics), receptance, options,
                       recs)                   # the orders fitted: fit_hbm may add some


def figures(result: FitResult, levels: list[SteppedSineFRF], harmonics: np.ndarray,
            receptance, reference: Model | None, dest: Path) -> list[Path]:
    """Measured vs fitted FRFs per level (paper fig 4.8; the model's curves continued through
    their folds) to ``dest``; hysteresis loops of the estimated (and reference) elements
    (fig 4.7) to ``<dest stem>-loop.png``."""
    from analysis.spectral import LevelFRF
    from analysis.hbm import HBMSystem, loop

    from .. import reports as report_figures

    dof = levels[0].force_dof
    system = HBMSystem(result.model, [dof], harmonics, receptance=receptance)
    measured, curves = [], []
    for lv in levels:
        amp = float(np.median(lv.force))
        measured.append(LevelFRF(label=f"{lv.level:.3g} N", level=lv.level,
                                 excitation="stepped-sine", response_kind="displacement",
                                 force_dofs=np.array([dof]), freqs=lv.freqs,
                                 H=lv.frf[:, :, None]))
        curves.append(model_curve(system, lv.freqs, amp, "displacement"))
    dest.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(dest) as tmp:
        report_figures.fitted_frfs(measured, curves, dof).savefig(tmp)
    written = [dest]
    amp = max(float(np.abs(c.H).max()) * float(np.median(lv.force))
              for c, lv in zip(curves, levels))
    loops = {}
    for label, model in (("estimated", result.model), ("reference", reference)):
        for e, el in enumerate(model.elements if model else []):
            loops[f"{label} element {e} ({el.kind})"] = loop(el.kind, el.params, amp)
    if loops and amp > 0:
        loop_path = dest.with_name(dest.stem + "-loop.png")
        with atomic_path(loop_path) as tmp:
            report_figures.hysteresis_loops(loops).savefig(tmp)
        written.append(loop_path)
    return written


def model_curve(system, freqs: np.ndarray, amp: float, response_kind: str):
    """The model's fundamental FRF at force amplitude ``amp`` over the measured band,
    continued through its folds (`analysis.hbm.response_curves`), in the measured
    response kind; a plain sweep at ``freqs`` (all marked stable) if continuation fails."""
    from analysis.hbm import response_curves
    from analysis.errors import EstimationError
    from analysis.hbm import HBMError

    from ..reports import ModelCurve

    i1 = int(np.flatnonzero(system.harmonics == 1)[0])
    try:
        branch = response_curves(system, float(np.min(freqs)), float(np.max(freqs)), [amp])[0]
        f, X, stable = branch.freqs, branch.X[:, i1, :], branch.stable
    except (EstimationError, HBMError):
        f = np.sort(freqs)
        X = system.sweep(f, [amp]).X[:, i1, :]
        stable = np.ones(f.size, bool)
    jw = 2j * np.pi * f[:, None]
    H = X / amp * {"displacement": 1, "velocity": jw, "acceleration": jw ** 2}[response_kind]
    return ModelCurve(f, H, stable)


# --- report --------------------------------------------------------------------------------
def _estimated_elements(found: StoredResult) -> list:
    from analysis.models import Element
    return [Element(e.kind, np.asarray(e.w, float), dict(e.params))
            for e in found.elements if e.params]


def report_sections(run: RunData, frfs: list[LevelFRF], found: StoredResult | None,
                    candidate: Model | None = None) -> list[Section]:
    """Hysteresis loops (fig 4.7) and measured vs estimated-model FRFs (fig 4.8) from the
    stored harmonic-balance result ``found``; the reference model of a simulated run is drawn
    for comparison."""
    from analysis.models import KINDS
    from analysis.hbm import loop

    from .. import reports as report_figures
    from ..reports import Section, reference_model

    if found is None:
        return []
    name = found.name
    est = _estimated_elements(found)
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
    stepped = [(f, r) for f, r in zip(frfs, run.recordings)
               if f.excitation == Excitation.STEPPED_SINE]
    if est and ref is not None and stepped:
        fitted = [_hbm_frf(ref.with_elements(est), r) for _, r in stepped]
        sec = Section("Measured vs estimated model", "Stepped-sine FRFs at every level "
                      "(markers) and the harmonic-balance response curves of the estimated "
                      "model at the same force amplitude (lines), continued through their "
                      "folds: where the model's curve bends back, the dashed part is unstable "
                      "and a sweep jumps at the circled folds (paper fig 4.8).")
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


def _hbm_frf(model, rec: Recording):
    """The model's response curve at the level's drive amplitude (same response kind)."""
    from analysis.hbm import HBMSystem
    from analysis.spectral import sine_fit

    amp = rec.level if rec.level else float(np.median(np.abs(
        [sine_fit(rec.force[i, :, 0], rec.fs, f)[0]
         for i, f in enumerate(rec.freqs)])))
    system = HBMSystem(model, force_dofs=rec.force_dofs[:1])
    return model_curve(system, rec.freqs, amp, rec.response_kind)


@dataclass(frozen=True)
class HbmStored(StoredEstimate):
    """A harmonic-balance JSON or stored result read back (`Method.result`): the elements
    (known ones too, ``estimated`` naming the fitted parameters), warnings, final cost and
    the harmonics balanced (empty in results stored before they were written)."""

    harmonics: tuple[int, ...] = ()

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> HbmStored:
        """Read ``data`` (`HbmEstimate.to_json`, or a result stored before ``"estimator"``)."""
        cost = data.get("cost")
        return replace(super().from_json(data), cost=None if cost is None else float(cost),
                       harmonics=tuple(int(k) for k in data.get("harmonics") or ()))


def output_files(options: HbmOptions) -> list[str]:
    """``--figure`` and the loop figure beside it."""
    if not options.figure:
        return []
    dest = Path(options.figure)
    return [str(dest), str(dest.with_name(dest.stem + "-loop.png"))]


register(Method(NAME, "stepped sine: multi-harmonic balance fit", HbmOptions,
                Excitation.STEPPED_SINE,
                estimate, sections=report_sections, legacy_keys=("elements", "cost"),
                output_files=output_files, result=HbmStored))
