"""The one candidate library searched by every diagnosis (and located by reverse-path
screening): locations x kinds.

A *location* is a position vector ``w``: ``e_i`` (element from DOF i to ground) or
``e_j - e_i`` (element between DOFs i < j). A *kind* is either an element kind of
`analysis.models.KINDS` (every one, in `analysis.models.search_order`) or a linear error
(``mass_error``, ``stiffness_error``, ``damping_error``). The library is the full cross
product (mass errors only at single DOFs; kinds with a stuck stiffness also with that
stiffness taken out of the linear part, as a model fitted at a low level holds it); nothing in
it depends on the data or on the scenario being diagnosed.

A model's ``[support]`` (`Support`, contracts section 7) narrows the grounded locations: with
``points = [...]`` grounded candidates stand only at those points; with ``free = true`` no
grounded element stands anywhere and only the linear errors remain grounded (a suspension's
stiffness and damping, a point's mass). Mass errors stand at every point (a mass is not held
by a support). Without ``[support]`` every point may be grounded. Relative candidates (every
pair) are never narrowed.

Kept below `analysis.diagnose` so that `analysis.reverse_path` screens the same locations
without importing the diagnosis.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from ._kinds import KINDS, search_order
from ._model import Support

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
    """The element's stuck stiffness (`analysis.models._kinds.Kind.initial_stiffness`) is taken out
    of the linear part: the starting model, fitted where the element sticks, holds it."""
    names: tuple[str, ...] | None = field(default=None, compare=False, repr=False)
    """The model's point names (None: points are numbered), for messages only."""

    @property
    def w(self) -> np.ndarray:
        """Position vector: ``e_i`` to ground, ``e_j - e_i`` between DOFs ``i < j``."""
        w = np.zeros(self.n_dof)
        w[self.dofs[-1]] = 1.0
        if len(self.dofs) == 2:
            w[self.dofs[0]] = -1.0
        return w

    @property
    def linear(self) -> bool:
        """A linear model error (not an element kind)."""
        return self.kind in LINEAR_KINDS

    @property
    def memory(self) -> bool:
        """An element kind with internal state (a slider)."""
        return not self.linear and KINDS[self.kind].memory

    @property
    def n_params(self) -> int:
        """Free parameters counted by the information criterion."""
        if self.linear:
            return 1
        return len(KINDS[self.kind].params)

    @property
    def points(self) -> list[str]:
        """Names of the points the candidate acts on (numbers when the model has none)."""
        return [self.names[d] if self.names else str(d) for d in self.dofs]

    @property
    def where(self) -> str:
        """``P to ground`` or ``between P and Q`` (DOF numbers when the points are unnamed)."""
        a = self.points
        if len(self.dofs) == 1:
            return f"{a[0]} to ground" if self.names else f"DOF {a[0]} to ground"
        return f"between {a[0]} and {a[1]}" if self.names else f"between DOFs {a[0]} and {a[1]}"

    @property
    def label(self) -> str:
        """Kind and location in words, for messages."""
        stuck = " (its stuck stiffness taken from the linear part)" if self.compensated else ""
        return f"{self.kind} {self.where}{stuck}"


def locations(n_dof: int) -> list[tuple[int, ...]]:
    """Every grounded DOF and every DOF pair."""
    return [(i,) for i in range(n_dof)] + list(combinations(range(n_dof), 2))


def grounded_allowed(kind: str, point: int, support: Support | None) -> bool:
    """Whether ``kind`` may act from ``point`` to ground under ``support`` (None: the model
    does not say, every point may be grounded)."""
    if support is None or kind == "mass_error":
        return True
    if support.free:
        return kind in LINEAR_KINDS
    return point in support.points


def library(n_dof: int, names: list[str] | None = None,
            support: Support | None = None) -> list[Candidate]:
    """The complete candidate library of an ``n_dof`` model (``names``: its point names, used
    in messages when they are not just the point numbers; ``support``: its ``[support]``,
    which narrows the grounded candidates, see the module docstring)."""
    named = tuple(names) if names and list(names) != [str(i) for i in range(n_dof)] else None
    out = []
    for loc in locations(n_dof):
        for kind in search_order() + LINEAR_KINDS:
            if kind == "mass_error" and len(loc) != 1:
                continue
            if len(loc) == 1 and not grounded_allowed(kind, loc[0], support):
                continue
            out.append(Candidate(kind, loc, n_dof, names=named))
            if kind in KINDS and KINDS[kind].initial_stiffness is not None:
                out.append(Candidate(kind, loc, n_dof, compensated=True, names=named))
    return out
