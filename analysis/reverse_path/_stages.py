"""Sequential (two-stage) reverse path: each coefficient re-estimated with the others fixed.

The joint estimate gives every input a free complex coefficient at every line, so a basis
identifies its parameter only through the part of it that the forces *and the other bases*
do not explain. Two bases on the same deformation share much of it (``v|v|`` next to
``x^3`` near resonance: the damping's joint interval is 5-7x wider than it need be). Fixing
the others at their joint estimates removes their columns from the regression: an element
whose position vector lies on the forced DOFs is then subtracted from the force
(`analysis.reverse_path._channels`), and the remaining parameter is estimated alone.

The fixed values are uncertain; that uncertainty is propagated through a measured
sensitivity: the second stage is repeated with each fixed parameter moved by its standard
error and the change is added in quadrature (first order, the errors taken as independent).
Elements off the forced DOFs cannot be fixed this way (a known force there enters as a free
nuisance input), so they keep their joint estimates and are not fixed for the others.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Callable

import numpy as np

from ..models import Element, Model
from ._core import Z95, Coefficient, ReversePathResult, _force_span


def sequential(estimate: Callable[[Model], ReversePathResult], model: Model
               ) -> ReversePathResult:
    """Joint estimate, then each fixable coefficient alone with the others fixed.

    Parameters
    ----------
    estimate : callable
        ``estimate(candidate)`` runs the joint reverse path on the data.
    model : Model
        The candidate (unknown parameters omitted).

    Returns
    -------
    ReversePathResult
        The joint result with the refined coefficients; ``refine`` records the method and
        the joint values and intervals.
    """
    joint = estimate(model)
    coefs = joint.coefficients
    fdofs = joint.force_dofs
    fixable = [_force_span(c.w, fdofs) is not None for c in coefs]
    if not any(fixable[j] for k in range(len(coefs)) for j in range(len(coefs)) if j != k):
        warnings.warn("reverse path: refine='sequential' changes nothing here: no other "
                      "coefficient lies on the forced DOFs to be fixed, so the joint "
                      "estimate stands", UserWarning, stacklevel=3)
    fitted = joint.estimated_model(model)
    refined: list[Coefficient] = []
    for k, c in enumerate(coefs):
        others = [j for j in range(len(coefs)) if j != k and fixable[j]]
        if not others:
            refined.append(c)
            continue
        base = _alone(estimate, fitted, c, {})
        var = base.std ** 2
        for j in others:
            o = coefs[j]
            moved = _alone(estimate, fitted, c, {o.element: (o.param, o.value + o.std)})
            var += (moved.value - base.value) ** 2
        std = float(np.sqrt(var))
        # the stage's own quantile (Student t of its batch means, or normal)
        q = (base.ci95[1] - base.ci95[0]) / (2 * base.std) if base.std > 0 else Z95
        refined.append(replace(base, std=std, ci95=(base.value - q * std,
                                                     base.value + q * std)))
    joint.coefficients = refined
    joint.refine = {"method": "sequential",
                    "joint": [{"element": c.element, "param": c.param, "value": c.value,
                               "ci95": [float(c.ci95[0]), float(c.ci95[1])]} for c in coefs]}
    return joint


def _alone(estimate: Callable[[Model], ReversePathResult], fitted: Model, free: Coefficient,
           moved: dict[int, tuple[str, float]]) -> Coefficient:
    """Estimate of ``free`` with every other element at its fitted (or ``moved``: element ->
    (parameter, value)) value."""
    elements = []
    for i, el in enumerate(fitted.elements):
        params = dict(el.params)
        if i == free.element:
            del params[free.param]
        elif i in moved:
            params[moved[i][0]] = moved[i][1]
        elements.append(Element(el.kind, el.w.copy(), params))
    (coef,) = estimate(fitted.with_elements(elements)).coefficients
    return coef
