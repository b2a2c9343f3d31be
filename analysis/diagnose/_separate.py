"""What would separate two kinds the data cannot tell apart (`.policy.kind_ties`).

Two kinds fitted to the same levels (a cubic spring and a gap whose width is refitted, say)
make about the same equivalent stiffness over the tested deformations and differ beyond them.
Each fitted law is replaced by its equivalent linear stiffness along the measured deformation
``u`` of the highest fitting level scaled by ``s`` (``k(s) = <g(s u), s u> / <s u, s u>``,
the linearization the FRF fit itself makes at ``s = 1``, keeping the measured distribution's
shape; plus the stiffness correction fitted jointly with it). The two stiffnesses, added at
the location to the current model's linear part, give two FRFs at that level; their
distance in the units the tie was judged in (``chi2`` of that level's noise, `.compare.chi2`)
is compared with the tie's own threshold (`.outofsample.tied`: the noise's deviations
combined, or the misfit either leaves, whichever is larger). The smallest ``s`` at which it
exceeds that threshold is the deformation a test would need (the force to reach it scales
only roughly with it: a hardening structure moves less), and `AT` is always reported.

Only for memoryless restoring kinds (springs, gaps) and stiffness errors on random data,
where the deformation along the location is measured: a dissipative or memory kind, or a
stepped-sine search, gives no separation (None), and the explanation says a level beyond
the fitted ones would.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..models import KINDS, LINEAR_PARAM, Candidate, restoring_force
from ._compare import chi2, model_frf
from ._linear_update import updated_receptance
from ._result import KindSeparation
from ._select import Search

AT = 1.5
"""Scale of the highest fitting level at which both kinds' predictions are always given."""
SCALES = np.geomspace(1.0, 4.0, 61)
"""Scales of the highest level's deformation searched for the separating one."""
MAX_SAMPLES = 16384
"""Samples of the measured deformation used (every k-th: its distribution is what counts)."""


def equivalent_stiffness(kind: str, params: dict[str, float], u: np.ndarray,
                         scales: np.ndarray) -> np.ndarray:
    """``<g(s u), s u> / <s u, s u>`` along the measured deformation ``u`` scaled by each
    of ``scales``; a stiffness error is its own constant."""
    if kind == "stiffness_error":
        return np.full(scales.shape, params[LINEAR_PARAM[kind]])
    su = scales[:, None] * u[None, :]
    g = restoring_force(kind, params, su.ravel(), np.zeros(su.size))[0].reshape(su.shape)
    return np.sum(g * su, axis=1) / np.sum(su * su, axis=1)


def separable(kind: str) -> bool:
    """Whether a kind's equivalent stiffness says what it predicts (memoryless and
    restoring, or a stiffness error)."""
    if kind == "stiffness_error":
        return True
    spec = KINDS.get(kind)
    return spec is not None and not (spec.memory or spec.dissipative)


@dataclass(frozen=True)
class Law:
    """A tied kind's law as scored: candidate, parameters and their 95 % intervals, and the
    stiffness correction at its location fitted jointly with it (N/m, 0 without)."""

    cand: Candidate
    params: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    joint: float = 0.0


def separation(search: Search, named: Law, other: Law, threshold: float
               ) -> KindSeparation | None:
    """What separates ``named`` from the tied ``other`` at the highest fitting level of
    ``search`` (``threshold``: the tie's, `chi2`), or None where it cannot be computed (see
    the module)."""
    a, b = named.cand, other.cand
    if not (separable(a.kind) and separable(b.kind)) or a.dofs != b.dofs:
        return None
    top = max(range(len(search.levels)), key=lambda i: search.levels[i].level)
    u = search.deformation(a, top)
    if u is None or not np.any(u):
        return None
    u = u[:: max(1, u.size // MAX_SAMPLES)]
    lf, hl, hm = search.levels[top], search.H_lins[top], search.H_modes[top]
    s = np.unique(np.concatenate([SCALES, [AT]]))
    ks = [equivalent_stiffness(f.cand.kind, f.params, u, s) + f.joint
          for f in (named, other)]

    def frf(k: float) -> np.ndarray:
        return model_frf(updated_receptance(hl, hm, "stiffness_error", a.w, k, lf.freqs)[0],
                         lf, search.terms)

    diff = np.array([chi2(replace(lf, H=frf(ka)), frf(kb)) for ka, kb in zip(*ks)])
    beyond = np.flatnonzero(diff > threshold)
    i = int(np.flatnonzero(s == AT)[0])
    return KindSeparation(float(lf.level), float(threshold), float(diff[0]), AT,
                          float(diff[i]), (float(ks[0][i]), float(ks[1][i])),
                          float(s[beyond[0]]) if beyond.size else None)
