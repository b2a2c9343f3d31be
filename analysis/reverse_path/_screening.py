"""Candidate screening for reverse path (paper eq 20 and section 3.3.1).

The library is every registered element kind whose basis can be formed from the data alone
(memoryless, linear in one coefficient, any other parameter with a default: `screenable_kinds`)
at every location of the diagnosis library (`analysis.models.locations`: each
grounded DOF, ``w = e_i``, and each pair ``i < j``, ``w = e_j - e_i``). Every candidate
``(kind, w)`` becomes one more input ``r = -basis(w.x or w.v)`` next to the forces; one Welch
pass gives the spectral matrix of all of them. Each candidate is scored by

* its *conditioned coherence*: the ordinary coherence of the outputs with the candidate
  conditioned on the forces alone (Bendat's ``Phi``, paper eq 17-19), band- and
  output-averaged;
* its *multiple-coherence gain*, measured as decades of incoherence removed,
  ``mean(-log10(1 - gamma^2))`` over band and outputs (the plain mean saturates near 1):
  stepwise selection (forward, then dropping terms made redundant) picks the set; the gain of
  a candidate is the score of that set with it minus without it (the input order the paper
  says matters is thereby chosen by the data);
* *coefficient significance and consistency*: estimated with the selected set (plus itself),
  ``|p| / sigma`` (``sigma`` the standard error of the frequency-averaged coefficient, which
  already takes the larger of the line-by-line and the sub-band spread) and the
  imaginary-to-real ratio (a true element has a real, flat ``p(f)``).

A candidate is *significant* when it is selected (removes at least `MIN_GAIN` decades) and
``|p| / sigma`` exceeds the two-sided 5 % family-wise critical value over all candidates
screened (Bonferroni, Student t with the batch-means degrees of freedom): on a linear
structure every candidate is noise, and the chance that any of them passes is below 5 %.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Sequence

import numpy as np
from scipy.stats import t as student_t

from .. import models as bas    # the reverse-path basis functions of a kind
from ..models import KINDS, Candidate, Element, Model, locations, search_order
from ..errors import EstimationError, InputError
from ..spectral import (Spectra, conditioned_inputs, default_nperseg, h1, multiple_coherence,
                        spectral_matrix)
from ..recordings import Recording, excitation_band
from ._core import (N_BATCHES, _Processing, _average, _channels,
                    _element_estimates, _integrated, _records)
from ._documents import CandidateCoefficient, ScreeningRow

MIN_GAIN = 0.1    # decades of incoherence a term must remove to be selected
FAMILY_ALPHA = 0.05   # chance that any candidate of a linear structure is called significant


@dataclass(frozen=True)
class _Candidate:
    """One screened term: ``basis`` of ``u = w.x`` (or ``w.v``), the model kind it stands for
    (None for a basis no kind has) and where it acts."""

    basis: bas.Basis
    w: np.ndarray
    kind: str | None
    where: str

    @property
    def label(self) -> str:
        return f"{self.kind or self.basis.name} {self.where}"


@dataclass
class ScreeningResult:
    """Ranked candidate table.

    Attributes
    ----------
    rows : list of ScreeningRow
        One per candidate, best first (significant, then selected, then by gain): ``rank``,
        ``kind`` (model-file kind, None for a basis no kind has), ``where``, ``label``,
        ``basis``, ``w``, ``selected``, ``significant``, ``conditioned_coherence``,
        ``coherence_gain`` (decades), ``param``, ``p``, ``ci95``, ``z`` (``|p|/sigma``),
        ``imag_ratio``, ``rel_ci``, ``in_model`` (the screened model already has this kind
        at this ``w``).
    coherence : list of float
        Selection score after each step (forces only first), decades.
    band : (lo, hi)
    z_crit : float
        ``|p|/sigma`` a selected candidate needs to be significant.
    """

    rows: list[ScreeningRow]
    coherence: list[float]
    band: tuple[float, float]
    z_crit: float

    @property
    def chosen(self) -> list[ScreeningRow]:
        """The significant candidates, best first."""
        return [r for r in self.rows if r["significant"]]

    def criterion(self) -> str:
        """The significance rule in words, with its numbers."""
        return (f"significant (sig *): selected, i.e. removes >= {MIN_GAIN:g} decades of "
                f"incoherence, and |p|/sigma >= {self.z_crit:.2f} (two-sided "
                f"{100 * FAMILY_ALPHA:g} % family-wise over {len(self.rows)} candidates, "
                "Bonferroni)")

    def snippet(self) -> str:
        """``[[element]]`` tables (kind and w, parameters omitted) adding the chosen
        candidates the model does not hold yet to a model file; empty when there is none."""
        out = []
        for r in self.chosen:
            if r["kind"] is None or r["in_model"]:
                continue
            w = "[" + ", ".join(repr(float(v)) for v in r["w"]) + "]"
            out += [f"[[element]]    # screened: {r['label']}, {r['param']} to estimate",
                    f'kind = "{r["kind"]}"', f"w = {w}", ""]
        return "\n".join(out)

    def table(self) -> str:
        """Readable table."""
        width = max([len("candidate")] + [len(r["label"]) for r in self.rows])
        out = [f"{'rank':>4}  {'candidate':<{width}} {'basis':<8} {'sel':>3} {'sig':>3} "
               f"{'cond.coh':>8} {'gain':>7} {'coefficient':>15} {'|p|/sig':>9} "
               f"{'|Im/Re|':>8} {'ci/p':>8}"]
        for r in self.rows:
            coef = f"{r['param']} = {r['p']:.4g}"
            out.append(f"{r['rank']:>4}  {r['label']:<{width}} {r['basis']:<8} "
                       f"{'*' if r['selected'] else '':>3} {'*' if r['significant'] else '':>3} "
                       f"{r['conditioned_coherence']:8.4f} {r['coherence_gain']:7.3f} "
                       f"{coef:>15} {r['z']:9.3g} {r['imag_ratio']:8.3f} {r['rel_ci']:8.3f}")
        out.append(self.criterion())
        return "\n".join(out)

    def to_json(self) -> dict[str, Any]:
        """The ranking, coherence steps, band, significance rule and chosen candidates as JSON."""
        return {"ranking": self.rows, "coherence_steps": self.coherence,
                "band_hz": list(self.band),
                "significance": {"min_gain_decades": MIN_GAIN, "z_crit": self.z_crit,
                                 "family_alpha": FAMILY_ALPHA, "n_candidates": len(self.rows)},
                "chosen": [r["label"] for r in self.chosen], "snippet": self.snippet()}


def screenable_kinds() -> dict[str, bas.Basis]:
    """Every registered kind whose basis screening forms from the data alone, with that basis.

    These are the memoryless kinds linear in one coefficient whose other parameters (if any)
    have defaults, in `analysis.models.search_order`. Memory kinds (not linear in their
    parameters) and kinds needing a parameter without a default (``gap`` width) are left out.
    """
    out = {}
    for kind in search_order():
        try:
            out[kind] = bas.element_basis(Element(kind, np.ones(1), {}))[1]
        except (EstimationError, InputError):
            continue
    return out


def default_locations(n_dof: int) -> list[np.ndarray]:
    """Each grounded DOF (``e_i``) and each DOF pair (``e_j - e_i``, ``i < j``): the
    diagnosis library's locations."""
    return [Candidate("", dofs, n_dof).w for dofs in locations(n_dof)]


def _where(w: np.ndarray) -> str:
    """The diagnosis's name of a location, or the vector itself."""
    nz = np.flatnonzero(w)
    if nz.size == 1 and w[nz[0]] == 1.0:
        return Candidate("", (int(nz[0]),), w.size).where
    if nz.size == 2 and w[nz[0]] == -1.0 and w[nz[1]] == 1.0:
        return Candidate("", (int(nz[0]), int(nz[1])), w.size).where
    return "at w = [" + ", ".join(f"{v:g}" for v in w) + "]"


def screen_candidates(data: Any, model: Model,
                      candidates: Sequence[tuple[str, Sequence[float]]] | None = None, *,
                      locations: Sequence[Sequence[float]] | None = None,
                      kinds: Sequence[str] | None = None, fs: float | None = None,
                      force_dofs: Sequence[int] | None = None,
                      response_kind: str = "displacement",
                      band: tuple[float, float] | None = None, nperseg: int | None = None,
                      force_hold: str | None = None, max_terms: int = 6) -> ScreeningResult:
    """Rank candidate nonlinear elements and locations (see module docstring).

    Parameters
    ----------
    data : Recording, list of Recording, or (force, response) arrays
        As for `analysis.reverse_path.reverse_path`.
    model : Model
        Its linear part sizes the problem; its complete elements are included as known
        forces, its incomplete ones are ignored (the candidates replace them). A linear model
        (no elements) screens for every nonlinearity.
    candidates : list of (name, w), optional
        ``name`` an element kind of `screenable_kinds` or a basis of
        `analysis.models.LIBRARY` (e.g. ``"x^5"``; named after its kind when one has it).
        Default: every kind in ``kinds`` at every location in ``locations``.
    locations : list of w, optional
        Default: `default_locations`.
    kinds : list of str, optional
        Default: every kind of `screenable_kinds`.
    fs, force_dofs, response_kind, band, nperseg, force_hold
        As for `reverse_path`.
    max_terms : int
        At most this many forward-selection steps.

    Returns
    -------
    ScreeningResult
    """
    recs = _records(data, fs, force_dofs, response_kind)
    rec0: Recording = recs[0][0]
    n_dof = model.n_dof
    if rec0.n_dof != n_dof:
        raise InputError(f"the response has {rec0.n_dof} channels but the model has "
                         f"{n_dof} DOFs; screening needs every DOF measured")
    cands = _candidate_list(candidates, locations, kinds, n_dof)
    known = [(i, el) for i, el in enumerate(model.elements) if el.known]
    unknown = [(k, SimpleNamespace(w=c.w), None, c.basis) for k, c in enumerate(cands)]
    fsr = float(rec0.fs)
    nps = (nperseg if nperseg is not None
           else default_nperseg(min(r.force.shape[0] for r, _ in recs)))
    if band is None:
        fspec = Spectra.pool([spectral_matrix(r.force, fsr, nperseg=nps) for r, _ in recs])
        band = excitation_band(fspec.freqs, fspec.auto(), kind=_integrated(recs))
    band = (float(band[0]), float(band[1]))
    parts = []
    for rec, kind in recs:
        proc = _Processing(fsr, kind, band, "auto",
                           force_hold or rec.force_hold, None)
        ch, _ = _channels(rec.response, rec.force, rec.force_dofs, proc, unknown, known, [],
                          None)
        parts.append(spectral_matrix(ch, fsr, nperseg=nps, band=band))
    spec = Spectra.pool(parts)
    n_in = rec0.force_dofs.size
    n_known = spec.S.shape[1] - n_dof - n_in - len(cands)
    base = list(range(n_dof, n_dof + n_in + n_known))      # forces and known nuisances
    first = n_dof + n_in + n_known
    res = _rank(spec, n_dof, base, first, cands, rec0.force_dofs, band, max_terms)
    present = {(el.kind, tuple(el.w.tolist())) for el in model.elements}
    for r in res.rows:
        r["in_model"] = (r["kind"], tuple(r["w"])) in present
    return res


def _candidate_list(candidates, locations, kinds, n_dof: int) -> list[_Candidate]:
    library = screenable_kinds()
    if candidates is None:
        names = list(kinds) if kinds is not None else list(library)
        locs = locations if locations is not None else default_locations(n_dof)
        candidates = [(name, w) for w in locs for name in names]
    kind_of_basis = {b.name: k for k, b in reversed(library.items())}
    out = []
    for name, w in candidates:
        if name in library:
            kind, fn = name, library[name]
        elif name in bas.LIBRARY:
            kind, fn = kind_of_basis.get(name), bas.LIBRARY[name]
        else:
            raise InputError(f"'{name}' is neither a kind screening can form ("
                             f"{', '.join(library)}) nor a basis ({', '.join(bas.LIBRARY)})")
        w = np.asarray(w, dtype=float)
        if w.shape != (n_dof,) or not np.any(w):
            raise InputError(f"location {w.tolist()} must be a non-zero vector of {n_dof} "
                             "entries")
        out.append(_Candidate(fn, w, kind, _where(w)))
    if not out:
        raise InputError("no candidate to screen; give kinds and locations")
    return out


def _score(spec: Spectra, n_dof: int, cols: list[int]) -> float:
    """Band/output mean of ``-log10(1 - multiple coherence)``: decades of incoherence removed."""
    S = spec.S
    S_xx = np.einsum("fii->fi", S[:, :n_dof, :n_dof]).real
    try:
        coh = multiple_coherence(S_xx, S[:, :n_dof][:, :, cols], S[:, cols][:, :, cols])
    except InputError:                 # collinear inputs: no information added
        return -np.inf
    return float(np.mean(-np.log10(np.clip(1 - coh, 1e-12, 1))))


def _rank(spec: Spectra, n_dof: int, base: list[int], first: int, cands: list[_Candidate],
          fdofs: np.ndarray, band: tuple[float, float], max_terms: int) -> ScreeningResult:
    S = spec.S
    S_xx = np.einsum("fii->fi", S[:, :n_dof, :n_dof]).real
    idx = list(range(first, first + len(cands)))
    cond_coh = {}
    for c in idx:                     # conditioned on the forces only: last in the order
        cols = base + [c]
        cond = conditioned_inputs(S_xx, S[:, :n_dof][:, :, cols], S[:, cols][:, :, cols])
        cond_coh[c] = float(np.mean(cond.coherence[:, :, -1]))
    selected: list[int] = []
    steps = [_score(spec, n_dof, base)]
    while len(selected) < max_terms:            # forward selection
        trial = {c: _score(spec, n_dof, base + selected + [c]) for c in idx
                 if c not in selected}
        best = max(trial, key=trial.get) if trial else None
        if best is None or trial[best] - steps[-1] < MIN_GAIN:
            break
        selected.append(best)
        steps.append(trial[best])
        while len(selected) > 1:                # backward: drop terms made redundant
            loss = {c: steps[-1] - _score(spec, n_dof, base + [s for s in selected if s != c])
                    for c in selected}
            worst = min(loss, key=loss.get)
            if loss[worst] >= MIN_GAIN:
                break
            selected.remove(worst)
            steps.append(steps[-1] - loss[worst])
    final = _score(spec, n_dof, base + selected)
    # Student t with the batch-means degrees of freedom: the widest quantile `_average` uses
    z_crit = float(student_t.ppf(1 - FAMILY_ALPHA / (2 * len(cands)), N_BATCHES - 1))
    rows = []
    for c in idx:
        cand = cands[c - first]
        others = base + [s for s in selected if s != c]
        gain = (final if c in selected else _score(spec, n_dof, others + [c])) \
            - _score(spec, n_dof, others)
        coef = _consistency(spec, n_dof, base, selected, c, cand, fdofs)
        rows.append({"kind": cand.kind, "where": cand.where, "label": cand.label,
                     "basis": cand.basis.name, "w": cand.w.tolist(),
                     "selected": c in selected,
                     "significant": bool(c in selected and coef["z"] >= z_crit),
                     "conditioned_coherence": cond_coh[c], "coherence_gain": float(gain),
                     "param": KINDS[cand.kind].coef if cand.kind else "p", **coef})
    rows.sort(key=lambda r: (not r["significant"], not r["selected"], -r["coherence_gain"]))
    rows = [{"rank": k, **r} for k, r in enumerate(rows, 1)]
    return ScreeningResult(rows, steps, band, z_crit)


def _consistency(spec: Spectra, n_dof: int, base: list[int], selected: list[int], c: int,
                 cand: _Candidate, fdofs: np.ndarray) -> CandidateCoefficient:
    """Coefficient of candidate ``c`` estimated with the selected set: value, 95 % interval,
    ``|p|/sigma``, ``|Im p|/|Re p|`` and the relative 95 % half-width."""
    cols = base + [s for s in selected if s != c] + [c]
    S = spec.S
    S_xr, S_rr = S[:, :n_dof][:, :, cols], S[:, cols][:, :, cols]
    S_xx = np.einsum("fii->fi", S[:, :n_dof, :n_dof]).real
    nan = float("nan")
    try:
        H = h1(S_xr, S_rr)
        rr_inv = np.linalg.inv(S_rr)
    except (InputError, np.linalg.LinAlgError):
        return {"p": nan, "ci95": [nan, nan], "z": nan, "imag_ratio": nan, "rel_ci": nan}
    coh = multiple_coherence(S_xx, S_xr, S_rr)
    sigma2 = np.maximum((1 - coh) * S_xx, 1e-15 * S_xx) / max(spec.n_eff - len(cols), 1.0)
    est, var = _element_estimates(H, rr_inv, sigma2, cand.w, fdofs, len(cols) - 1)
    name = cand.basis.name
    co = _average(c, SimpleNamespace(kind=name, w=cand.w), "p", name, est, var,
                  spec.bin_factor)
    scale = max(abs(co.value), 1e-300)
    return {"p": co.value, "ci95": list(co.ci95), "z": abs(co.value) / max(co.std, 1e-300),
            "imag_ratio": abs(co.imag) / scale, "rel_ci": (co.ci95[1] - co.value) / scale}
