"""Which of two tied kinds the data prefer when each is given the other (`.policy.kind_ties`).

Two kinds whose out-of-sample gains tie (`.outofsample.tied`) may still not be equivalent:
the model with one of them can leave a level dependence that the other explains, and not the
reverse. The encompassing test of non-nested models (Mizon & Richard 1986; the J test of
Davidson & MacKinnon 1981) asks exactly that: kind ``b`` is scored out of sample
(`.outofsample.score`, the same rule as every candidate) on the model that already holds
``a`` at its scored estimate, with ``a``'s force scale (and the stiffness correction fitted
jointly with either) free, so that ``b`` is not credited with ``a``'s estimation error. ``b``
encompasses ``a`` when it wins there and ``a`` does not win on the model holding ``b``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ._compare import model_frf
from ._linear_update import updated_receptance
from ._outofsample import Predictor, Score, score
from ._select import Fit, Search, coef_name

Held = tuple[Fit, Score]
"""A tied kind's fit and its out-of-sample score."""


def testable(fit: Fit) -> bool:
    """Whether the test applies: a nonlinear element with a force basis (not a linear
    error, nor a memory law fitted in all its parameters without one)."""
    return not fit.cand.linear and not (fit.cand.memory and fit.extra is None)


def adds_to(search: Search, b: Held, a: Held) -> bool:
    """Whether ``b`` wins out of sample on the model holding ``a`` (see the module)."""
    (fa, sa), (fb, sb) = a, b
    search.ensure_basis(fa.cand, fa.extra)
    search.ensure_basis(fb.cand, fb.extra)
    joint = sa.joint is not None or sb.joint is not None
    pb = _coef(fb, sb)
    predict = _predict(search, a, b, joint)
    theta = np.array([pb, 0.0] + ([sa.joint or 0.0] if joint else []))
    scale = np.array([abs(pb) or 1.0, 1.0]
                     + ([search.linear_size("stiffness_error", fa.cand.w)] if joint else []))
    base = predict(np.array([0.0, 0.0] + ([sa.joint or 0.0] if joint else [])))
    pred = Predictor(predict, theta, 1, scale, joint_at=2 if joint else None)
    return score(search.levels, base, pred, sa.ref).wins


def _coef(fit: Fit, s: Score) -> float:
    """The kind's coefficient as scored (jointly with a stiffness correction: its joint
    estimate)."""
    return float(s.estimate[0]) if s.joint is not None else float(
        fit.params[coef_name(fit.cand.kind)])


def _predict(search: Search, a: Held, b: Held, joint: bool
             ) -> Callable[[np.ndarray], list[np.ndarray]]:
    """``t -> model FRFs``: ``t[0]`` ``b``'s coefficient, ``t[1]`` the relative change of
    ``a``'s, ``t[2]`` (``joint``) the stiffness correction at ``a``'s location."""
    (fa, sa), (fb, _) = a, b
    ca, cb, pa = fa.cand, fb.cand, _coef(*a)

    def predict(t: np.ndarray) -> list[np.ndarray]:
        terms = search.terms + [(ca.w, pa * (1 + t[1]), (ca, fa.extra)),
                                (cb.w, t[0], (cb, fb.extra))]
        out = []
        for lf, hl, hm in zip(search.levels, search.H_lins, search.H_modes):
            if joint:
                hl = updated_receptance(hl, hm, "stiffness_error", ca.w, t[2], lf.freqs)[0]
            out.append(model_frf(hl, lf, terms))
        return out
    return predict


def encompassing(search: Search, tied: list[Held]) -> Held | None:
    """The one kind of ``tied`` that encompasses every other (`adds_to` one way only), or
    None when no single kind does (the tie stands)."""
    if len(tied) < 2 or not all(testable(f) for f, _ in tied):
        return None
    for b in tied:
        others = [a for a in tied if a is not b]
        if all(adds_to(search, b, a) and not adds_to(search, a, b) for a in others):
            return b
    return None
