"""Structural models and their TOML form (contracts section 2).

A `Model` holds the underlying linear system and a list of nonlinear `Element`s. The linear
system is ``M q'' + C q' + K q`` over internal coordinates ``q`` seen at named *points* through
``x = T q``: for the ``[linear]`` form ``q`` are the points themselves (``T = I``); for the
``[modal]`` form ``q`` are modal coordinates (``M = I``, ``C = diag(2 ζ ω)``, ``K = diag(ω^2)``,
``T`` the mass-normalised mode shapes at the points). Elements, forces and recordings act on
points; only the simulated plant and the matrix-level diagnosis see ``q``.
An element whose parameters are omitted is *unknown*: it marks what an estimator is to find.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.linalg import eigh

from ..errors import ModelError
from ._element import Element
from ._model_checks import check_element, check_physics, check_rates
from ._model_file import point_index
from ._model_tables import (MAX_DOF, MAX_ELEMENTS, MAX_MODES, coupling_table, matrix,
                            modal_table, points_table, shapes_table)
from ._model_toml import ModelTables, from_tables, model_text
from ._receptance import LinearReceptance
from ._support import Support
from ._textfile import parse_toml, read_text


@dataclass
class Model:
    """Linear system plus nonlinear elements: ``M q'' + C q' + K q + sum T'w g = T'B f``,
    ``x = T q`` at the points (module docstring).

    Parameters
    ----------
    mass, damping, stiffness : ndarray, shape (n_q, n_q)
        Linear system over the internal coordinates (SI).
    elements : list of Element
        Each ``w`` has one entry per point.
    name : str
    points : list of str, optional
        Point names; default ``"0", "1", ...``.
    shapes : ndarray, shape (n_points, n_q), optional
        ``T``; default the identity (the ``[linear]`` form).
    n_residual : int
        Trailing modal coordinates that are residual pseudo-modes (``[modal]`` form).
    support : Support, optional
        Where the structure meets the ground, when the model file says (``[support]``).
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    elements: list[Element] = field(default_factory=list)
    name: str = "model"
    points: list[str] | None = None
    shapes: np.ndarray | None = None
    n_residual: int = 0
    support: Support | None = None

    def __post_init__(self) -> None:
        self.mass = matrix(self.mass, "linear.mass", max_size=MAX_MODES)
        n = self.mass.shape[0]
        self.damping = matrix(self.damping, "linear.damping", n, max_size=MAX_MODES)
        self.stiffness = matrix(self.stiffness, "linear.stiffness", n, max_size=MAX_MODES)
        if self.shapes is None:
            if n > MAX_DOF:
                raise ModelError(f"linear.mass is {n} x {n}: more than {MAX_DOF} DOFs; reduce "
                                 "the model (e.g. to the measured DOFs) or give it in modal form")
            self.shapes = np.eye(n)
        self.shapes = shapes_table(self.shapes, n)
        self.points = points_table(self.points, self.shapes.shape[0])
        check_physics(self)
        if len(self.elements) > MAX_ELEMENTS:
            raise ModelError(f"{len(self.elements)} elements, more than {MAX_ELEMENTS}")
        for i, el in enumerate(self.elements):
            check_element(el, i, self.n_dof)
        check_rates(self)
        if self.support is not None and any(not 0 <= i < self.n_dof
                                            for i in self.support.points):
            raise ModelError(f"support points {list(self.support.points)} outside the "
                             f"{self.n_dof} points")

    @classmethod
    def modal(cls, freqs_hz: Any, damping_ratios: Any, shapes: Any, *,
              elements: list[Element] | None = None, name: str = "model",
              points: list[str] | None = None, residual_freqs_hz: Any = (),
              residual_damping: Any = (), residual_shapes: Any = None,
              damping_coupling: Any = None) -> "Model":
        """Model of the ``[modal]`` form: modes (and residual pseudo-modes) at the points.

        ``shapes`` is (n_modes, n_points), mass-normalised (1/sqrt(kg)); the residual
        pseudo-modes, outside the band, stand for the modes the table leaves out;
        ``damping_coupling`` (square over all modes, zero diagonal, symmetric) the off-diagonal
        modal damping a correction leaves (`modal_coupling`).
        """
        f, z, phi = modal_table(freqs_hz, damping_ratios, shapes, "modal")
        nr = len(residual_freqs_hz)
        if nr:
            fr, zr, phr = modal_table(residual_freqs_hz, residual_damping, residual_shapes,
                                 "modal.residual", n_points=phi.shape[1])
            f, z, phi = np.r_[f, fr], np.r_[z, zr], np.vstack([phi, phr])
        w = 2 * np.pi * f
        c = np.diag(2 * z * w) + coupling_table(damping_coupling, f.size)
        return cls(np.eye(f.size), c, np.diag(w ** 2), list(elements or []),
                   name, points, phi.T, nr)

    @property
    def n_dof(self) -> int:
        """Number of points (the DOFs forces, elements and recordings refer to)."""
        return self.shapes.shape[0]

    @property
    def n_q(self) -> int:
        """Number of internal coordinates (DOFs of the [linear] form, or modes)."""
        return self.mass.shape[0]

    @property
    def is_modal(self) -> bool:
        """Whether the linear part is given by mode shapes (not the identity over points)."""
        return not (self.shapes.shape[0] == self.shapes.shape[1]
                    and np.array_equal(self.shapes, np.eye(self.n_q)))

    @property
    def decoupled(self) -> bool:
        """Whether ``M``, ``C`` and ``K`` are all diagonal (uncoupled modal coordinates)."""
        return all(np.array_equal(a, np.diag(np.diag(a)))
                   for a in (self.mass, self.damping, self.stiffness))

    def to_q(self, w: np.ndarray) -> np.ndarray:
        """A vector over points (an element's ``w``, a force direction) in internal coordinates."""
        return self.shapes.T @ np.asarray(w, dtype=float)

    def point_index(self, point: str | int) -> int:
        """Index of a point given by name or index."""
        return point_index(point, self.points, "point")

    @property
    def complete(self) -> bool:
        """Whether every element parameter is known (the model can be simulated)."""
        return all(el.known for el in self.elements)

    def require_complete(self, what: str = "simulation") -> None:
        """Raise `ModelError` if any element parameter is unknown."""
        for i, el in enumerate(self.elements):
            if el.missing:
                raise ModelError(
                    f"element {i} ({el.kind}) has no value for {', '.join(el.missing)}; "
                    f"{what} needs every parameter: give it in the model file")

    def linear_frf(self, freqs: np.ndarray, force_dofs: list[int] | None = None) -> np.ndarray:
        """Receptance of the underlying linear system at the points, (n_f, n_dof, n_in)."""
        return self.receptance(force_dofs)(freqs)

    def receptance(self, force_dofs: list[int] | None = None) -> "LinearReceptance":
        """`linear_frf` as a function of the frequencies alone, with what does not depend on
        them (the decoupled check, the columns, the contraction order) worked out once: for
        callers evaluating it point by point (continuation). It holds the matrices as they are
        now; results are those of `linear_frf` bit for bit."""
        return LinearReceptance(self, force_dofs)

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies of the linear system, Hz, ascending (pseudo-modes
        included)."""
        lam = eigh(self.stiffness, self.mass, eigvals_only=True)
        return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)

    def stiffness_along(self, w: np.ndarray) -> float:
        """Stiffness the linear system shows along ``w`` (over points): ``w' K w`` of the
        ``[linear]`` form, ``1 / (w' T K^-1 T' w)`` (static) of the ``[modal]`` form."""
        w = np.asarray(w, dtype=float)
        if not self.is_modal:
            return float(w @ self.stiffness @ w)
        return float(1.0 / max(w @ self.point_flexibility() @ w, 1e-300))

    def point_flexibility(self) -> np.ndarray:
        """Static flexibility ``T K^-1 T'`` at the points (m/N; pseudo-inverse if ``K`` is
        singular)."""
        return self.shapes @ np.linalg.pinv(self.stiffness) @ self.shapes.T

    def modal_form(self, points: list[str | int], names: list[str] | None = None,
                   n_modes: int | None = None) -> "Model":
        """This model in ``[modal]`` form at some of its points (an FE model seen at its
        sensors): the lowest ``n_modes`` modes (all by default), mass-normalised; damping
        ratios from the diagonal of the modal damping (exact for modal damping). Elements
        move along when they act on the kept points only."""
        idx = [self.point_index(p) for p in points]
        names = list(names) if names is not None else [self.points[i] for i in idx]
        lam, vec = eigh(self.stiffness, self.mass)
        keep = slice(0, n_modes)
        lam, vec = lam[keep], vec[:, keep]
        w = np.sqrt(np.clip(lam, 0.0, None))
        zeta = np.einsum("qi,qr,ri->i", vec, self.damping, vec) / (2 * w)
        shapes = (self.shapes @ vec)[idx]
        elements = []
        for i, el in enumerate(self.elements):
            if np.any(np.delete(el.w, idx)):
                raise ModelError(f"element {i} ({el.kind}) acts on a point not kept; keep "
                                 "its end points")
            elements.append(Element(el.kind, el.w[idx], dict(el.params)))
        out = Model.modal(w / (2 * np.pi), zeta, shapes.T, elements=elements,
                          name=self.name, points=names)
        if self.support is not None:     # supports at the kept points move along
            out.support = Support(tuple(idx.index(i) for i in self.support.points if i in idx),
                                  self.support.free)
        return out

    def with_elements(self, elements: list[Element], name: str | None = None) -> "Model":
        """Copy of this model with another element list."""
        return self.with_linear(self.mass, self.damping, self.stiffness, elements,
                                name or self.name)

    def with_linear(self, mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                    elements: list[Element] | None = None, name: str | None = None
                    ) -> "Model":
        """Copy with other internal-coordinate matrices (same points and shapes)."""
        return Model(np.array(mass, dtype=float), np.array(damping, dtype=float),
                     np.array(stiffness, dtype=float),
                     list(self.elements if elements is None else elements), name or self.name,
                     list(self.points), self.shapes.copy(), self.n_residual, self.support)

    # --- TOML -----------------------------------------------------------------------------
    def to_dict(self) -> ModelTables:
        """The tables of this model's file (what `from_dict` reads back)."""
        return tomllib.loads(self.dumps())

    def dumps(self) -> str:
        """TOML text of this model (matrices one row per line; loads back exactly)."""
        return model_text(self)

    def save(self, path: str | Path) -> None:
        """Write the model file (`dumps`) to ``path``.

        Parameters
        ----------
        path : str or Path
        """
        Path(path).write_text(self.dumps())

    @classmethod
    def from_dict(cls, data: ModelTables, source: str = "model") -> "Model":
        """Model from the tables of a model file (strict schema: see docs/model-format.md)."""
        try:
            return from_tables(cls, data)
        except ModelError as exc:
            raise ModelError(f"{source}: {exc}") from None

    @classmethod
    def loads(cls, text: str, source: str = "model") -> "Model":
        """Model from the text of a model file.

        Parameters
        ----------
        text : str
            TOML text.
        source : str
            Name used in error messages.

        Returns
        -------
        Model

        Raises
        ------
        ModelError
            Invalid TOML or schema.
        """
        return cls.from_dict(parse_toml(text, source, ModelError), source)

    @classmethod
    def load(cls, path: str | Path) -> "Model":
        """Model from a model file (TOML, docs/model-format.md).

        Parameters
        ----------
        path : str or Path

        Returns
        -------
        Model

        Raises
        ------
        ModelError
            Unreadable file, invalid TOML or schema.
        """
        return cls.loads(read_text(path, "model file", ModelError), str(path))
