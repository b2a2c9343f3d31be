"""Run reports: what a run shows (FRFs per level, estimates, diagnosis) and the HTML page.

`nlid_lab.reports.load_run` reads a stored run (HDF5 through `nlid_lab.store`, or an NPZ recording),
`analysis.spectral.level_frf` turns one level's recording into FRFs and coherences, and `write_report` writes the PNG figures
(`nlid_lab.reports._figures`) plus one ``index.html`` that links them. A section appears only when its
data is stored in the run or can be computed from it.
"""

from __future__ import annotations

import html
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Protocol, Sequence

import numpy as np

from analysis.detection import bla_summary, level_change
from analysis.errors import EstimationError, InputError
from analysis.modal import fit_linear
from analysis.recordings import Excitation, channel_labels, one_kind, record_level
from analysis.spectral import LevelFRF, level_label

from ..formats import describe
from . import _figures as figures
from ._figures import LevelBars
from ._backbone_figure import backbone_section
from ._rundata import RunData, Section, all_level_frfs

if TYPE_CHECKING:
    from analysis.diagnose import Diagnosis

    from ..store import EstimatedElement


class FoundEstimate(Protocol):
    """A stored estimate as the registry finds it (`nlid_lab.methods.StoredResult`): the
    name it is stored under and its elements, read back typed."""

    @property
    def name(self) -> str:
        """Name of the stored result."""

    @property
    def elements(self) -> tuple[EstimatedElement, ...]:
        """The estimated elements."""


class Estimators(Protocol):
    """The estimator registry as a report reads it: `nlid_lab.methods`, a room above this
    one, handed in by the caller (the report does not import it: rooms import one way)."""

    def methods(self) -> Sequence[Any]:
        """Registered methods (each with ``sections``), in order."""

    def find_stored(self, results: Mapping[str, object], method: Any) -> FoundEstimate | None:
        """The last stored result of ``method``, read back typed."""

    def stored_estimates(self, results: Mapping[str, object]) -> Sequence[FoundEstimate]:
        """Stored results of any registered method, read back typed."""


# --- report sections ----------------------------------------------------------------------


def channel_names(run: RunData) -> tuple[list[str], list[str]] | None:
    """(``"point (kind)"`` per response channel, force points) of a run with a sensor map,
    else None (the figures say ``DOF q``)."""
    rec = run.recordings[0] if run.recordings else None
    if rec is None or rec.sensors is None:
        return None
    return channel_labels(rec), list(rec.sensors.force_points)


def stored_diagnosis(run: RunData) -> Diagnosis | None:
    """The run's stored diagnosis, in any layout nlid-lab wrote (None without one)."""
    from analysis.diagnose import RESULT_NAME, Diagnosis   # the diagnosis room loads on use
    res = run.results.get(RESULT_NAME)
    if res is None:
        return None
    try:
        return Diagnosis.from_json(res)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"the run's stored diagnosis cannot be read ({exc!r}); store it "
                         "again with `nlid-lab diagnose ... --store RUN.h5`") from None


def frf_sections(frfs: list[LevelFRF], names=None) -> list[Section]:
    """FRFs per level (figs 2.1/3.5/4.5) and, for random levels, multiple coherence;
    ``names``: (response, force) channel names of a run with a sensor map."""
    n_dof, n_in = frfs[0].H.shape[1:]
    sec = Section("FRFs per force level",
                  "Magnitude and phase of the measured FRF at every level, one figure per "
                  "response DOF. A resonance that moves or flattens with level marks a "
                  "nonlinearity (paper figs 2.1, 3.5, 4.5).")
    sec.figures = [(f"frf_levels_out{q}_in{p}", figures.frf_levels(frfs, q, p, names))
                   for p in range(n_in) for q in range(n_dof)]
    out = [sec]
    random = [f for f in frfs if f.multiple_coherence is not None]
    if random:
        coh = Section("Multiple coherence per level (linear analysis)",
                      "Coherence of each response with the applied forces (periodic-random "
                      "levels: of the period averages across realizations). A dip near "
                      "resonance that deepens with level is distortion the linear model "
                      "cannot explain.")
        coh.figures = [(f"coherence_levels_out{q}",
                        figures.multiple_coherence_levels(random, q, names))
                       for q in range(n_dof)]
        out.append(coh)
    return out


def diagnosis_section(run: RunData) -> Section | None:
    """The stored diagnosis: FRF error per level and time residual, before and after the
    correction (None without one)."""
    d = stored_diagnosis(run)
    if d is None:
        return None
    fit = d.fit
    sec = Section("Diagnosis", html.escape(d.explanation))
    if fit.before is not None and fit.after is not None:
        sec.figures.append(("diagnosis_fit", figures.diagnosis_fit(
            fit.metric, float(fit.before), float(fit.after),
            f"FRF error before and after the correction (verdict: {d.verdict})",
            diagnosis_levels(d, "N rms" if run.recordings and
                             run.recordings[0].excitation == Excitation.RANDOM else "N"))))
    tr = fit.time_residual
    if tr is not None:
        sec.figures.append(("diagnosis_time", figures.diagnosis_fit(
            tr.metric, float(tr.before), float(tr.after),
            "Time residual of replays before and after the correction")))
    return sec


def diagnosis_levels(d: Diagnosis, unit: str = "N") -> list[LevelBars] | None:
    """Per-level FRF errors of a diagnosis as the figure's bars (label: the level in
    ``unit``); None when a level lacks them."""
    out = []
    for i, lv in enumerate(d.fit.levels):
        if lv.before is None or lv.after is None:
            return None
        label = (f"{lv.level:.3g} {unit}" if lv.level is not None
                 else lv.label or f"level {i + 1}")
        out.append(LevelBars(label, lv.before, lv.after, lv.held_back))
    return out or None


def level_change_section(run: RunData) -> Section | None:
    """Two or more random (Welch) levels: where the FRF changes with level beyond its noise
    (`analysis.detection.level_change`)."""
    random = [r for r in run.recordings
              if r.excitation == Excitation.RANDOM and r.layout is None]
    if len(random) < 2:
        return None
    try:
        change = level_change(random)
    except InputError:
        return None
    t = change.summary
    verdict = (f"the FRF changes beyond its noise on {100 * t.share_flagged:.0f} % of the "
               f"lines ({t.band_hz[0]:.1f}-{t.band_hz[1]:.1f} Hz): the structure is "
               "nonlinear" if t.nonlinear else
               f"{100 * t.share_flagged:.1f} % of the lines change beyond the noise, as "
               "noise alone gives: no evidence of nonlinearity")
    sec = Section("Level dependence of the FRF (random levels)",
                  f"H1 at {t.labels[0]} against {t.labels[1]}, "
                  "line by line, relative to the variance of their difference; a linear "
                  "structure exceeds the dashed line on 1 % of the lines (chance up to "
                  f"{100 * t.share_limit:.1f} %). Here {verdict} (`nlid-lab detect`).")
    sec.figures = [("level_change", figures.level_change(change, channel_names(run)))]
    return sec


def distortion_section(frfs: list[LevelFRF], names=None) -> Section | None:
    """Periodic-random levels: BLA with noise and nonlinear-distortion levels, and the
    detection verdict per level and response."""
    # the distortion needs two or more realizations; one gives the period average only
    shown = [f for f in frfs if f.bla is not None and f.bla.realizations >= 2]
    if not shown:
        return None
    lines = []
    for frf in shown:
        t = bla_summary(frf.bla, frf.level)
        for q, (share, db) in enumerate(zip(t.by_output, t.median_change_db)):
            what = (f"nonlinear distortion on {100 * share:.0f} % of the lines, median "
                    f"{db:+.1f} dB over the noise" if share > t.share_limit else
                    f"no distortion above the noise ({100 * share:.1f} % of the lines "
                    "flagged, as noise alone gives)")
            lines.append(f"{frf.label}, response {figures.response_name(q, names)}: "
                         f"{what}.")
    sec = Section("Best linear approximation and nonlinear distortion (periodic random)",
                  "Robust method (Pintelon & Schoukens): the BLA averaged over the "
                  f"{shown[0].bla.realizations} realizations, the standard deviation of that "
                  "average from the spread over periods (noise) and over realizations (noise + "
                  "stochastic nonlinear distortion). Where the total lies above the noise, a "
                  "linear model cannot explain the response. A line is flagged when the ratio "
                  "exceeds the 99 % quantile a linear system would give. " + " ".join(lines))
    n_dof = shown[0].H.shape[1]
    sec.figures = [(f"bla_distortion_out{q}", figures.bla_levels(shown, q, names))
                   for q in range(n_dof)]
    return sec


def modal_fit_section(run: RunData) -> Section | None:
    """Random or multisine levels: the modal fit `nlid-lab fit-linear` makes of the lowest
    one (stabilisation diagram and the modes), or why it cannot be made."""
    from analysis.diagnose import level_name   # the diagnosis room loads on use
    random = [r for r in run.recordings if r.excitation == Excitation.RANDOM]
    if not random:
        return None
    rec = one_kind(min(random, key=record_level))      # mixed kinds: as fit-linear reads them
    title = "Modal fit of the lowest level (fit-linear)"
    points = None if rec.sensors is None else list(rec.sensors.response_points)
    try:
        fit = fit_linear(rec, points=points)
    except (InputError, EstimationError) as exc:
        return Section(title, f"No modal fit of {html.escape(level_name(rec))}: "
                       f"{html.escape(str(exc))}.")
    m, model = fit.modes, fit.model
    mac = m.mac - np.eye(m.mac.shape[0])
    rows = "".join(f"<tr><td>{i + 1}</td><td>{f:.3f}</td><td>{100 * z:.3f}</td>"
                   f"<td>{100 * s:.0f} %</td><td>{mac[i].max(initial=0.0):.3f}</td></tr>"
                   for i, (f, z, s) in enumerate(zip(m.freqs_hz, m.damping, m.support)))
    errors = ", ".join(f"{'DOF ' if points is None else ''}{html.escape(p)} {100 * e:.1f} %"
                       for p, e in zip(model.points, fit.frf_error))
    left_out = "".join(f" Force line left out of the excited lines: {html.escape(i.text())}."
                       for i in fit.data.interference)
    if fit.delay_samples:
        said = fit.delay.text()
        left_out += (f" {html.escape(said[0].upper() + said[1:])}: taken out of the FRF before "
                     "the fit" + (f" (import with <code>response_delay={fit.delay.stated:g}"
                                  "</code> to align the run for the other estimators)"
                                  if fit.delay.resolved else "") + ".")
    if fit.data.caveat is not None:
        left_out += f" Caveat: {html.escape(fit.data.caveat.text())}."
    sec = Section(title,
                  f"The lowest level ({html.escape(level_name(rec))}), the closest to linear: "
                  f"{html.escape(fit.data.method)}, modes in {m.band_hz[0]:.3g}-"
                  f"{m.band_hz[1]:.3g} Hz chosen where the poles stay stable as the model "
                  "order grows. In-band FRF error of the modal model "
                  f"({html.escape(rec.response_kind)}): {errors}.{left_out} "
                  "<code>nlid-lab fit-linear RUN --out MODEL.toml</code> writes this model."
                  "<table><tr><th>mode</th><th>f [Hz]</th><th>&zeta; [%]</th>"
                  "<th>stable in</th><th>max MAC to another mode</th></tr>"
                  f"{rows}</table>")
    sec.figures = [("stabilisation", figures.stabilisation(fit))]
    return sec


def sweep_section(run: RunData) -> Section | None:
    """Swept-sine levels: each level's sweep (direction, law, whether estimated on import)."""

    swept = [(i, r) for i, r in enumerate(run.recordings)
             if r.excitation == Excitation.SWEPT_SINE and r.sweep is not None]
    if not swept:
        return None
    said = "; ".join(f"{level_label(r, i)}: {describe(r.sweep)}" for i, r in swept)
    return Section("Swept-sine levels",
                   "The FRF of a swept-sine level is its fundamental tracked by sine fits on "
                   "the sweep's own phase (docs/hbm.md); read it with the sweep direction in "
                   "mind: a lightly damped mode answers a fast sweep late, and a nonlinear "
                   f"one jumps at different frequencies up and down. {said}.")


def sections(run: RunData, frfs: list[LevelFRF], estimators: Estimators, candidate=None
             ) -> list[Section]:
    """Every section the run has data for, in reading order (the estimators' own sections
    from the registry ``estimators``)."""
    names = channel_names(run)
    out = frf_sections(frfs, names)
    for extra in (sweep_section(run), backbone_section(run), level_change_section(run),
                  distortion_section(frfs, names),
                  modal_fit_section(run)):
        if extra is not None:
            out.append(extra)
    for method in estimators.methods():
        if method.sections is not None:
            out += method.sections(run, frfs, estimators.find_stored(run.results, method),
                                   candidate)
    diagnosis = diagnosis_section(run)
    if diagnosis is not None:
        out.append(diagnosis)
    return out


# --- writing --------------------------------------------------------------------------------
SCHEMA_VERSION = 1
"""Version of the ``report --json`` layout (`WrittenReport.to_json`)."""


@dataclass(frozen=True)
class WrittenReport:
    """What `write_report` wrote: the page, the figures' file names, the section titles."""

    html: str
    figures: tuple[str, ...]
    sections: tuple[str, ...]

    def to_json(self) -> dict[str, Any]:
        """The ``report --json`` result: ``schema_version``, html, figures, sections."""
        return {"schema_version": SCHEMA_VERSION, "html": self.html,
                "figures": list(self.figures), "sections": list(self.sections)}

def write_report(run: RunData, out_dir: str | Path, progress: Callable[[int], None] | None
                 = None, frfs: list[LevelFRF] | None = None, candidate=None, *,
                 estimators: Estimators) -> WrittenReport:
    """Write the PNG figures and ``index.html`` into ``out_dir``; returns what was written.

    ``candidate`` (a `Model`) enables the reverse-path section for runs without a stored
    reference model; ``estimators`` is the estimator registry (`nlid_lab.methods`).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    frfs = frfs if frfs is not None else all_level_frfs(run)
    secs = sections(run, frfs, estimators, candidate)
    written = []
    for sec in secs:
        for stem, fig in sec.figures:
            fig.savefig(out_dir / f"{stem}.png")
            written.append(f"{stem}.png")
            if progress:
                progress(1)
    page = out_dir / "index.html"
    page.write_text(render_html(run, frfs, secs, estimators))
    return WrittenReport(str(page), tuple(written), tuple(s.title for s in secs))


def _averages(f: LevelFRF) -> str:
    """What a level's FRF averages: Welch segments, or realizations x periods of a
    period-averaged multisine."""
    if f.bla is None:
        return str(f.n_averages)
    return f"{f.bla.realizations} x {f.bla.periods} periods"


def render_html(run: RunData, frfs: list[LevelFRF], secs: list[Section],
                estimators: Estimators) -> str:
    """The report page: the run's levels, stored estimates and every section with its
    figures."""
    esc = html.escape
    rows = "".join(f"<tr><td>{i + 1}</td><td>{esc(f.label)}</td><td>{esc(f.excitation)}</td>"
                   f"<td>{f.freqs.size}</td><td>{_averages(f)}</td></tr>"
                   for i, f in enumerate(frfs))
    body = [f"<h1>nlid-lab report: {esc(run.name)}</h1>",
            f"<p>Run file <code>{esc(str(run.path))}</code> · status <b>{esc(run.status)}</b>"
            f" · {len(frfs)} level(s) · response kind {esc(frfs[0].response_kind)}, FRF unit "
            f"{esc(frfs[0].units)}</p>",
            "<table><tr><th>#</th><th>level</th><th>excitation</th><th>frequencies</th>"
            f"<th>averages</th></tr>{rows}</table>"]
    est = _estimates_table(run.results, estimators)
    if est:
        body.append(f"<h2>Stored estimates</h2>{est}")
    for sec in secs:
        body.append(f"<h2>{esc(sec.title)}</h2><p>{sec.text}</p>")
        body += [f'<img src="{stem}.png" alt="{esc(sec.title)}">' for stem, _ in sec.figures]
    style = ("body{font-family:sans-serif;max-width:980px;margin:auto;padding:1em}"
             "img{max-width:100%;display:block;margin:1em 0}"
             "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px}")
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(run.name)}</title>"
            f"<style>{style}</style></head><body>{''.join(body)}</body></html>\n")


def estimate_rows(results: Mapping[str, object], estimators: Estimators
                  ) -> list[tuple[str, str, str, str, str]]:
    """(result, element, parameter, value, 95 % interval) of every stored estimate of a
    method in the registry ``estimators`` (`nlid_lab.methods`), among a run's ``results``."""
    rows = []
    for found in estimators.stored_estimates(results):
        for i, el in enumerate(found.elements):
            for par, value in el.params.items():
                lo_hi = el.ci95.get(par)
                rows.append((found.name, f"{i}: {el.kind}", par, f"{value:.5g}",
                             f"[{lo_hi[0]:.5g}, {lo_hi[1]:.5g}]" if lo_hi else "-"))
    return rows


def _estimates_table(results: Mapping[str, object], estimators: Estimators) -> str:
    rows = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>"
                   for row in estimate_rows(results, estimators))
    if not rows:
        return ""
    return ("<table><tr><th>result</th><th>element</th><th>parameter</th><th>value</th>"
            f"<th>95 % interval</th></tr>{rows}</table>")
