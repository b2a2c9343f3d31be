"""The one candidate library searched by every diagnosis: locations x kinds.

A *location* is a position vector ``w``: ``e_i`` (element from DOF i to ground) or
``e_j - e_i`` (element between DOFs i < j). A *kind* is either an element kind of
`analysis.kinds.KINDS` (every one, in `analysis.kinds.search_order`) or a linear error
(``mass_error``, ``stiffness_error``, ``damping_error``). The library is the full cross
product (mass errors only at single DOFs; kinds with a stuck stiffness also with that
stiffness taken out of the linear part, as a model fitted at a low level holds it); nothing in it depends on the data or on the
scenario being diagnosed.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..kinds import KINDS, search_order

LINEAR_KINDS = ("stiffness_error", "damping_error", "mass_error")
"""Linear model errors: a constant added to K, C (at ``w w^T``) or M (at ``e_i e_i^T``)."""

LINEAR_PARAM = {"stiffness_error": "delta_stiffness", "damping_error": "delta_damping",
                "mass_error": "delta_mass"}


@dataclass(frozen=True)
class Candidate:
    """One hypothesis: element (or linear error) ``kind`` acting on ``u = w.x``."""

    kind: str
    dofs: tuple[int, ...]
    n_dof: int
    compensated: bool = False
    """The element's stuck stiffness (`analysis.kinds.Kind.initial_stiffness`) is taken out
    of the linear part: the starting model, fitted where the element sticks, holds it."""

    @property
    def w(self) -> np.ndarray:
        w = np.zeros(self.n_dof)
        w[self.dofs[-1]] = 1.0
        if len(self.dofs) == 2:
            w[self.dofs[0]] = -1.0
        return w

    @property
    def linear(self) -> bool:
        return self.kind in LINEAR_KINDS

    @property
    def memory(self) -> bool:
        return not self.linear and KINDS[self.kind].memory

    @property
    def n_params(self) -> int:
        """Free parameters counted by the information criterion."""
        if self.linear:
            return 1
        return len(KINDS[self.kind].params)

    @property
    def where(self) -> str:
        if len(self.dofs) == 1:
            return f"DOF {self.dofs[0]} to ground"
        return f"between DOFs {self.dofs[0]} and {self.dofs[1]}"

    @property
    def label(self) -> str:
        stuck = " (its stuck stiffness taken from the linear part)" if self.compensated else ""
        return f"{self.kind} {self.where}{stuck}"


def locations(n_dof: int) -> list[tuple[int, ...]]:
    """Every grounded DOF and every DOF pair."""
    return [(i,) for i in range(n_dof)] + list(combinations(range(n_dof), 2))


def library(n_dof: int) -> list[Candidate]:
    """The complete candidate library of an ``n_dof`` model."""
    out = []
    for loc in locations(n_dof):
        for kind in search_order() + LINEAR_KINDS:
            if kind == "mass_error" and len(loc) != 1:
                continue
            out.append(Candidate(kind, loc, n_dof))
            if kind in KINDS and KINDS[kind].initial_stiffness is not None:
                out.append(Candidate(kind, loc, n_dof, compensated=True))
    return out
