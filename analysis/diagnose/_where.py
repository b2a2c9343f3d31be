"""Where the effect is: the location table and the locations the data cannot separate.

Every location of the library (each point the model lets be grounded, every pair of measured
points) is scored by its best candidate of the first search pass: the refined estimate where
the pass refined one, else its screening fit (`.select.Search.screen`), so that a joint is
scored even when no candidate of it reached the shortlist. A pair's row carries the best
grounded candidate at either end and the measured relative motion across it; a grounded
row the best joint through its point: joints and supports are shown side by side.

Two locations are *not separable* (`alternatives`) when

* their scores are within `SEPARATE` BIC points of each other (the evidence a discrepancy
  itself needs, Kass & Raftery's "very strong") and both explain the data on their own, or
* they are linked by a pair whose sensors move nearly together: the relative motion across
  it (the largest over the fitting levels) is below `RIGID` of the absolute and the other
  location still gains BIC points (a joint there and a support at either end act on nearly
  the same motion; the first is told from the second only through the few per cent by which
  the sensors differ, which a model-form error of that size swamps).
"""

from __future__ import annotations

import copy
import weakref
from typing import Sequence

import numpy as np

from ..models import Candidate
from ._compare import LevelFRF
from ._evidence import GroundedEnd, LocationRow, PairThrough
from ._result import Alternative
from ._select import Fit, Search

SEPARATE = 10.0
"""BIC points by which one location must beat another to be told apart from it (the same
"very strong" evidence, Kass & Raftery, that a discrepancy needs over no correction)."""

RIGID = 0.10
"""Relative motion across a pair (rms of the difference over the larger rms) below which its
sensors move nearly together (issue 24: 5-10 % on a real GVT's bolted interface)."""

MAX_ALTERNATIVES = 4
"""Alternatives listed at most (the best scored first)."""

_SCREENED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def screened(search: Search) -> list[Fit]:
    """``search.screen()``, computed once per search (the pool, the table and the
    alternatives share it); read it, do not edit its fits (`screening` copies them)."""
    if search not in _SCREENED:
        _SCREENED[search] = search.screen()
    return _SCREENED[search]


def screening(search: Search) -> list[Fit]:
    """A copy of `screened` whose fits the caller may refit in place (the candidates shared)."""
    return [copy.deepcopy(f, {id(f.cand): f.cand}) for f in screened(search)]


def best_by_location(search: Search, pool: Sequence[Fit], linear: bool | None = None
                     ) -> dict[tuple[int, ...], Fit]:
    """The best fit at each location: ``pool``'s (refined) fit where it holds one, else the
    screening fit (``linear``: only linear errors, only nonlinear kinds, or None: both)."""
    best: dict[tuple[int, ...], Fit] = {}
    for fits in (pool, screened(search)):
        seen = dict(best)
        for f in fits:
            if linear is not None and f.cand.linear != linear:
                continue
            d = f.cand.dofs
            if d in seen:
                continue                  # a location the pool scored keeps the pool's fit
            if d not in best or f.delta_bic > best[d].delta_bic:
                best[d] = f
    return best


def top_level(search: Search) -> LevelFRF:
    """The highest fitting level of ``search``."""
    return max(search.levels, key=lambda lf: lf.level)


def largest_relative_motion(search: Search, i: int, j: int) -> tuple[float, LevelFRF]:
    """The largest `relative_motion` across ``(i, j)`` over the fitting levels (a joint that
    slips at the top level moves its sides apart there), and its level."""
    return max(((relative_motion(lf, i, j), lf) for lf in search.levels), key=lambda t: t[0])


def relative_motion(lf: LevelFRF, i: int, j: int) -> float:
    """``rms(x_j - x_i) / max(rms x_i, rms x_j)`` of the measured FRFs of level ``lf`` in the
    recorded response kind, under a flat force over its lines (every input summed)."""
    wgt = (2 * np.pi * lf.freqs) ** (2 * lf.kind_order)
    hi, hj = lf.H[:, i, :], lf.H[:, j, :]
    num = float(np.sum(wgt[:, None] * np.abs(hj - hi) ** 2))
    den = max(float(np.sum(wgt[:, None] * np.abs(hi) ** 2)),
              float(np.sum(wgt[:, None] * np.abs(hj) ** 2)), 1e-300)
    return float(np.sqrt(num / den))


def _reduction(search: Search, f: Fit) -> float:
    return float((search.chi2_0 - f.chi2) / search.chi2_0)


def location_table(search: Search, pool: list[Fit]) -> tuple[LocationRow, ...]:
    """Every location ranked by its best candidate (`best_by_location`), with its kind, misfit
    reduction and BIC gain; a pair also with the best grounded candidate at either end and
    the relative motion across it, a grounded point with the best joint through it."""
    best = best_by_location(search, pool)
    rows = []
    for dofs, f in sorted(best.items(), key=lambda kv: -kv[1].delta_bic):
        end, through, rel = None, None, None
        if len(dofs) == 2:
            rel = largest_relative_motion(search, *dofs)[0]
            ends = [best[(d,)] for d in dofs if (d,) in best]
            if ends:
                g = max(ends, key=lambda e: e.delta_bic)
                end = GroundedEnd(tuple(g.cand.points), g.cand.kind, _reduction(search, g))
        else:
            pairs = [p for p in best.values() if len(p.cand.dofs) == 2 and dofs[0] in p.cand.dofs]
            if pairs:
                p = max(pairs, key=lambda e: e.delta_bic)
                through = PairThrough(tuple(p.cand.points), p.cand.kind, _reduction(search, p),
                                      float(p.delta_bic),
                                      largest_relative_motion(search, *p.cand.dofs)[0])
        rows.append(LocationRow(tuple(f.cand.points), dofs, f.cand.kind, _reduction(search, f),
                                float(f.delta_bic), end, rel, through))
    return tuple(rows)


def _link(a: tuple[int, ...], b: tuple[int, ...]) -> tuple[int, int] | None:
    """The pair linking locations ``a`` and ``b`` (a joint and a support at one of its ends,
    or supports at both ends of a pair), None when they share no pair."""
    if len(a) + len(b) == 3 and set(a) & set(b):
        pair = a if len(a) == 2 else b
        return pair[0], pair[1]
    if len(a) == len(b) == 1:
        i, j = sorted((a[0], b[0]))
        return i, j
    return None


def _point(c: Candidate, d: int) -> str:
    """The name of point ``d`` of ``c``'s model (``DOF d`` when the points are numbered)."""
    return c.names[d] if c.names else f"DOF {d}"


def _drive_advice(lf: LevelFRF, c: Candidate, pair: tuple[int, int]) -> str:
    """Where to drive to make the two sides of ``pair`` move apart: at the end that is not
    driven now (either end when neither is)."""
    driven = {int(i) for i in np.flatnonzero(np.abs(lf.B).sum(axis=1))}
    ends = [d for d in pair if d not in driven] or list(pair)
    return " or ".join(_point(c, d) for d in ends)


def _why(search: Search, chosen: Fit, f: Fit) -> tuple[str, str, float | None]:
    """Why ``f``'s location is not separable from ``chosen``'s, the measurement that would
    separate them and the largest relative motion of the pair linking them over the fitting
    levels ('' when separable)."""
    gap = float(chosen.delta_bic - f.delta_bic)
    pair = _link(chosen.cand.dofs, f.cand.dofs)
    rel, lf = largest_relative_motion(search, *pair) if pair else (None, top_level(search))
    if rel is not None and rel < RIGID and f.delta_bic > 0:
        a, b = _point(chosen.cand, pair[0]), _point(chosen.cand, pair[1])
        return (f"{a} and {b} move within {100 * rel:.2g} % of each other (at most, at "
                f"{lf.label}): a joint between them and a support at either end act on nearly "
                "the same motion",
                f"a sensor pair across the joint between {a} and {b} whose relative motion "
                f"exceeds {100 * RIGID:.0f} % of the absolute (drive at "
                f"{_drive_advice(lf, chosen.cand, pair)}, or record levels at which the joint "
                "slips further)", rel)
    if f.delta_bic > SEPARATE and gap < SEPARATE:
        other = sorted(set(f.cand.dofs) ^ set(chosen.cand.dofs))
        at = " or ".join(_point(chosen.cand, d) for d in other)
        return (f"its best candidate gains {f.delta_bic:.4g} BIC points against "
                f"{chosen.delta_bic:.4g}, within the {SEPARATE:g} needed to tell them apart",
                f"a drive or sensor at {at}, where the two act differently, or levels that "
                "exercise the effect further", rel)
    return "", "", rel


def alternatives(search: Search, pool: Sequence[Fit], chosen: Fit,
                 taken: Sequence[tuple[int, ...]] = ()) -> tuple[Alternative, ...]:
    """The locations the first search cannot separate from ``chosen``'s (module docstring),
    best scored first, with each one's score, why and the measurement that would separate
    them. Compared within the chosen candidate's class (nonlinear kinds or linear errors);
    locations in ``taken`` (those of further effects found) are not alternatives."""
    best = best_by_location(search, pool, linear=chosen.cand.linear)
    own = best.get(chosen.cand.dofs, chosen)
    top = own if own.delta_bic >= chosen.delta_bic else chosen
    out = []
    for dofs, f in sorted(best.items(), key=lambda kv: -kv[1].delta_bic):
        if dofs == chosen.cand.dofs or dofs in taken:
            continue
        why, how, rel = _why(search, top, f)
        if why:
            out.append(Alternative(tuple(f.cand.points), tuple(f.cand.w.tolist()), f.cand.kind,
                                   float(f.delta_bic), why, how, rel))
    return tuple(out[:MAX_ALTERNATIVES])
