"""Structural models and their TOML form (contracts section 2).

A `Model` holds the underlying linear system ``M, C, K`` and a list of nonlinear `Element`s.
An element whose parameters are omitted is *unknown*: it marks what an estimator is to find.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .elements import KINDS
from .errors import ModelError
from .textfile import nearest, read_text, unknown_keys

TOP_KEYS = ("name", "linear", "element")
LINEAR_KEYS = ("mass", "damping", "stiffness")
MAX_DOF = 100
MAX_ELEMENTS = 100
MAX_ENTRY = 1e15          # largest |matrix entry| (SI: kg, N s/m, N/m)
MIN_MASS = 1e-12          # kg: smallest eigenvalue of the mass matrix
MAX_PARAM = 1e30          # largest |element parameter|
MAX_RATE_HZ = 1e7         # highest natural frequency or viscous decay rate / (2 pi)


@dataclass
class Element:
    """One nonlinear element acting on ``u = w.x``."""

    kind: str
    w: np.ndarray
    params: dict[str, float] = field(default_factory=dict)

    @property
    def missing(self) -> list[str]:
        """Required parameters that have no value (to be estimated)."""
        return [name for name in KINDS[self.kind].params if name not in self.params]

    @property
    def known(self) -> bool:
        return not self.missing

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind, "w": [float(x) for x in self.w]}
        out.update({k: float(v) for k, v in self.params.items()})
        return out


@dataclass
class Model:
    """Linear system plus nonlinear elements: ``M x'' + C x' + K x + sum w g = B f``."""

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    elements: list[Element] = field(default_factory=list)
    name: str = "model"

    def __post_init__(self) -> None:
        self.mass = _matrix(self.mass, "linear.mass")
        n = self.mass.shape[0]
        self.damping = _matrix(self.damping, "linear.damping", n)
        self.stiffness = _matrix(self.stiffness, "linear.stiffness", n)
        _check_physics(self)
        if len(self.elements) > MAX_ELEMENTS:
            raise ModelError(f"{len(self.elements)} elements, more than {MAX_ELEMENTS}")
        for i, el in enumerate(self.elements):
            _check_element(el, i, n)
        _check_rates(self)

    @property
    def n_dof(self) -> int:
        return self.mass.shape[0]

    @property
    def complete(self) -> bool:
        return all(el.known for el in self.elements)

    def require_complete(self, what: str = "simulation") -> None:
        """Raise `ModelError` if any element parameter is unknown."""
        for i, el in enumerate(self.elements):
            if el.missing:
                raise ModelError(
                    f"element {i} ({el.kind}) has no value for {', '.join(el.missing)}; "
                    f"{what} needs every parameter: give it in the model file")

    def linear_frf(self, freqs: np.ndarray, force_dofs: list[int] | None = None) -> np.ndarray:
        """Receptance of the underlying linear system, shape (n_f, n_dof, n_in)."""
        w = 2 * np.pi * np.asarray(freqs, dtype=float)
        z = (-w[:, None, None] ** 2 * self.mass + 1j * w[:, None, None] * self.damping
             + self.stiffness)
        h = np.linalg.inv(z)
        return h if force_dofs is None else h[:, :, list(force_dofs)]

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies of the linear system, Hz, ascending."""
        from scipy.linalg import eigh
        lam = eigh(self.stiffness, self.mass, eigvals_only=True)
        return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)

    def with_elements(self, elements: list[Element], name: str | None = None) -> "Model":
        """Copy of this model with another element list."""
        return Model(self.mass.copy(), self.damping.copy(), self.stiffness.copy(),
                     list(elements), name or self.name)

    # --- TOML -----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "name": self.name,
            "linear": {key: getattr(self, key).tolist()
                       for key in ("mass", "damping", "stiffness")},
        }
        if self.elements:
            out["element"] = [el.to_dict() for el in self.elements]
        return out

    def dumps(self) -> str:
        """TOML text of this model (matrices one row per line; loads back exactly)."""
        # Written by hand: tomli-w puts every matrix entry on its own line, which makes model
        # files unreadable to the engineers who edit them. The schema is small and fixed.
        lines = [f"name = {_toml_str(self.name)}", "", "[linear]"]
        for key in ("mass", "damping", "stiffness"):
            rows = ",\n    ".join(_toml_list(row) for row in getattr(self, key))
            lines.append(f"{key} = [\n    {rows},\n]")
        for el in self.elements:
            lines += ["", "[[element]]", f"kind = {_toml_str(el.kind)}", f"w = {_toml_list(el.w)}"]
            lines += [f"{name} = {_toml_num(value)}" for name, value in el.params.items()]
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> None:
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
        _keys(data, TOP_KEYS, "top level")
        linear = data.get("linear")
        if not isinstance(linear, dict):
            raise ModelError("no [linear] table; give mass, damping and stiffness matrices "
                             "under [linear]")
        _keys(linear, LINEAR_KEYS, "[linear]")
        for key in LINEAR_KEYS:
            if key not in linear:
                raise ModelError(f"[linear] lacks '{key}'; give an n x n matrix")
            _toml_matrix(linear[key], f"linear.{key}")
        name = data.get("name", "model")
        if not isinstance(name, str):
            raise ModelError(f"name must be a string, got {name!r}")
        raw_elements = data.get("element", [])
        if not isinstance(raw_elements, list):
            raise ModelError("element must be an array of tables ([[element]])")
        if len(raw_elements) > MAX_ELEMENTS:
            raise ModelError(f"{len(raw_elements)} elements, more than {MAX_ELEMENTS}; "
                             "split the model or merge elements acting on the same w")
        elements = [_toml_element(raw, i) for i, raw in enumerate(raw_elements)]
        return cls(linear["mass"], linear["damping"], linear["stiffness"], elements, name)

    @classmethod
    def loads(cls, text: str, source: str = "model") -> "Model":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"{source}: not valid TOML ({exc}); fix the syntax") from None
        return cls.from_dict(data, source)

    @classmethod
    def load(cls, path: str | Path) -> "Model":
        return cls.loads(read_text(path, "model file", ModelError), str(path))


def _toml_num(x: float) -> str:
    return repr(float(x))


def _toml_list(values: Any) -> str:
    return "[" + ", ".join(_toml_num(x) for x in values) + "]"


def _toml_str(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)  # JSON string escapes are valid TOML


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _keys(table: Any, allowed: tuple[str, ...], where: str, noun: str = "key") -> None:
    if not isinstance(table, dict):
        raise ModelError(f"{where} must be a table")
    message = unknown_keys(table, allowed, where, noun)
    if message:
        raise ModelError(message)


def _toml_matrix(value: Any, name: str) -> None:
    """A matrix in a file is a list of equal-length rows of numbers (no scalar, no strings)."""
    hint = "write it as a list of rows of numbers, e.g. [[1.0, 0.0], [0.0, 1.0]]"
    if not isinstance(value, list) or not value:
        raise ModelError(f"{name} = {_short(value)} is not a matrix; {hint}")
    for r, row in enumerate(value):
        if not isinstance(row, list):
            raise ModelError(f"{name} row {r} = {_short(row)} is not a list; {hint}")
        for c, x in enumerate(row):
            if not _is_number(x):
                raise ModelError(f"{name}[{r}][{c}] = {_short(x)} is not a number; {hint}")


def _toml_element(raw: Any, i: int) -> Element:
    if not isinstance(raw, dict):
        raise ModelError(f"element {i} must be a table ([[element]])")
    kind = raw.get("kind")
    if not isinstance(kind, str):
        raise ModelError(f"element {i} has no 'kind' string; use one of {', '.join(KINDS)}")
    if kind not in KINDS:
        hint = f"did you mean '{near}'? " if (near := nearest(kind, KINDS)) else ""
        raise ModelError(f"element {i}: unknown kind '{kind}'; {hint}"
                         f"use one of {', '.join(KINDS)}")
    where = f"element {i} ({kind})"
    _keys(raw, ("kind", "w") + KINDS[kind].all_params, where, "parameter")
    if "w" not in raw:
        raise ModelError(f"{where} has no position vector 'w'")
    w = raw["w"]
    if not isinstance(w, list) or not all(_is_number(x) for x in w):
        raise ModelError(f"{where}: w = {_short(w)} must be a flat list of numbers, one per "
                         "DOF (e.g. [0.0, 1.0])")
    params = {k: v for k, v in raw.items() if k not in ("kind", "w")}
    for name, value in params.items():
        if not _is_number(value):
            raise ModelError(f"{where}: parameter {name} = {_short(value)} is not a number")
    return Element(kind, w, params)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _matrix(value: Any, name: str, n: int | None = None) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be a square matrix of numbers (a list of equal-length "
                         "rows)") from None
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or arr.shape[0] == 0:
        raise ModelError(f"{name} must be a square n x n matrix, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ModelError(f"{name} is {arr.shape[0]} x {arr.shape[0]} but mass is {n} x {n}; "
                         "all linear matrices must have the same size")
    if arr.shape[0] > MAX_DOF:
        raise ModelError(f"{name} is {arr.shape[0]} x {arr.shape[0]}: more than {MAX_DOF} "
                         "DOFs; reduce the model (e.g. to the measured DOFs)")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name} holds NaN or infinite values")
    big = np.abs(arr).max()
    if big > MAX_ENTRY:
        raise ModelError(f"{name} has an entry of magnitude {big:.3g}, above {MAX_ENTRY:g}; "
                         "give SI units (kg, N s/m, N/m)")
    return arr


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
    from scipy.linalg import eigh
    stiff, visc = model.stiffness.copy(), model.damping.copy()
    for el in elements:
        spec, ww = KINDS[el.kind], np.outer(el.w, el.w)
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
        raise ModelError(f"{where}: w has {el.w.size} entries but the model has {n} DOFs")
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
        smallest = spec.param(name).smallest
        lo, hi = (-MAX_PARAM if smallest is None else smallest), MAX_PARAM
        if not lo <= value <= hi:
            raise ModelError(f"{where}: parameter {name} = {value:g} is outside "
                             f"{lo:g}..{hi:g}")
        params[name] = float(value)
    el.params = params
