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

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.linalg import eigh

from ._elements import KINDS
from ..errors import ModelError
from ._model_file import (check_keys, check_toml_matrix, default_points, point_index,
                          short, toml_element, toml_list, toml_num, toml_str, toml_where)
from ._model_tables import (MAX_DOF, MAX_ENTRY, MAX_MODES, MAX_RATE_HZ, matrix,
                            modal_table, points_table, shapes_table)
from ._textfile import parse_toml, read_text

TOP_KEYS = ("name", "points", "linear", "modal", "element", "support")
SUPPORT_KEYS = ("points", "free")
LINEAR_KEYS = ("mass", "damping", "stiffness")
MODAL_KEYS = ("frequencies_hz", "damping_ratios", "shapes", "residual_frequencies_hz",
              "residual_damping_ratios", "residual_shapes", "damping_coupling")
MAX_ELEMENTS = 100
MIN_MASS = 1e-12          # kg: smallest eigenvalue of the mass matrix
MAX_PARAM = 1e30          # largest |element parameter|


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

    def to_dict(self) -> dict[str, Any]:
        """The element as ``{kind, w, <param>: value}`` (floats)."""
        out: dict[str, Any] = {"kind": self.kind, "w": [float(x) for x in self.w]}
        out.update({k: float(v) for k, v in self.params.items()})
        return out


@dataclass(frozen=True)
class Support:
    """Where the structure meets the ground (a model file's ``[support]``, contracts section 7).

    Parameters
    ----------
    points : tuple of int
        Indices of the points held by the supports (``[support] points = [...]``).
    free : bool
        A free or suspended structure: no point is held (``[support] free = true``).
    """

    points: tuple[int, ...] = ()
    free: bool = False

    def toml(self, names: list[str]) -> list[str]:
        """The ``[support]`` table's lines."""
        if self.free:
            return ["", "[support]", "free = true"]
        held = ", ".join(toml_str(names[i]) for i in self.points)
        return ["", "[support]", f"points = [{held}]"]


def _support(raw: Any, names: list[str]) -> Support:
    """`Support` from a ``[support]`` table (exactly one of ``points`` and ``free``)."""
    check_keys(raw, SUPPORT_KEYS, "[support]")
    if len(raw) != 1:
        raise ModelError("[support] takes either points = [...] (the points held) or "
                         "free = true (a free or suspended structure)")
    if "free" in raw:
        if raw["free"] is not True:
            raise ModelError(f"[support] free = {short(raw['free'])}: write free = true, or "
                             "give points = [...] instead")
        return Support(free=True)
    pts = raw["points"]
    if not isinstance(pts, list) or not pts:
        raise ModelError(f"[support] points = {short(pts)} must list the points held, e.g. "
                         '["root"]')
    return Support(tuple(sorted({point_index(p, names, "[support] points") for p in pts})))


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
        _check_physics(self)
        if len(self.elements) > MAX_ELEMENTS:
            raise ModelError(f"{len(self.elements)} elements, more than {MAX_ELEMENTS}")
        for i, el in enumerate(self.elements):
            _check_element(el, i, self.n_dof)
        _check_rates(self)
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
        c = np.diag(2 * z * w) + _coupling(damping_coupling, f.size)
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
    def to_dict(self) -> dict[str, Any]:
        """The tables of this model's file (what `from_dict` reads back)."""
        return tomllib.loads(self.dumps())

    def dumps(self) -> str:
        """TOML text of this model (matrices one row per line; loads back exactly)."""
        # Written by hand: tomli-w puts every matrix entry on its own line, which makes model
        # files unreadable to the engineers who edit them. The schema is small and fixed.
        lines = [f"name = {toml_str(self.name)}"]
        named = self.points != default_points(self.n_dof)
        if named or self.is_modal:          # a [modal] file names its points (`from_dict`)
            lines.append(f"points = [{', '.join(toml_str(p) for p in self.points)}]")
        if self.is_modal:
            lines += ["", "[modal]                  # mass-normalised shapes: one row per mode, "
                      "one value per point (1/sqrt(kg))"]
            freqs, zeta, shapes, nr = _modal_tables(self)
            for key, f, z, phi in (("", freqs[:-nr or None], zeta[:-nr or None],
                                    shapes[:-nr or None]),
                                   ("residual_", freqs[len(freqs) - nr:],
                                    zeta[len(freqs) - nr:], shapes[len(freqs) - nr:])):
                if not len(f):
                    continue
                rows = ",\n    ".join(toml_list(row) for row in phi)
                lines += [f"{key}frequencies_hz = {toml_list(f)}",
                          f"{key}damping_ratios = {toml_list(z)}",
                          f"{key}shapes = [\n    {rows},\n]"]
            coupling = modal_coupling(self)
            if coupling is not None:
                rows = ",\n    ".join(toml_list(row) for row in coupling)
                lines.append(f"damping_coupling = [\n    {rows},\n]")
        else:
            lines += ["", "[linear]"]
            for key in ("mass", "damping", "stiffness"):
                rows = ",\n    ".join(toml_list(row) for row in getattr(self, key))
                lines.append(f"{key} = [\n    {rows},\n]")
        if self.support is not None:
            lines += self.support.toml(self.points)
        for el in self.elements:
            lines += ["", "[[element]]", f"kind = {toml_str(el.kind)}",
                      toml_where(el.w, self.points) if named else f"w = {toml_list(el.w)}"]
            lines += [f"{name} = {toml_num(value)}" for name, value in el.params.items()]
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> None:
        """Write the model file (`dumps`) to ``path``.

        Parameters
        ----------
        path : str or Path
        """
        Path(path).write_text(self.dumps())

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "model") -> "Model":
        """Model from the tables of a model file (strict schema: see docs/model-format.md)."""
        try:
            return cls._from_dict(data)
        except ModelError as exc:
            raise ModelError(f"{source}: {exc}") from None

    @classmethod
    def _from_dict(cls, data: dict[str, Any]) -> "Model":
        check_keys(data, TOP_KEYS, "top level")
        name = data.get("name", "model")
        if not isinstance(name, str):
            raise ModelError(f"name must be a string, got {name!r}")
        points = data.get("points")
        if points is not None and (not isinstance(points, list) or not points):
            raise ModelError(f"points = {short(points)} must be a list of point names, e.g. "
                             '["drive", "tip"]')
        raw_elements = data.get("element", [])
        if not isinstance(raw_elements, list):
            raise ModelError("element must be an array of tables ([[element]])")
        if len(raw_elements) > MAX_ELEMENTS:
            raise ModelError(f"{len(raw_elements)} elements, more than {MAX_ELEMENTS}; "
                             "split the model or merge elements acting on the same w")
        linear, modal = data.get("linear"), data.get("modal")
        if linear is None and modal is None:
            raise ModelError("no [linear] table; give mass, damping and stiffness matrices "
                             "under [linear] (or modes under [modal], docs/model-format.md)")
        if linear is not None and modal is not None:
            raise ModelError("both [linear] and [modal]: give the linear system in one form")
        if linear is not None:
            check_keys(linear, LINEAR_KEYS, "[linear]")
            for key in LINEAR_KEYS:
                if key not in linear:
                    raise ModelError(f"[linear] lacks '{key}'; give an n x n matrix")
                check_toml_matrix(linear[key], f"linear.{key}")
            n_points = len(linear["mass"])
        else:
            check_keys(modal, MODAL_KEYS, "[modal]")
            for key in MODAL_KEYS[:3]:
                if key not in modal:
                    raise ModelError(f"[modal] lacks '{key}'; see docs/model-format.md")
            check_toml_matrix(modal["shapes"], "modal.shapes")
            if points is None:
                raise ModelError("a [modal] model needs top-level points = [...] naming the "
                                 "point of each shape column")
            n_points = len(points)
        names = points_table(points, n_points)
        elements = [Element(*toml_element(raw, i, names)) for i, raw in enumerate(raw_elements)]
        support = None if "support" not in data else _support(data["support"], names)
        if linear is not None:
            return cls(linear["mass"], linear["damping"], linear["stiffness"], elements, name,
                       names, support=support)
        if "residual_shapes" in modal:
            check_toml_matrix(modal["residual_shapes"], "modal.residual_shapes")
        model = cls.modal(modal["frequencies_hz"], modal["damping_ratios"], modal["shapes"],
                          elements=elements, name=name, points=names,
                          residual_freqs_hz=modal.get("residual_frequencies_hz", []),
                          residual_damping=modal.get("residual_damping_ratios", []),
                          residual_shapes=modal.get("residual_shapes"),
                          damping_coupling=modal.get("damping_coupling"))
        model.support = support
        return model

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


def _coupling(value: Any, n: int) -> np.ndarray:
    """The validated ``damping_coupling`` of a ``[modal]`` table (zeros when absent)."""
    if value is None:
        return np.zeros((n, n))
    check_toml_matrix(value, "modal.damping_coupling")
    c = np.array(value, dtype=float)
    if c.shape != (n, n) or not np.all(np.isfinite(c)):
        raise ModelError(f"modal.damping_coupling must be {n} x {n} (every mode, pseudo-modes "
                         f"last), got shape {c.shape}")
    if np.any(np.diag(c) != 0) or not np.allclose(c, c.T, rtol=1e-9, atol=0.0):
        raise ModelError("modal.damping_coupling must be symmetric with a zero diagonal (the "
                         "diagonal is damping_ratios)")
    return c


def modal_coupling(model: Model) -> np.ndarray | None:
    """Off-diagonal modal damping (N s/m per unit modal mass) in the modes a ``[modal]`` file
    writes, when a correction left one (a stuck stiffness taken out of the linear part
    couples the modes through a non-proportional damping); None when the damping is
    diagonal there (within 1e-12 of its largest entry)."""
    m, c, k = model.mass, model.damping, model.stiffness
    if model.decoupled and np.all(np.diag(m) == 1):
        return None
    vec = eigh(k, m)[1]
    cq = vec.T @ c @ vec
    off = cq - np.diag(np.diag(cq))
    if not np.abs(off).max() > 1e-12 * np.abs(cq).max():
        return None
    return (off + off.T) / 2


def _modal_tables(model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Frequencies, damping ratios, shapes (n_modes, n_points) and the number of trailing
    pseudo-modes of a modal model; matrices changed by a correction are diagonalised again
    (undamped modes of ``K, M``; damping ratios from the diagonal of the modal damping)."""
    m, c, k = model.mass, model.damping, model.stiffness
    if model.decoupled and np.all(np.diag(m) == 1):
        w = np.sqrt(np.diag(k))
        return w / (2 * np.pi), np.diag(c) / (2 * w), model.shapes.T, model.n_residual
    lam, vec = eigh(k, m)
    w = np.sqrt(np.clip(lam, 0.0, None))
    zeta = np.einsum("qi,qr,ri->i", vec, c, vec) / (2 * np.maximum(w, 1e-300))
    return w / (2 * np.pi), zeta, (model.shapes @ vec).T, 0


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


def _check_physics(model: Model) -> None:
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


def _check_rates(model: Model) -> None:
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


def _check_element(el: Element, i: int, n: int) -> None:
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
