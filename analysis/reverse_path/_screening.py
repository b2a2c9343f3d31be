"""Candidate screening for reverse path (paper eq 20 and section 3.3.1).

Every candidate ``(basis, w)`` becomes one more input ``r = -basis(w.x or w.v)`` next to the
forces; one Welch pass gives the spectral matrix of all of them. Each candidate is scored by

* its *conditioned coherence*: the ordinary coherence of the outputs with the candidate
  conditioned on the forces alone (Bendat's ``Phi``, paper eq 17-19), band- and
  output-averaged;
* its *multiple-coherence gain*, measured as decades of incoherence removed,
  ``mean(-log10(1 - gamma^2))`` over band and outputs (the plain mean saturates near 1):
  stepwise selection (forward, then dropping terms made redundant) picks the set; the gain of
  a candidate is the score of that set with it minus without it (the input order the paper
  says matters is thereby chosen by the data);
* *coefficient consistency*: estimated with the selected set (plus itself), a true element
  has a real, flat ``p(f)``: the table gives the imaginary-to-real ratio and the relative
  95 % half-width.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Sequence

import numpy as np

from .. import basis as bas
from ..errors import InputError
from ..frf import default_nperseg
from ..model import Model
from ..recording import Recording
from ._core import (_Processing, _average, _channels,
                           _element_estimates, _records)
from ..signals import excitation_band
from ..spectral import Spectra, conditioned_inputs, h1, multiple_coherence, spectral_matrix

MIN_GAIN = 0.1    # decades of incoherence a term must remove to be selected


@dataclass
class ScreeningResult:
    """Ranked candidate table.

    Attributes
    ----------
    rows : list of dict
        One per candidate, selected ones first, then by gain: ``basis``, ``w``,
        ``selected``, ``conditioned_coherence``, ``coherence_gain`` (decades),
        ``p``, ``ci95``, ``imag_ratio``, ``rel_ci``.
    coherence : list of float
        Selection score after each step (forces only first), decades.
    band : (lo, hi)
    """

    rows: list[dict[str, Any]]
    coherence: list[float]
    band: tuple[float, float]

    def table(self) -> str:
        """Readable table."""
        out = [f"{'rank':>4} {'basis':<8} {'w':<22} {'sel':>3} {'cond.coh':>8} {'gain':>8} "
               f"{'p':>11} {'|Im/Re|':>8} {'ci/p':>8}"]
        for k, r in enumerate(self.rows, 1):
            w = "[" + ", ".join(f"{v:g}" for v in r["w"]) + "]"
            out.append(f"{k:>4} {r['basis']:<8} {w:<22} {'*' if r['selected'] else '':>3} "
                       f"{r['conditioned_coherence']:8.4f} {r['coherence_gain']:8.4f} "
                       f"{r['p']:11.4g} {r['imag_ratio']:8.3f} {r['rel_ci']:8.3f}")
        return "\n".join(out)

    def to_json(self) -> dict[str, Any]:
        return {"ranking": self.rows, "coherence_steps": self.coherence,
                "band_hz": list(self.band)}


def default_locations(n_dof: int) -> list[np.ndarray]:
    """Each grounded DOF (``e_i``) and each DOF pair (``e_j - e_i``, ``i < j``)."""
    eye = np.eye(n_dof)
    return [eye[i] for i in range(n_dof)] + [eye[j] - eye[i] for i in range(n_dof)
                                             for j in range(i + 1, n_dof)]


def screen_candidates(data: Any, model: Model,
                      candidates: Sequence[tuple[str, Sequence[float]]] | None = None, *,
                      locations: Sequence[Sequence[float]] | None = None,
                      bases: Sequence[str] | None = None, fs: float | None = None,
                      force_dofs: Sequence[int] | None = None,
                      response_kind: str = "displacement",
                      band: tuple[float, float] | None = None, nperseg: int | None = None,
                      force_hold: str | None = None, max_terms: int = 6) -> ScreeningResult:
    """Rank candidate nonlinear functions and locations (see module docstring).

    Parameters
    ----------
    data : Recording, list of Recording, or (force, response) arrays
        As for `analysis.reverse_path.reverse_path`.
    model : Model
        Its linear part sizes the problem; its complete elements are included as known
        forces, its incomplete ones are ignored (the candidates replace them).
    candidates : list of (basis name, w), optional
        Default: every basis in ``bases`` at every location in ``locations``.
    locations : list of w, optional
        Default: `default_locations`.
    bases : list of str, optional
        Names in `analysis.basis.LIBRARY` (default: all of it, paper eq 20 and more).
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
    cands = _candidate_list(candidates, locations, bases, n_dof)
    known = [(i, el) for i, el in enumerate(model.elements) if el.known]
    unknown = [(k, SimpleNamespace(w=w), None, fn) for k, (fn, w) in enumerate(cands)]
    fsr = float(rec0.fs)
    nps = (nperseg if nperseg is not None
           else default_nperseg(min(r.force.shape[0] for r, _ in recs)))
    if band is None:
        fspec = Spectra.pool([spectral_matrix(r.force, fsr, nperseg=nps) for r, _ in recs])
        band = excitation_band(fspec.freqs, fspec.auto())
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
    return _rank(spec, n_dof, base, first, cands, rec0.force_dofs, band, max_terms)


def _candidate_list(candidates, locations, bases, n_dof: int) -> list[tuple[bas.Basis, np.ndarray]]:
    if candidates is None:
        names = list(bases) if bases is not None else list(bas.LIBRARY)
        locs = locations if locations is not None else default_locations(n_dof)
        candidates = [(name, w) for w in locs for name in names]
    out = []
    for name, w in candidates:
        if name not in bas.LIBRARY:
            raise InputError(f"unknown basis '{name}'; choose from {', '.join(bas.LIBRARY)}")
        w = np.asarray(w, dtype=float)
        if w.shape != (n_dof,) or not np.any(w):
            raise InputError(f"location {w.tolist()} must be a non-zero vector of {n_dof} "
                             "entries")
        out.append((bas.LIBRARY[name], w))
    if not out:
        raise InputError("no candidate to screen; give bases and locations")
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


def _rank(spec: Spectra, n_dof: int, base: list[int], first: int, cands, fdofs, band,
          max_terms: int) -> ScreeningResult:
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
    rows = []
    for c in idx:
        fn, w = cands[c - first]
        others = base + [s for s in selected if s != c]
        gain = (final if c in selected else _score(spec, n_dof, others + [c])) \
            - _score(spec, n_dof, others)
        rows.append({"basis": fn.name, "w": w.tolist(), "selected": c in selected,
                     "conditioned_coherence": cond_coh[c], "coherence_gain": float(gain),
                     **_consistency(spec, n_dof, base, selected, c, w, fdofs, fn.name)})
    rows.sort(key=lambda r: (not r["selected"], -r["coherence_gain"]))
    return ScreeningResult(rows, steps, band)


def _consistency(spec: Spectra, n_dof: int, base: list[int], selected: list[int], c: int,
                 w: np.ndarray, fdofs: np.ndarray, name: str) -> dict[str, Any]:
    """Coefficient of candidate ``c`` estimated with the selected set."""
    cols = base + [s for s in selected if s != c] + [c]
    S = spec.S
    S_xr, S_rr = S[:, :n_dof][:, :, cols], S[:, cols][:, :, cols]
    S_xx = np.einsum("fii->fi", S[:, :n_dof, :n_dof]).real
    nan = {"p": float("nan"), "ci95": [float("nan")] * 2, "imag_ratio": float("nan"),
           "rel_ci": float("nan")}
    try:
        H = h1(S_xr, S_rr)
        rr_inv = np.linalg.inv(S_rr)
    except (InputError, np.linalg.LinAlgError):
        return nan
    coh = multiple_coherence(S_xx, S_xr, S_rr)
    sigma2 = np.maximum((1 - coh) * S_xx, 1e-15 * S_xx) / max(spec.n_eff - len(cols), 1.0)
    est, var = _element_estimates(H, rr_inv, sigma2, w, fdofs, len(cols) - 1)
    co = _average(c, SimpleNamespace(kind=name, w=w), "p", name, est, var, spec.bin_factor)
    scale = max(abs(co.value), 1e-300)
    return {"p": co.value, "ci95": list(co.ci95), "imag_ratio": abs(co.imag) / scale,
            "rel_ci": (co.ci95[1] - co.value) / scale}
