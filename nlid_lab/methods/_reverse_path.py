"""Reverse path / NIFO (random excitation): ``analyze reverse-path`` and its registry entry.

Besides the contracts section 4 keys, the JSON holds ``"estimator": "reverse-path"``,
``"force_hold"`` (how the applied force was taken to behave between samples) and ``"modal"``:
natural frequencies, damping ratios and mode shapes of the estimated underlying linear FRF
columns (`analysis.modal.modal_summary`; through the Welch kernel on the residual-force H1
where that applies, docs/reverse-path.md). ``--screen`` adds ``"screening"`` (ranked table,
significance rule, chosen candidates and the ``[[element]]`` snippet adding them); with a
model that has nothing to estimate (a linear model) ``--screen`` screens only: ``"elements"``
is empty and there is no ``"modal"``/``"multiple_coherence"``.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from analysis.errors import EstimationError, InputError
from analysis.recordings import Excitation

from ..outputs import atomic_path
from ._registry import ESTIMATOR_KEY, Method, StoredEstimate, StoredResult, option, register

if TYPE_CHECKING:
    from analysis.modal import ModalSummary
    from analysis.models import Model
    from analysis.recordings import Recording
    from analysis.reverse_path import ReversePathResult
    from analysis.reverse_path import ScreeningResult
    from analysis.reverse_path import ReversePathOptions as EstimatorOptions

    from ..reports import RunData, Section

NAME = "reverse-path"

FORCE_HOLDS = ("none", "linear")


@dataclass
class ReversePathOptions:
    """Settings of the reverse path (``analyze reverse-path`` flags; band, nperseg and refine
    also for ``reanalyze``)."""

    band: tuple[float, float] | None = option(
        "--band", batch=True, type=float, nargs=2, metavar=("LO", "HI"),
        help="analysis band in Hz (default: chosen from coherence and excitation)")
    nperseg: int | None = option("--nperseg", batch=True, type=int,
                                 help="Welch segment length in samples")
    force_hold: str | None = option(
        "--force-hold", choices=FORCE_HOLDS,
        help="how the applied force behaves between samples: 'linear' for a first-order-hold "
        "drive such as the simulated plant's, 'none' for a force transducer behind an "
        "anti-alias filter (default: what the run declares, else none)")
    screen: bool = option(
        "--screen", default=False, action="store_true",
        help="also rank every element kind reverse path can estimate at every DOF and DOF pair "
        "(coherence gain, |p|/sigma) and print the [[element]] tables adding the significant "
        "ones; with a linear model (nothing to estimate) only this")
    candidate_out: str | None = option(
        "--candidate-out", metavar="CANDIDATE.toml",
        help="with --screen: write the model with the significant candidates added, "
        "parameters omitted (the candidate model for the estimate)")
    refine: str = option(
        "--refine", default="joint", batch=True, choices=("joint", "sequential"),
        help="'sequential': re-estimate each coefficient with the elements on forced DOFs "
        "fixed at their joint estimates (narrower intervals when two bases share a "
        "deformation, e.g. v|v| next to x^3; docs/reverse-path.md)")

    def estimator_options(self) -> EstimatorOptions:
        """The `analysis.reverse_path.ReversePathOptions` these flags set (band, nperseg,
        refine; the rest at their defaults)."""
        from analysis.reverse_path import ReversePathOptions as Options
        return Options(band=None if self.band is None else tuple(self.band),
                       nperseg=self.nperseg, refine=self.refine)


def format_table(result: ReversePathResult, modal: ModalSummary | None = None,
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
        lines.append(f"underlying linear system (force at DOF {modal.force_dof}):")
        lines.append(f"{'mode':>7}  {'freq [Hz]':>10} {'damping':>9}  shape")
        for k, m in enumerate(modal.modes):
            shape = " ".join(f"{v:+.3f}" for v in m.shape)
            lines.append(f"{k:>7}  {m.freq_hz:10.3f} {100 * m.damping_ratio:8.3f}%  "
                         f"[{shape}]" + ("" if m.in_band else "  (outside the band)"))
    lines += [f"warning: {w}" for w in result.warnings]
    return "\n".join(lines)


@dataclass(frozen=True)
class ReversePathEstimate:
    """A reverse-path estimate with its modal summary (the `Estimate` of this method)."""

    result: ReversePathResult | None          # None: screening only (nothing to estimate)
    modal: ModalSummary | None
    force_hold: str
    n_records: int
    screening: ScreeningResult | None = None
    model: Model | None = None
    candidate_out: str | None = None

    def to_json(self) -> dict[str, Any]:
        """Contracts section 4 JSON plus ``estimator``, ``force_hold``, ``modal`` (and
        ``screening``)."""
        if self.result is None:
            out = {ESTIMATOR_KEY: NAME, "elements": [], "warnings": self.warnings(),
                   "force_hold": self.force_hold}
        else:
            out = {ESTIMATOR_KEY: NAME, **self.result.to_json(),
                   "force_hold": self.force_hold,
                   "modal": None if self.modal is None else self.modal.to_json()}
            out["warnings"] = out["warnings"] + self.warnings()
        if self.screening is not None:
            out["screening"] = self.screening.to_json()
        return out

    def warnings(self) -> list[str]:
        """Screening warnings (the estimate's own are in its result)."""
        if self.screening is None or self.screening.snippet():
            return []
        why = ("every significant candidate is already in the model" if self.screening.chosen
               else "no candidate is significant")
        return [f"screening: {why}; nothing to add to the model"
                + (f" ({self.candidate_out} not written)" if self.candidate_out else "")]

    def table(self) -> str:
        """The estimate as a table for people."""
        lines = [f"{self.n_records} record(s), force hold '{self.force_hold}'"]
        if self.result is not None:
            lines.append(format_table(self.result, self.modal))
        if self.screening is not None:
            lines += ["candidate screening (every kind reverse path estimates, at every DOF "
                      "and DOF pair; best first):", self.screening.table()]
            snippet = self.screening.snippet()
            if snippet:
                lines += ["add to the model file (parameters omitted: `analyze reverse-path` "
                          "estimates them)" + (f"; written with the model to "
                                              f"{self.candidate_out}" if self.candidate_out
                                              else "") + ":", snippet.rstrip()]
        lines += [f"warning: {w}" for w in self.warnings()]
        return "\n".join(lines)

    def write_files(self) -> list[str]:
        """``--candidate-out``: the model with the screened snippet appended."""
        if (not self.candidate_out or self.screening is None or self.model is None
                or not self.screening.snippet()):
            return []
        with atomic_path(self.candidate_out) as tmp:
            tmp.write_text(self.model.dumps() + "\n" + self.screening.snippet())
        return [self.candidate_out]


def estimate(recs: Sequence[Recording], model: Model,
             options: ReversePathOptions | None = None) -> ReversePathEstimate:
    """Reverse path on all ``recs`` pooled, with modal parameters (and screening).

    ``options.force_hold`` None takes each recording's declared ``force_hold``.
    """
    from analysis.modal import modal_summary
    from analysis.reverse_path import reverse_path
    from analysis.reverse_path import residual_force_frf
    from analysis.reverse_path import screen_candidates

    options = options or ReversePathOptions()
    if options.candidate_out and not options.screen:
        raise InputError("--candidate-out writes the screened candidates: add --screen")
    to_estimate = any(not el.known for el in model.elements)
    if not to_estimate and not options.screen:
        raise InputError("the candidate model has no unknown parameter: omit the parameters "
                         "of the elements to estimate, or add --screen to rank candidate "
                         "elements for this model")
    holds = {r.force_hold for r in recs} if options.force_hold is None \
        else {options.force_hold}
    if len(holds) > 1:
        raise InputError("the runs declare different force holds; analyse them separately "
                         "or give --force-hold")
    hold = holds.pop()
    if not to_estimate:
        screening = screen_candidates(recs, model, band=options.band,
                                      nperseg=options.nperseg, force_hold=hold)
        return ReversePathEstimate(None, None, hold, len(recs), screening, model,
                                   options.candidate_out)
    result = reverse_path(recs, model, options.estimator_options(), force_hold=hold)
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
    screening = screen_candidates(recs, model, band=result.band, nperseg=options.nperseg,
                                  force_hold=hold) if options.screen else None
    return ReversePathEstimate(result, modal, hold, len(recs), screening, model,
                               options.candidate_out)


@dataclass(frozen=True)
class ReversePathLevel:
    """One level's reverse path for reanalysis (the coefficients only; a `LevelEstimate`)."""

    result: ReversePathResult

    def to_json(self) -> dict[str, Any]:
        """Contracts section 4 JSON plus ``estimator``."""
        return {ESTIMATOR_KEY: NAME, **self.result.to_json()}


def estimate_level(rec: Recording, model: Model, options: ReversePathOptions
                   ) -> ReversePathLevel:
    """One level for reanalysis: the coefficients only (no modal summary, no screening)."""
    from analysis.reverse_path import reverse_path
    return ReversePathLevel(reverse_path(rec, model, options.estimator_options(),
                                         force_hold=options.force_hold))


# --- report --------------------------------------------------------------------------------
def report_sections(run: RunData, frfs: list, stored: StoredResult | None,
                    candidate: Model | None = None) -> list[Section]:
    """Underlying linear FRF, coefficients vs frequency and multiple coherence linear vs
    nonlinear (figs 3.6, 3.8, 3.9), computed from the random levels (pooled) when a
    candidate model is known (``candidate``, or the reference model of a simulated run)."""
    from analysis.spectral import FRF_UNITS
    from analysis.reverse_path import reverse_path

    from .. import reports as figures
    from ..reports import PARAM_UNITS, Section, candidate_model, reference_model

    from analysis.errors import InputError
    from analysis.recordings import model_at_sensors, one_kind

    model = candidate_model(run, candidate)
    recs = [one_kind(r) for r in run.recordings if r.excitation == Excitation.RANDOM]
    if model is None or not recs or not any(not el.known for el in model.elements):
        return []
    ref = reference_model(run)
    try:            # a run with a sensor map: the models at its measured points
        model = model_at_sensors(model, recs, "the report's reverse path")
        ref = None if ref is None else model_at_sensors(ref, recs, "the report's reverse path")
    except InputError as exc:
        return [Section("Reverse path: underlying linear system and nonlinear coefficients",
                        f"Not computed: {html.escape(str(exc))}.")]
    res = reverse_path(recs, model)
    H_model = None if ref is None else ref.linear_frf(res.freqs, list(res.force_dofs))
    coefs, units, exact = {}, {}, {}
    for c in res.coefficients:
        name = f"{c.param} of {c.kind} (element {c.element})"
        coefs[name] = c.values
        units[name] = PARAM_UNITS.get(c.kind, "-")
        if ref is not None and c.param in ref.elements[c.element].params:
            exact[name] = float(ref.elements[c.element].params[c.param])
    sec = Section("Reverse path: underlying linear system and nonlinear coefficients",
                  f"Random levels pooled ({len(recs)}), candidate model '{html.escape(model.name)}'"
                  ". Each nonlinear coefficient is estimated at every frequency: a flat real "
                  "part at the parameter value and a small imaginary part mean the candidate "
                  "term explains the data (paper figs 3.6, 3.8). The multiple coherence of "
                  "the nonlinear analysis should be close to 1 where the linear one dips "
                  "(fig 3.9).")
    for p in range(res.H_linear.shape[2]):
        sec.figures.append((f"reverse_path_linear_coefficients_in{p}",
                            figures.linear_and_coefficients(
                                res.freqs, res.H_linear[:, :, p],
                                FRF_UNITS["displacement"], coefs, units,
                                None if H_model is None else H_model[:, :, p], exact)))
    sec.figures.append(("reverse_path_coherence", figures.coherence_linear_vs_nonlinear(
        res.freqs, res.coherence_linear, res.coherence_nonlinear)))
    return [sec]


@dataclass(frozen=True)
class ReversePathStored(StoredEstimate):
    """A reverse-path JSON or stored result read back (`Method.result`): the elements,
    warnings, lowest multiple coherence (None for a screening-only result) and the force hold
    taken (None in runs stored before it was written)."""

    force_hold: str | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ReversePathStored:
        """Read ``data`` (`ReversePathEstimate.to_json`, or a result stored before
        ``"estimator"``, ``"force_hold"`` or ``"modal"`` were written)."""
        coherence = data.get("multiple_coherence") or {}
        lowest = coherence.get("min")
        hold = data.get("force_hold")
        return replace(super().from_json(data),
                       coherence_min=None if lowest is None else float(lowest),
                       force_hold=None if hold is None else str(hold))


def output_files(options: ReversePathOptions) -> list[str]:
    """``--candidate-out``."""
    return [options.candidate_out] if options.candidate_out else []


register(Method(NAME, "random excitation: reverse path / NIFO", ReversePathOptions,
                Excitation.RANDOM,
                estimate, estimate_level, report_sections,
                legacy_keys=("elements", "multiple_coherence"), output_files=output_files,
                result=ReversePathStored))
