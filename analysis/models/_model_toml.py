"""A model as the tables and text of its file: reading the tables (strict schema) and writing
the text (`Model.from_dict`, `Model.dumps`; docs/model-format.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypedDict

import numpy as np
from scipy.linalg import eigh

from ..documents import TomlTable
from ..errors import ModelError
from ._model_file import (check_keys, check_toml_matrix, default_points, short, toml_element,
                          toml_list, toml_num, toml_str, toml_where)
from ._model_tables import MAX_ELEMENTS, points_table
from ._support import support_table

if TYPE_CHECKING:
    from ._model import Model

Matrix = list[list[float]]


class LinearTable(TypedDict, total=False):
    """A model file's ``[linear]`` table: the matrices over the model's points."""

    mass: Matrix
    damping: Matrix
    stiffness: Matrix


class ModalTable(TypedDict, total=False):
    """A model file's ``[modal]`` table: modes (and pseudo-modes) over the points."""

    frequencies_hz: list[float]
    damping_ratios: list[float]
    shapes: Matrix
    residual_frequencies_hz: list[float]
    residual_damping_ratios: list[float]
    residual_shapes: Matrix
    damping_coupling: Matrix


class SupportTable(TypedDict, total=False):
    """A model file's ``[support]`` table: the points held, or ``free = true``."""

    points: list[str | int]
    free: bool


class ModelTables(TypedDict, total=False):
    """The tables of a model file (docs/model-format.md), as `tomllib` reads them.

    One of ``linear`` and ``modal``; each ``[[element]]`` table's keys follow its kind (the
    kind descriptors check them), so an element stays a `TomlTable`.
    """

    name: str
    points: list[str]
    linear: LinearTable
    modal: ModalTable
    element: list[TomlTable]
    support: SupportTable


#: the keys each table may hold, in the order messages list them (from the schema above)
TOP_KEYS = tuple(ModelTables.__annotations__)
LINEAR_KEYS = tuple(LinearTable.__annotations__)
MODAL_KEYS = tuple(ModalTable.__annotations__)


def from_tables(cls: type[Model], data: ModelTables) -> Model:
    """A ``cls`` model from the tables of a model file (strict schema, docs/model-format.md;
    `Model.from_dict` adds the source to the message)."""
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
    elements = [toml_element(raw, i, names) for i, raw in enumerate(raw_elements)]
    support = None if "support" not in data else support_table(data["support"], names)
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


def model_text(model: Model) -> str:
    """TOML text of a model (matrices one row per line; loads back exactly)."""
    # Written by hand: tomli-w puts every matrix entry on its own line, which makes model
    # files unreadable to the engineers who edit them. The schema is small and fixed.
    lines = [f"name = {toml_str(model.name)}"]
    named = model.points != default_points(model.n_dof)
    if named or model.is_modal:          # a [modal] file names its points (`from_dict`)
        lines.append(f"points = [{', '.join(toml_str(p) for p in model.points)}]")
    if model.is_modal:
        lines += ["", "[modal]                  # mass-normalised shapes: one row per mode, "
                  "one value per point (1/sqrt(kg))"]
        freqs, zeta, shapes, nr = _modal_tables(model)
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
        coupling = modal_coupling(model)
        if coupling is not None:
            rows = ",\n    ".join(toml_list(row) for row in coupling)
            lines.append(f"damping_coupling = [\n    {rows},\n]")
    else:
        lines += ["", "[linear]"]
        for key in ("mass", "damping", "stiffness"):
            rows = ",\n    ".join(toml_list(row) for row in getattr(model, key))
            lines.append(f"{key} = [\n    {rows},\n]")
    if model.support is not None:
        lines += model.support.toml(model.points)
    for el in model.elements:
        lines += ["", "[[element]]", f"kind = {toml_str(el.kind)}",
                  toml_where(el.w, model.points) if named else f"w = {toml_list(el.w)}"]
        lines += [f"{name} = {toml_num(value)}" for name, value in el.params.items()]
    return "\n".join(lines) + "\n"


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
