"""The model file's text: TOML values written by hand, strict table checks, element placement
(``w``, ``at``, ``between``) and point names (`analysis.models._model` holds the model itself)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ._element import Element
from ._elements import KINDS
from ..errors import ModelError
from ._textfile import nearest, unknown_keys

PLACEMENT_KEYS = ("w", "at", "between")


def toml_num(x: float) -> str:
    """A float as a TOML number that reads back to the same value."""
    return repr(float(x))

def toml_list(values: Any) -> str:
    """A sequence of numbers as a TOML array."""
    return "[" + ", ".join(toml_num(x) for x in values) + "]"

def toml_str(text: str) -> str:
    """``text`` as a quoted TOML string."""
    return json.dumps(text, ensure_ascii=False)  # JSON string escapes are valid TOML

def is_number(value: Any) -> bool:
    """Whether ``value`` is an int or float (a bool is not)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)

def check_keys(table: Any, allowed: tuple[str, ...], where: str, noun: str = "key") -> None:
    """Raise `ModelError` unless ``table`` is a table whose keys are all in ``allowed``.

    Parameters
    ----------
    table : Any
        The parsed TOML value.
    allowed : tuple of str
        Keys the table may hold.
    where : str
        Where the table is, for the message (e.g. ``"[[element]] 2"``).
    noun : str
        What a key is called in the message.
    """
    if not isinstance(table, dict):
        raise ModelError(f"{where} must be a table")
    message = unknown_keys(table, allowed, where, noun)
    if message:
        raise ModelError(message)

def check_toml_matrix(value: Any, name: str) -> None:
    """A matrix in a file is a list of equal-length rows of numbers (no scalar, no strings)."""
    hint = "write it as a list of rows of numbers, e.g. [[1.0, 0.0], [0.0, 1.0]]"
    if not isinstance(value, list) or not value:
        raise ModelError(f"{name} = {short(value)} is not a matrix; {hint}")
    for r, row in enumerate(value):
        if not isinstance(row, list):
            raise ModelError(f"{name} row {r} = {short(row)} is not a list; {hint}")
        for c, x in enumerate(row):
            if not is_number(x):
                raise ModelError(f"{name}[{r}][{c}] = {short(x)} is not a number; {hint}")

def toml_element(raw: Any, i: int, points: list[str]) -> Element:
    """The `Element` of ``[[element]]`` table ``i`` (strict schema; its values are checked
    against the model when the model is built)."""
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
    check_keys(raw, ("kind",) + PLACEMENT_KEYS + KINDS[kind].all_params, where, "parameter")
    given = [key for key in PLACEMENT_KEYS if key in raw]
    if len(given) != 1:
        raise ModelError(f"{where}: " + ("has no position vector; " if not given else "")
                         + "give its place as one of w = [...] (one entry per point), "
                         'at = "point" (grounded) or between = ["a", "b"] (u = x_b - x_a)'
                         + (f"; got {' and '.join(given)}" if given else ""))
    w = placement(given[0], raw[given[0]], points, where)
    params = {k: v for k, v in raw.items() if k not in ("kind",) + PLACEMENT_KEYS}
    for name, value in params.items():
        if not is_number(value):
            raise ModelError(f"{where}: parameter {name} = {short(value)} is not a number")
    return Element(kind, w, params)

def placement(key: str, value: Any, points: list[str], where: str) -> np.ndarray:
    """Position vector of an element from its ``w``, ``at`` or ``between`` entry."""
    if key == "w":
        if not isinstance(value, list) or not all(is_number(x) for x in value):
            raise ModelError(f"{where}: w = {short(value)} must be a flat list of numbers, one "
                             "per point (e.g. [0.0, 1.0])")
        return np.array(value, dtype=float)
    ends = [value] if key == "at" else value
    if key == "between" and not (isinstance(value, list) and len(value) == 2):
        raise ModelError(f'{where}: between = {short(value)} must name two points, e.g. '
                         '["joint", "payload"]')
    idx = [point_index(p, points, f"{where}: {key}") for p in ends]
    w = np.zeros(len(points))
    if key == "between":
        if idx[0] == idx[1]:
            raise ModelError(f"{where}: between names point {points[idx[0]]!r} twice; use "
                             f'at = "{points[idx[0]]}" for a grounded element')
        w[idx[0]], w[idx[1]] = -1.0, 1.0
    else:
        w[idx[0]] = 1.0
    return w

def point_index(point: Any, points: list[str], where: str) -> int:
    """Index of a point given by name or index.

    Parameters
    ----------
    point : str or int
        A name in ``points`` or an index into it.
    points : list of str
        The model's point names.
    where : str
        Where the reference is, for the message.

    Returns
    -------
    int

    Raises
    ------
    ModelError
        No such point (the message suggests the nearest name).
    """
    if isinstance(point, str) and point in points:
        return points.index(point)
    if isinstance(point, int) and not isinstance(point, bool) and 0 <= point < len(points):
        return point
    hint = f"did you mean '{near}'? " if isinstance(point, str) and \
        (near := nearest(point, points)) else ""
    raise ModelError(f"{where}: no point {point!r}; {hint}the points are "
                     f"{', '.join(points)} (or their indices 0..{len(points) - 1})")

def toml_where(w: np.ndarray, points: list[str]) -> str:
    """The placement line of an element: ``at``/``between`` where ``w`` is a unit vector or
    a unit difference, else ``w``."""
    nz = np.flatnonzero(w)
    if nz.size == 1 and w[nz[0]] == 1.0:
        return f"at = {toml_str(points[nz[0]])}"
    if nz.size == 2 and sorted(w[nz]) == [-1.0, 1.0]:
        a, b = nz if w[nz[0]] < 0 else nz[::-1]
        return f"between = [{toml_str(points[a])}, {toml_str(points[b])}]"
    return f"w = {toml_list(w)}"

def default_points(n: int) -> list[str]:
    """Point names of a model that names none: ``"0" .. "n-1"``."""
    return [str(i) for i in range(n)]

def short(value: Any) -> str:
    """``repr(value)`` cut to 40 characters, for messages."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
