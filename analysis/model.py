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
        for i, el in enumerate(self.elements):
            _check_element(el, i, n)

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
        try:
            linear = data["linear"]
        except KeyError:
            raise ModelError(f"{source}: no [linear] table; give mass, damping and stiffness "
                             "matrices under [linear]") from None
        unknown = set(data) - {"name", "linear", "element"}
        if unknown:
            raise ModelError(f"{source}: unknown top-level key(s) {sorted(unknown)}; "
                             "expected name, [linear] and [[element]]")
        for key in ("mass", "damping", "stiffness"):
            if key not in linear:
                raise ModelError(f"{source}: [linear] lacks '{key}'; give an n x n matrix")
        elements = []
        for i, raw in enumerate(data.get("element", [])):
            raw = dict(raw)
            kind = raw.pop("kind", None)
            if kind is None:
                raise ModelError(f"{source}: element {i} has no 'kind'; "
                                 f"use one of {', '.join(KINDS)}")
            if "w" not in raw:
                raise ModelError(f"{source}: element {i} ({kind}) has no position vector 'w'")
            w = raw.pop("w")
            elements.append(Element(str(kind), w, raw))
        try:
            return cls(linear["mass"], linear["damping"], linear["stiffness"], elements,
                       str(data.get("name", "model")))
        except ModelError as exc:
            raise ModelError(f"{source}: {exc}") from None

    @classmethod
    def loads(cls, text: str, source: str = "model") -> "Model":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"{source}: not valid TOML ({exc}); fix the syntax") from None
        return cls.from_dict(data, source)

    @classmethod
    def load(cls, path: str | Path) -> "Model":
        path = Path(path)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise ModelError(f"model file {path} not found; check the path") from None
        except (IsADirectoryError, UnicodeDecodeError, PermissionError) as exc:
            raise ModelError(f"cannot read model file {path}: {exc}") from None
        return cls.loads(text, str(path))


def _toml_num(x: float) -> str:
    return repr(float(x))


def _toml_list(values: Any) -> str:
    return "[" + ", ".join(_toml_num(x) for x in values) + "]"


def _toml_str(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)  # JSON string escapes are valid TOML


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
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name} holds NaN or infinite values")
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
        if not positive and eig.min() < -1e-9 * scale:
            raise ModelError(f"linear.{key} has a negative eigenvalue ({eig.min():.3g}); "
                             f"{key} must be positive semi-definite")


def _check_element(el: Element, i: int, n: int) -> None:
    where = f"element {i} ({el.kind})"
    if el.kind not in KINDS:
        raise ModelError(f"element {i}: unknown kind '{el.kind}'; "
                         f"use one of {', '.join(KINDS)}")
    spec = KINDS[el.kind]
    try:
        el.w = np.array(el.w, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: w must be a list of numbers") from None
    if el.w.shape != (n,):
        raise ModelError(f"{where}: w has {el.w.size} entries but the model has {n} DOFs")
    if not np.all(np.isfinite(el.w)) or not np.any(el.w):
        raise ModelError(f"{where}: w must be finite and not all zero")
    params = {}
    for name, value in el.params.items():
        if name not in spec.all_params:
            raise ModelError(f"{where}: unknown parameter '{name}'; "
                             f"{el.kind} takes {', '.join(spec.all_params)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value):
            raise ModelError(f"{where}: parameter {name} = {value!r} is not a finite number")
        if name in spec.positive and value <= 0:
            raise ModelError(f"{where}: parameter {name} must be > 0, got {value}")
        params[name] = float(value)
    el.params = params
