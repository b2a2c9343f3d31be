"""A model's nonlinear element: its kind, where it acts and its parameters (`analysis.models._model`
holds the model; `_model_checks` checks an element against it)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._elements import KINDS


@dataclass
class Element:
    """One nonlinear element acting on ``u = w.x`` (``w`` over the model's points)."""

    kind: str
    w: np.ndarray
    params: dict[str, float] = field(default_factory=dict)

    @property
    def missing(self) -> list[str]:
        """Required parameters that have no value (to be estimated)."""
        return [name for name in KINDS[self.kind].params if name not in self.params]

    @property
    def known(self) -> bool:
        """Whether every required parameter has a value."""
        return not self.missing
