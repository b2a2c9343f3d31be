"""``nlid-lab analyze reverse-path``: load runs, estimate, print a table, write JSON.

Besides the contracts section 4 keys, the JSON holds ``"force_hold"`` (how the applied force
was taken to behave between samples) and ``"modal"``: natural frequencies, damping ratios and
mode shapes of the estimated underlying linear FRF columns (`analysis.modal.modal_fit`;
through the Welch kernel on the residual-force H1 where that applies, docs/reverse-path.md).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any, TextIO

import numpy as np

from analysis.errors import EstimationError, InputError
from analysis.modal import modal_fit, welch_smoothing
from analysis.model import Model
from analysis.recording import Recording
from analysis.reverse_path import ReversePathResult, reverse_path
from analysis.reverse_path_linear import residual_force_frf
from analysis.screening import screen_candidates
from analysis.spectral import Spectra, multiple_coherence

from .outputs import write_json
from .store import check_result_target, load_recordings, save_result

FORCE_HOLDS = ("none", "linear")


def recorded_force_hold(rec: Recording) -> str | None:
    """Force hold a recording declares: ``meta["force_hold"]``, else its run settings'."""
    hold = rec.meta.get("force_hold") or (rec.meta.get("settings") or {}).get("force_hold")
    if hold is not None and hold not in FORCE_HOLDS:
        raise InputError(f"recording declares force_hold '{hold}'; expected none or linear "
                         "(override with --force-hold)")
    return hold


def modal_summary(result: ReversePathResult, n_modes: int,
                  linear: tuple[np.ndarray, np.ndarray, Spectra] | None = None
                  ) -> dict[str, Any]:
    """Modes of the estimated underlying linear FRF columns (rational-fraction fit).

    All columns share the poles; each mode shape is the residue vector of the first forced
    column, scaled to a unit largest component. ``n_modes`` is the model's DOF count, for
    which the fit of a lumped system's receptance is exact; modes outside the analysed band
    are extrapolated and flagged ``in_band: false``. With ``linear`` (the residual-force H1,
    `analysis.reverse_path_linear.residual_force_frf`) the fit goes through the Welch
    window's smoothing kernel, which removes the leakage bias of the damping; otherwise the
    reverse path's ``H_linear`` is fitted directly.
    """
    if linear is not None:
        freqs, frf, spec = linear
        n, auto = frf.shape[1], spec.auto()
        coh = multiple_coherence(auto[:, :n], spec.S[:, :n, n:], spec.S[:, n:, n:])
        smoothing = welch_smoothing(spec.window, spec.nperseg, spec.fs,
                                    input_spectrum=(freqs, auto[:, n:].sum(axis=1)))
        fit = modal_fit(freqs, frf, n_modes, weights=coh.min(axis=1), smoothing=smoothing)
        method = ("global rational fraction polynomial on the residual-force H1, through "
                  f"the {spec.window} window's Welch kernel")
    else:
        frf = result.H_linear
        fit = modal_fit(result.freqs, frf, n_modes,
                        weights=result.coherence_nonlinear.min(axis=1))
        method = "global rational fraction polynomial on the reverse-path H_linear"
    n_in = frf.shape[2]
    lo, hi = result.band
    modes = []
    for f, zeta, r in zip(fit.freqs_hz, fit.damping, fit.residues):
        col = r[::n_in]                                   # outputs of the first force column
        k = int(np.argmax(np.abs(col)))
        shape = col / col[k]
        shape[k] = 1.0                                    # exactly, not to round-off
        modes.append({"freq_hz": float(f), "damping_ratio": float(zeta),
                      "shape": [float(v) for v in shape.real],
                      "in_band": bool(lo <= f <= hi)})
    return {"method": method, "force_dof": int(result.force_dofs[0]), "modes": modes}


def result_json(result: ReversePathResult, modal: dict[str, Any] | None,
                force_hold: str | None) -> dict[str, Any]:
    """Contracts section 4 JSON plus ``force_hold`` and ``modal``."""
    out = result.to_json()
    out["force_hold"] = force_hold
    out["modal"] = modal
    return out


def format_table(result: ReversePathResult, modal: dict[str, Any] | None = None,
                 reference: Model | None = None) -> str:
    """Readable summary: coefficients (with the true value when ``reference`` has it), 95 %
    intervals, multiple coherence and modes."""
    ref_col = reference is not None
    how = "sequential (each with the others fixed)" if result.refine else "joint"
    lines = [f"reverse path: band {result.band[0]:.1f}-{result.band[1]:.1f} Hz, "
             f"{result.spectra.n_avg} averages at {result.spectra.fs / result.spectra.nperseg:.3g}"
             f" Hz resolution",
             f"multiple coherence min {result.coherence_nonlinear.min():.4f} nonlinear, "
             f"{result.coherence_linear.min():.4f} linear only",
             f"coefficients: {how} estimate",
             f"{'element':>7}  {'kind':<18} {'param':<5} "
             + (f"{'true':>12} " if ref_col else "")
             + f"{'estimate':>12}  {'95 % interval':>27}" + ("  error" if ref_col else "")]
    for c in result.coefficients:
        truth = reference.elements[c.element].params.get(c.param) if ref_col else None
        row = f"{c.element:>7}  {c.kind:<18} {c.param:<5} "
        if ref_col:
            row += f"{truth:12.5g} " if truth is not None else f"{'-':>12} "
        row += f"{c.value:12.5g}  [{c.ci95[0]:12.5g}, {c.ci95[1]:12.5g}]"
        if truth:
            row += f"  {100 * (c.value / truth - 1):+.3f} %"
        lines.append(row)
    if modal:
        lines.append(f"underlying linear system (force at DOF {modal['force_dof']}):")
        lines.append(f"{'mode':>7}  {'freq [Hz]':>10} {'damping':>9}  shape")
        for k, m in enumerate(modal["modes"]):
            shape = " ".join(f"{v:+.3f}" for v in m["shape"])
            lines.append(f"{k:>7}  {m['freq_hz']:10.3f} {100 * m['damping_ratio']:8.3f}%  "
                         f"[{shape}]" + ("" if m["in_band"] else "  (outside the band)"))
    lines += [f"warning: {w}" for w in result.warnings]
    return "\n".join(lines)


def estimate(recs: list[Recording], model: Model, *, force_hold: str | None = None,
             band: tuple[float, float] | None = None, nperseg: int | None = None,
             refine: str = "joint") -> tuple[ReversePathResult, dict[str, Any]]:
    """Reverse path with modal parameters; returns the result and its JSON dictionary.

    ``force_hold`` None takes each recording's declared hold (`recorded_force_hold`).
    """
    holds = {recorded_force_hold(r) for r in recs} if force_hold is None else {force_hold}
    if len(holds) > 1:
        raise InputError("the runs declare different force holds; analyse them separately "
                         "or give --force-hold")
    hold = holds.pop() or "none"
    result = reverse_path(recs, model, band=band, nperseg=nperseg, force_hold=hold,
                          refine=refine)
    try:   # an estimate a model file cannot hold (e.g. negative damping): H_linear instead
        linear = residual_force_frf(recs, result.estimated_model(model), result,
                                    force_hold=hold)
    except InputError:
        linear = None
    try:
        modal = modal_summary(result, model.n_dof, linear)
    except (EstimationError, InputError) as exc:
        result.warnings.append(f"modal parameters not estimated: {exc}")
        modal = None
    return result, result_json(result, modal, hold)


def run(args: argparse.Namespace) -> int:
    if getattr(args, "store", None):
        check_result_target(args.store)      # before the work: a bad target exits 2 at once
    model = Model.load(args.model)
    recs = [rec for path in args.runs for rec in load_recordings(path)]
    result, out = estimate(recs, model, force_hold=getattr(args, "force_hold", None),
                           band=tuple(args.band) if args.band else None, nperseg=args.nperseg,
                           refine=getattr(args, "refine", "joint"))
    # with --json - the table goes to stderr so stdout stays pure JSON
    stream: TextIO = sys.stderr if args.json == "-" else sys.stdout
    print(f"{len(recs)} record(s), force hold '{out['force_hold']}'", file=stream)
    print(format_table(result, out["modal"]), file=stream)
    if getattr(args, "screen", False):
        screening = screen_candidates(recs, model, band=result.band, nperseg=args.nperseg,
                                      force_hold=out["force_hold"])
        print("candidate screening (paper eq 20 library; * = selected):", file=stream)
        print(screening.table(), file=stream)
        out["screening"] = screening.to_json()
    write_json(out, args.json)
    if getattr(args, "store", None):
        save_result(args.store, "analyze-reverse-path", out)
    return 0
