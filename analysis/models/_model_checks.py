"""A model's physics checked when it is built: symmetric, definite matrices; time scales a
supported sample rate resolves; each element's kind, position vector and parameter values."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import eigh

from ..errors import ModelError
from ._element import Element
from ._elements import KINDS
from ._model_tables import MAX_ENTRY, MAX_PARAM, MAX_RATE_HZ, MIN_MASS

if TYPE_CHECKING:
    from ._model import Model


def check_physics(model: Model) -> None:
    """Raise `ModelError` unless the mass matrix is symmetric positive definite (eigenvalues
    at least `MIN_MASS`) and damping and stiffness are symmetric positive semi-definite."""
    for key, positive in (("mass", True), ("damping", False), ("stiffness", False)):
        a = getattr(model, key)
        scale = max(np.abs(a).max(), 1e-300)
        if np.abs(a - a.T).max() > 1e-9 * scale:
            raise ModelError(f"linear.{key} is not symmetric; a passive structure has "
                             f"symmetric {key} (check the off-diagonal terms)")
        eig = np.linalg.eigvalsh(0.5 * (a + a.T))
        if positive and eig.min() <= 0:
            raise ModelError("linear.mass is not positive definite; every DOF needs mass > 0")
        if positive and eig.min() < MIN_MASS:
            raise ModelError(f"linear.mass has an eigenvalue of {eig.min():.3g} kg, below "
                             f"{MIN_MASS:g} kg; give SI units (kg)")
        if not positive and eig.min() < -1e-9 * scale:
            raise ModelError(f"linear.{key} has a negative eigenvalue ({eig.min():.3g}); "
                             f"{key} must be positive semi-definite")


def _rates(model: Model, elements: list[Element]) -> tuple[float, float]:
    """Highest natural frequency and viscous decay rate, Hz, of the linear system stiffened
    and damped by ``elements`` at rest (their kinds' slopes at zero amplitude: the
    piecewise-linear and Coulomb kinds' steepest)."""
    stiff, visc = model.stiffness.copy(), model.damping.copy()
    for el in elements:
        wq = model.to_q(el.w)
        spec, ww = KINDS[el.kind], np.outer(wq, wq)
        if el.missing:                      # a candidate's unknown element: no slope yet
            continue
        if spec.stiffness is not None:
            stiff += abs(spec.stiffness(el.params, 0.0)) * ww
        if spec.damping is not None:
            visc += abs(spec.damping(el.params, 0.0)) * ww
    lam = eigh(stiff, model.mass, eigvals_only=True).max()
    rate = eigh(visc, model.mass, eigvals_only=True).max()
    return math.sqrt(max(lam, 0.0)) / (2 * np.pi), max(rate, 0.0) / (2 * np.pi)


def check_rates(model: Model) -> None:
    """Refuse time scales no supported sample rate resolves (they stall the simulated plant
    and overflow the estimators): name the matrix or the first element that makes them."""
    if max(_rates(model, [])) > MAX_RATE_HZ:
        raise ModelError(f"linear.stiffness/damping over mass give a natural frequency or decay "
                         f"rate above {MAX_RATE_HZ:g} Hz; check the units (kg, N s/m, N/m)")
    if not model.elements or max(_rates(model, model.elements)) <= MAX_RATE_HZ:
        return
    for i, el in enumerate(model.elements):
        if max(_rates(model, model.elements[:i + 1])) > MAX_RATE_HZ:
            raise ModelError(f"element {i} ({el.kind}) makes a natural frequency or decay "
                             f"rate above {MAX_RATE_HZ:g} Hz; check its parameter values")


def check_element(el: Element, i: int, n: int) -> None:
    """Check element ``i`` of a model with ``n`` points and normalise it in place (``w`` a
    float array, parameters floats); raise `ModelError` naming what is wrong."""
    where = f"element {i} ({el.kind})"
    if el.kind not in KINDS:
        raise ModelError(f"element {i}: unknown kind '{el.kind}'; "
                         f"use one of {', '.join(KINDS)}")
    spec = KINDS[el.kind]
    try:
        el.w = np.array(el.w, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: w must be a list of numbers") from None
    if el.w.ndim != 1:
        raise ModelError(f"{where}: w must be a flat list of numbers, got shape {el.w.shape}")
    if el.w.size != n:
        raise ModelError(f"{where}: w has {el.w.size} entries but the model has {n} points")
    if not np.all(np.isfinite(el.w)) or not np.any(el.w):
        raise ModelError(f"{where}: w must be finite and not all zero")
    if np.abs(el.w).max() > MAX_ENTRY:
        raise ModelError(f"{where}: w has an entry above {MAX_ENTRY:g}; w is a position "
                         "vector of order 1 (e.g. e_j - e_i)")
    params = {}
    for name, value in el.params.items():
        if name not in spec.all_params:
            raise ModelError(f"{where}: unknown parameter '{name}'; "
                             f"{el.kind} takes {', '.join(spec.all_params)}")
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
                or not math.isfinite(value):
            raise ModelError(f"{where}: parameter {name} = {value!r} is not a finite number")
        if name in spec.positive and value <= 0:
            raise ModelError(f"{where}: parameter {name} must be > 0, got {value}")
        smallest, largest = spec.param(name).smallest, spec.param(name).largest
        lo = -MAX_PARAM if smallest is None else smallest
        hi = MAX_PARAM if largest is None else largest
        if not lo <= value <= hi:
            raise ModelError(f"{where}: parameter {name} = {value:g} is outside "
                             f"{lo:g}..{hi:g}")
        params[name] = float(value)
    el.params = params
