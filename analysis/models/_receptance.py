"""The receptance of a model's linear part at its points, for any frequencies, with what does
not depend on them worked out once (`Model.receptance`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ._model import Model


class LinearReceptance:
    """The receptance ``T (K - w^2 M + i w C)^-1 T'`` of a model's linear part at its points,
    for any frequencies (`Model.receptance`)."""

    def __init__(self, model: Model, force_dofs: list[int] | None = None) -> None:
        self.shapes = model.shapes
        self.cols = model.shapes if force_dofs is None else model.shapes[list(force_dofs)]
        self.decoupled = model.decoupled
        self.is_modal = model.is_modal
        self.mass, self.damping, self.stiffness = model.mass, model.damping, model.stiffness
        self.diag = tuple(np.diag(a).copy() for a in (model.mass, model.damping,
                                                       model.stiffness))
        #: the force columns' DOFs when ``T = I`` (a ``[linear]`` model): the receptance of a
        #: decoupled one is then ``hq`` on those entries, zero elsewhere
        self.dofs = None if self.is_modal else np.arange(model.n_q) if force_dofs is None \
            else np.asarray(force_dofs, dtype=int)
        self._paths: dict[int, list[Any]] = {}   # einsum's contraction order per n_f

    def __call__(self, freqs: np.ndarray) -> np.ndarray:
        """Receptance at ``freqs`` (Hz), (n_f, n_dof, n_in)."""
        w = 2 * np.pi * np.asarray(freqs, dtype=float)
        if self.decoupled:
            m, c, k = self.diag
            hq = 1.0 / (-w[:, None] ** 2 * m + 1j * w[:, None] * c + k)
            if self.dofs is not None:
                # what the product with T = I gives: each sum over q has one non-zero term,
                # times 1.0 (exact), so the entries are hq's bit for bit
                out = np.zeros((w.size, self.shapes.shape[0], self.dofs.size), dtype=complex)
                out[:, self.dofs, np.arange(self.dofs.size)] = hq[:, self.dofs]
                return out
            # the order einsum's optimizer picks depends on the sizes only: planned once
            # per number of frequencies (planning cost more than the product)
            path = self._paths.get(w.size)
            if path is None:
                path = self._paths[w.size] = np.einsum_path(
                    "pq,fq,iq->fpi", self.shapes, hq, self.cols, optimize=True)[0]
            return np.einsum("pq,fq,iq->fpi", self.shapes, hq, self.cols, optimize=path)
        z = (-w[:, None, None] ** 2 * self.mass + 1j * w[:, None, None] * self.damping
             + self.stiffness)
        h = np.linalg.solve(z, np.broadcast_to(self.cols.T, z.shape[:1] + self.cols.T.shape))
        return h if not self.is_modal else np.einsum("pq,fqi->fpi", self.shapes, h)
