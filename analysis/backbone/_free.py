"""Unbounded coordinates of an element kind's parameters, for continuous fits.

A positive parameter is fitted as its logarithm (stiffness, slip force: decades apart
between joints). A parameter with two finite bounds ``(a, b)`` (`analysis.models.Param.bounds`,
e.g. ``iwan``'s signed exponent ``chi`` in (-0.95, 0.9) and its full-slip share ``beta``) is
fitted as ``log((x - a) / (b - x))`` (a logit), which keeps it inside them with the sign
free; any other parameter is fitted as it is.
"""

from __future__ import annotations

import numpy as np

from ..models import KINDS

#: how far inside a two-sided bound a value is moved before its logit is taken
EDGE = 1e-9


def _how(kind: str, name: str) -> tuple[str, float, float]:
    p = KINDS[kind].param(name)
    if p.positive:
        return "log", 0.0, np.inf
    if p.bounds is not None and np.all(np.isfinite(p.bounds)):
        return "logit", float(p.bounds[0]), float(p.bounds[1])
    return "linear", -np.inf, np.inf


def to_free(kind: str, params: dict[str, float]) -> np.ndarray:
    """Free coordinates of ``params`` (`Kind.params` order)."""
    out = []
    for n in KINDS[kind].params:
        how, a, b = _how(kind, n)
        x = float(params[n])
        if how == "log":
            out.append(np.log(x))
        elif how == "logit":
            span = b - a
            x = min(max(x, a + EDGE * span), b - EDGE * span)
            out.append(np.log((x - a) / (b - x)))
        else:
            out.append(x)
    return np.array(out)


def _value(kind: str, name: str, v: float) -> float:
    """Parameter ``name`` at free coordinate ``v``."""
    how, a, b = _how(kind, name)
    if how == "log":
        return float(np.exp(v))
    if how == "logit":
        return float(a + (b - a) / (1 + np.exp(-v)))
    return float(v)


def from_free(kind: str, z: np.ndarray) -> dict[str, float]:
    """Parameters of free coordinates ``z`` (inverse of `to_free`)."""
    return {n: _value(kind, n, v) for n, v in zip(KINDS[kind].params, np.asarray(z, float))}


def free_bounds(kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the free coordinates: a positive parameter's own bounds in logarithms
    (unbounded without), none for a logit or a linear one (its bounds are built in)."""
    lo, hi = [], []
    for n in KINDS[kind].params:
        how, _, _ = _how(kind, n)
        b = KINDS[kind].param(n).bounds
        if how == "log" and b is not None:
            lo.append(np.log(b[0]) if b[0] > 0 else -np.inf)
            hi.append(np.log(b[1]))
        else:
            lo.append(-np.inf)
            hi.append(np.inf)
    return np.array(lo), np.array(hi)


def free_interval(kind: str, name: str, z: float, half: float, lo: float, hi: float
                  ) -> tuple[float, float]:
    """95 % interval of parameter ``name`` from its free coordinate ``z`` and the
    interval's half width ``half`` there, ending at the fit's bounds ``lo``, ``hi``."""
    cap = 700.0 if _how(kind, name)[0] == "log" else np.inf     # exp overflows beyond
    ends = (_value(kind, name, max(z - half, lo, -cap)),
            _value(kind, name, min(z + half, hi, cap)))
    return float(min(ends)), float(max(ends))
