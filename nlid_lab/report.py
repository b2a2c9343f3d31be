"""Run reports: what a run shows (FRFs per level, estimates, diagnosis) and the HTML page.

`load_run` reads a stored run (HDF5 through `nlid_lab.store`, or an NPZ recording), `level_frf`
turns one level's recording into FRFs and coherences, and `write_report` writes the PNG figures
(`nlid_lab.figures`) plus one ``index.html`` that links them. A section appears only when its
data is stored in the run or can be computed from it.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from analysis import spectral
from analysis.bla import best_linear_approximation
from analysis.sine_fit import hold_gain, sine_fit
from analysis.errors import InputError
from analysis.recording import Recording

from . import figures, store
from .outputs import level_text

#: FRF units by response kind (receptance, mobility, accelerance).
FRF_UNITS = {"displacement": "m/N", "velocity": "(m/s)/N", "acceleration": "(m/s²)/N"}


def convert_frf(H: np.ndarray, freqs: np.ndarray, kind: str, to: str) -> np.ndarray:
    """FRF ``H`` (first axis along ``freqs``) of response ``kind`` as response ``to``: times
    ``(i 2 pi f)`` per derivative (receptance -> mobility -> accelerance) or divided by it."""
    order = {"displacement": 0, "velocity": 1, "acceleration": 2}
    iw = (2j * np.pi * np.asarray(freqs, dtype=float)).reshape((-1,) + (1,) * (H.ndim - 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        return H * iw ** (order[to] - order[kind])


class ReportError(InputError):
    """A run cannot be reported or exported as asked."""


@dataclass
class LevelFRF:
    """FRFs of one level of a run.

    Attributes
    ----------
    label : str
        Legend text, e.g. ``"10 N rms"``.
    freqs : ndarray, shape (n_f,)
        Frequencies, Hz (uneven for stepped sine).
    H : ndarray, shape (n_f, n_dof, n_in), complex
        H1 estimate (random) or fundamental-harmonic ratio X1/F1 (stepped sine).
    coherence : ndarray, shape (n_f, n_dof, n_in), optional
        Ordinary coherence of each output/input pair (random only).
    multiple_coherence : ndarray, shape (n_f, n_dof), optional
        Multiple coherence of each output with all inputs (random only).
    bla : analysis.bla.BLA, optional
        Periodic-random levels: the robust best linear approximation (``H`` is its ``G``)
        with its noise and total variances.
    """

    label: str
    level: float | None
    excitation: str
    response_kind: str
    force_dofs: np.ndarray
    freqs: np.ndarray
    H: np.ndarray
    coherence: np.ndarray | None = None
    multiple_coherence: np.ndarray | None = None
    n_averages: int = 1
    bla: Any = None

    @property
    def units(self) -> str:
        return FRF_UNITS[self.response_kind]


@dataclass
class RunData:
    """Everything a view, report or export needs from one stored run."""

    path: Path
    recordings: list[Recording]
    meta: dict[str, Any] = field(default_factory=dict)
    results: dict[str, Any] = field(default_factory=dict)
    status: str = "complete"

    @property
    def name(self) -> str:
        return self.path.stem


def load_run(path: str | Path) -> RunData:
    """Read a run: an HDF5 file written by the store, or an NPZ recording (contracts 3)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(2, "No such file or directory", str(path))
    if path.suffix.lower() not in (".h5", ".hdf5"):
        return RunData(path, store.load_recordings(path))
    run = store.open_run(path)
    recs = run.recordings()
    if not recs:
        raise ReportError(f"{path} holds no recorded level; run or resume the campaign first")
    return RunData(path, recs, dict(run.meta), dict(run.results), run.status)


def default_nperseg(n: int, fs: float) -> int:
    """Welch segment length: a power of two giving >= 16 segments, at most 8192 samples."""
    target = max(n // 16, 64)
    return int(min(2 ** int(np.floor(np.log2(target))), 8192))


def level_label(rec: Recording, index: int) -> str:
    if rec.level is None:
        return f"level {index + 1}"
    unit = "N rms" if rec.excitation == "random" else "N"
    return f"{rec.level:.3g} {unit}"


def level_frf(rec: Recording, index: int = 0, nperseg: int | None = None) -> LevelFRF:
    """FRFs (and coherences for random data) of one level's recording."""
    label = level_label(rec, index)
    common = dict(label=label, level=rec.level, excitation=rec.excitation,
                  response_kind=rec.response_kind, force_dofs=rec.force_dofs)
    if rec.excitation == "stepped-sine":
        freqs, H = sine_frf(rec)
        return LevelFRF(freqs=freqs, H=H, n_averages=1, **common)
    if rec.meta.get("period") and rec.n_in == 1 and rec.meta.get("realizations", 1) >= 2:
        b = best_linear_approximation(rec.force, rec.response, rec.fs, int(rec.meta["period"]),
                                      transient_periods=int(rec.meta.get("transient_periods", 1)),
                                      realizations=int(rec.meta["realizations"]),
                                      force_hold=rec.meta.get("force_hold"))
        return frf_from_bla(b, **common)
    nseg = nperseg or default_nperseg(rec.force.shape[0], rec.fs)
    spec = spectral.spectral_matrix(np.concatenate([rec.force, rec.response], axis=1),
                                    rec.fs, nperseg=nseg)
    return frf_from_spectra(spec, rec.n_in, **common)


def frf_from_spectra(spec: spectral.Spectra, n_in: int, **common: Any) -> LevelFRF:
    """H1, ordinary and multiple coherence from a spectral matrix of [forces, responses],
    kept only over the excited band (outside it the force carries no power and H1 is noise)."""
    from analysis.signals import excitation_band
    n_ch = spec.S.shape[1]
    fin, fout = list(range(n_in)), list(range(n_in, n_ch))
    auto = spec.auto()
    lo, hi = excitation_band(spec.freqs, auto[:, fin])
    keep = (spec.freqs >= lo) & (spec.freqs <= hi)
    S = spec.S[keep]
    S_rr, S_xr = S[:, fin][:, :, fin], S[:, fout][:, :, fin]
    coh = np.stack([np.stack([spectral.ordinary_coherence(S, q, p) for p in fin], -1)
                    for q in fout], 1)
    mcoh = spectral.multiple_coherence(auto[keep][:, fout], S_xr, S_rr)
    return LevelFRF(freqs=spec.freqs[keep], H=spectral.h1(S_xr, S_rr), coherence=coh,
                    multiple_coherence=mcoh, n_averages=spec.n_avg, **common)


def frf_from_bla(b, **common: Any) -> LevelFRF:
    """A periodic-random level's FRFs: the BLA (`analysis.bla.BLA`) and its coherence across
    realizations."""
    return LevelFRF(freqs=b.freqs, H=b.G[:, :, None], coherence=b.coherence[:, :, None],
                    multiple_coherence=b.coherence, n_averages=b.realizations, bla=b, **common)


def sine_frf(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """Fundamental-harmonic FRF X1/F1 of each stepped-sine step, shape (n_steps, n_dof, n_in).

    With several force channels each column is the ratio to that channel's fundamental: exact
    for a single shaker, an indicator only when several forces act at once.
    """
    H = np.empty((rec.freqs.size, rec.n_dof, rec.n_in), complex)
    for i, f in enumerate(rec.freqs):
        X = sine_fit(rec.response[i], rec.fs, f)[0]     # (n_dof,)
        F = sine_fit(rec.force[i], rec.fs, f)[0]        # (n_in,)
        H[i] = X[:, None] / (F[None, :] * hold_gain(f, rec.fs, rec.meta.get("force_hold")))
    return rec.freqs.copy(), H


def all_level_frfs(run: RunData, progress: Callable[[int], None] | None = None
                   ) -> list[LevelFRF]:
    """`level_frf` of every level, in stored order."""
    out = []
    for i, rec in enumerate(run.recordings):
        out.append(level_frf(rec, i))
        if progress:
            progress(1)
    return out


# --- report sections ----------------------------------------------------------------------
@dataclass
class Section:
    """One report section: a heading, a short explanation and its figures."""

    title: str
    text: str
    figures: list[tuple[str, Any]] = field(default_factory=list)   # (file stem, Figure)


def find_result(results: dict[str, Any], *keys: str) -> tuple[str, dict] | None:
    """The last stored result holding all ``keys`` (results are stored by command name)."""
    found = None
    for name, res in results.items():
        if isinstance(res, dict) and all(k in res for k in keys):
            found = (name, res)
    return found


def reference_model(run: RunData):
    """The model stored with a simulated run (the reference system), or None."""
    from analysis.model import Model
    text = run.meta.get("model_toml") or ""
    return Model.loads(text) if text.strip() else None


def frf_sections(frfs: list[LevelFRF]) -> list[Section]:
    """FRFs per level (figs 2.1/3.5/4.5) and, for random levels, multiple coherence."""
    n_dof, n_in = frfs[0].H.shape[1:]
    sec = Section("FRFs per force level",
                  "Magnitude and phase of the measured FRF at every level, one figure per "
                  "response DOF. A resonance that moves or flattens with level marks a "
                  "nonlinearity (paper figs 2.1, 3.5, 4.5).")
    sec.figures = [(f"frf_levels_out{q}_in{p}", figures.frf_levels(frfs, q, p))
                   for p in range(n_in) for q in range(n_dof)]
    out = [sec]
    random = [f for f in frfs if f.multiple_coherence is not None]
    if random:
        coh = Section("Multiple coherence per level (linear analysis)",
                      "Coherence of each response with the applied forces (periodic-random "
                      "levels: of the period averages across realizations). A dip near "
                      "resonance that deepens with level is distortion the linear model "
                      "cannot explain.")
        coh.figures = [(f"coherence_levels_out{q}", figures.multiple_coherence_levels(random, q))
                       for q in range(n_dof)]
        out.append(coh)
    return out


#: Units of the coefficient of each element kind's basis function.
PARAM_UNITS = {"cubic_spring": "N/m³", "quadratic_spring": "N/m²",
               "quadratic_damping": "N·s²/m²", "cubic_damping": "N·s³/m³",
               "coulomb_friction": "N", "gap": "N/m"}


def candidate_model(run: RunData, candidate=None):
    """Model for reverse path: ``candidate`` if given, else the run's stored reference model
    with every element parameter removed (to be estimated); None when neither exists."""
    if candidate is not None:
        return candidate
    ref = reference_model(run)
    if ref is None or not ref.elements:
        return None
    from analysis.model import Element
    return ref.with_elements([Element(el.kind, el.w.copy(), {}) for el in ref.elements])


def reverse_path_section(run: RunData, candidate=None) -> Section | None:
    """Underlying linear FRF, coefficients vs frequency and multiple coherence linear vs
    nonlinear (figs 3.6, 3.8, 3.9), computed from the random levels (pooled) when a
    candidate model is known (``candidate``, or the reference model of a simulated run)."""
    from analysis.reverse_path import reverse_path
    model = candidate_model(run, candidate)
    recs = [r for r in run.recordings if r.excitation == "random"]
    if model is None or not recs or not any(not el.known for el in model.elements):
        return None
    res = reverse_path(recs, model)
    ref = reference_model(run)
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
    return sec


def _estimated_elements(res: dict) -> list:
    from analysis.model import Element
    return [Element(e["kind"], np.asarray(e["w"], float), dict(e["params"]))
            for e in res.get("elements", []) if e.get("params")]


def hbm_sections(run: RunData, frfs: list[LevelFRF]) -> list[Section]:
    """Hysteresis loops (fig 4.7) and measured vs estimated-model FRFs (fig 4.8) from a stored
    harmonic-balance result; the reference model of a simulated run is drawn for comparison."""
    from analysis.elements import KINDS
    from analysis.hbm import loop
    found = find_result(run.results, "elements", "cost")
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
        sec.figures.append(("hysteresis_loops", figures.hysteresis_loops(loops)))
        out.append(sec)
    stepped = [(f, r) for f, r in zip(frfs, run.recordings) if f.excitation == "stepped-sine"]
    if est and ref is not None and stepped:
        fitted = [_hbm_frf(ref.with_elements(est), f, r) for f, r in stepped]
        sec = Section("Measured vs estimated model", "Stepped-sine FRFs at every level "
                      "(markers) and the harmonic-balance FRFs of the estimated model (lines), "
                      "paper fig 4.8.")
        sec.figures = [(f"hbm_fit_out{q}", figures.fitted_frfs([f for f, _ in stepped],
                                                                fitted, q))
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
    amp = rec.level if rec.level else float(np.median(np.abs(
        [sine_fit(rec.force[i, :, 0], rec.fs, f)[0]
         for i, f in enumerate(rec.freqs)])))
    system = HBMSystem(model, force_dofs=rec.force_dofs[:1])
    sweep = system.sweep(rec.freqs, [amp])
    H = np.stack([sweep.frf(q, amp) for q in range(model.n_dof)], axis=1)
    jw = 2j * np.pi * rec.freqs[:, None]
    H = H * {"displacement": 1, "velocity": jw, "acceleration": jw ** 2}[rec.response_kind]
    return rec.freqs, H


def diagnosis_section(run: RunData) -> Section | None:
    found = find_result(run.results, "verdict", "fit")
    if found is None:
        return None
    name, res = found
    fit = res["fit"]
    sec = Section("Diagnosis", html.escape(str(res.get("explanation", ""))))
    if fit.get("before") is not None and fit.get("after") is not None:
        sec.figures.append(("diagnosis_fit", figures.diagnosis_fit(
            str(fit.get("metric", "misfit")), float(fit["before"]), float(fit["after"]),
            str(res["verdict"]))))
    tr = fit.get("time_residual")
    if tr and tr.get("before") is not None and tr.get("after") is not None:
        sec.figures.append(("diagnosis_time", figures.diagnosis_fit(
            str(tr.get("metric", "time residual")), float(tr["before"]), float(tr["after"]),
            str(res["verdict"]))))
    return sec


def level_change_section(run: RunData) -> Section | None:
    """Two or more random (Welch) levels: where the FRF changes with level beyond its noise
    (`analysis.detect.level_change`)."""
    from analysis.detect import level_change
    random = [r for r in run.recordings
              if r.excitation == "random" and not r.meta.get("period")]
    if len(random) < 2:
        return None
    try:
        change = level_change(random)
    except InputError:
        return None
    t = change.summary
    verdict = (f"the FRF changes beyond its noise on {100 * t['share_flagged']:.0f} % of the "
               f"lines ({t['band_hz'][0]:.1f}-{t['band_hz'][1]:.1f} Hz): the structure is "
               "nonlinear" if t["nonlinear"] else
               f"{100 * t['share_flagged']:.1f} % of the lines change beyond the noise, as "
               "noise alone gives: no evidence of nonlinearity")
    sec = Section("Level dependence of the FRF (random levels)",
                  f"H1 at {level_text(t['levels'][0])} against {level_text(t['levels'][1])} "
                  "N rms, line by line, relative to the variance of their difference; a linear "
                  "structure exceeds the dashed line on 1 % of the lines (chance up to "
                  f"{100 * t['share_limit']:.1f} %). Here {verdict} (`nlid-lab detect`).")
    sec.figures = [("level_change", figures.level_change(change))]
    return sec


def distortion_section(frfs: list[LevelFRF]) -> Section | None:
    """Periodic-random levels: BLA with noise and nonlinear-distortion levels, and the
    detection verdict per level and response."""
    shown = [f for f in frfs if f.bla is not None]
    if not shown:
        return None
    from analysis.detect import bla_summary
    lines = []
    for frf in shown:
        t = bla_summary(frf.bla, frf.level)
        for q, (share, db) in enumerate(zip(t["by_output"], t["median_change_db"])):
            what = (f"nonlinear distortion on {100 * share:.0f} % of the lines, median "
                    f"{db:+.1f} dB over the noise" if share > t["share_limit"] else
                    f"no distortion above the noise ({100 * share:.1f} % of the lines "
                    "flagged, as noise alone gives)")
            lines.append(f"{frf.label}, response DOF {q}: {what}.")
    sec = Section("Best linear approximation and nonlinear distortion (periodic random)",
                  "Robust method (Pintelon & Schoukens): the BLA averaged over the "
                  f"{shown[0].bla.realizations} realizations, the standard deviation of that "
                  "average from the spread over periods (noise) and over realizations (noise + "
                  "stochastic nonlinear distortion). Where the total lies above the noise, a "
                  "linear model cannot explain the response. A line is flagged when the ratio "
                  "exceeds the 99 % quantile a linear system would give. " + " ".join(lines))
    n_dof = shown[0].H.shape[1]
    sec.figures = [(f"bla_distortion_out{q}", figures.bla_levels(shown, q))
                   for q in range(n_dof)]
    return sec


def sections(run: RunData, frfs: list[LevelFRF], candidate=None) -> list[Section]:
    """Every section the run has data for, in reading order."""
    out = frf_sections(frfs)
    for extra in (level_change_section(run), distortion_section(frfs)):
        if extra is not None:
            out.append(extra)
    for extra in (reverse_path_section(run, candidate), *hbm_sections(run, frfs),
                  diagnosis_section(run)):
        if extra is not None:
            out.append(extra)
    return out


# --- writing --------------------------------------------------------------------------------
def write_report(run: RunData, out_dir: str | Path, progress: Callable[[int], None] | None
                 = None, frfs: list[LevelFRF] | None = None, candidate=None
                 ) -> dict[str, Any]:
    """Write the PNG figures and ``index.html`` into ``out_dir``; returns what was written.

    ``candidate`` (a `Model`) enables the reverse-path section for runs without a stored
    reference model.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    frfs = frfs if frfs is not None else all_level_frfs(run)
    secs = sections(run, frfs, candidate)
    written = []
    for sec in secs:
        for stem, fig in sec.figures:
            fig.savefig(out_dir / f"{stem}.png")
            written.append(f"{stem}.png")
            if progress:
                progress(1)
    page = out_dir / "index.html"
    page.write_text(render_html(run, frfs, secs))
    return {"html": str(page), "figures": written, "sections": [s.title for s in secs]}


def render_html(run: RunData, frfs: list[LevelFRF], secs: list[Section]) -> str:
    esc = html.escape
    rows = "".join(f"<tr><td>{i + 1}</td><td>{esc(f.label)}</td><td>{esc(f.excitation)}</td>"
                   f"<td>{f.freqs.size}</td><td>{f.n_averages}</td></tr>"
                   for i, f in enumerate(frfs))
    body = [f"<h1>nlid-lab report: {esc(run.name)}</h1>",
            f"<p>Run file <code>{esc(str(run.path))}</code> · status <b>{esc(run.status)}</b>"
            f" · {len(frfs)} level(s) · response kind {esc(frfs[0].response_kind)}, FRF unit "
            f"{esc(frfs[0].units)}</p>",
            "<table><tr><th>#</th><th>level</th><th>excitation</th><th>frequencies</th>"
            f"<th>averages</th></tr>{rows}</table>"]
    est = _estimates_table(run.results)
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


def estimate_rows(results: dict[str, Any]) -> list[tuple[str, str, str, str, str]]:
    """(result, element, parameter, value, 95 % interval) of every stored element estimate."""
    rows = []
    for name, res in results.items():
        if not isinstance(res, dict):
            continue
        for i, el in enumerate(res.get("elements", [])):
            ci = el.get("ci95") or {}
            for par, value in (el.get("params") or {}).items():
                lo_hi = ci.get(par)
                rows.append((name, f"{i}: {el.get('kind', '?')}", par, f"{value:.5g}",
                             f"[{lo_hi[0]:.5g}, {lo_hi[1]:.5g}]" if lo_hi else "-"))
    return rows


def _estimates_table(results: dict[str, Any]) -> str:
    rows = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>"
                   for row in estimate_rows(results))
    if not rows:
        return ""
    return ("<table><tr><th>result</th><th>element</th><th>parameter</th><th>value</th>"
            f"<th>95 % interval</th></tr>{rows}</table>")
