"""Validated tables of a model file: point names, mode shapes, modal tables, vectors and
matrices, with the size and range bounds they are checked against (`analysis.models._model`
builds the model from them)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ModelError
from ._model_file import check_toml_matrix, default_points, is_number, short

MAX_DOF = 100             # points, and DOFs of the [linear] form
MAX_MODES = 500
MAX_ENTRY = 1e15          # largest |matrix entry| (SI: kg, N s/m, N/m)
MAX_RATE_HZ = 1e7         # highest natural frequency or viscous decay rate / (2 pi)
MAX_ELEMENTS = 100
MIN_MASS = 1e-12          # kg: smallest eigenvalue of the mass matrix
MAX_PARAM = 1e30          # largest |element parameter|


def points_table(points: Any, n: int) -> list[str]:
    """Validated point names (default ``"0", "1", ...``)."""
    if points is None:
        return default_points(n)
    points = list(points)
    if len(points) != n:
        raise ModelError(f"points names {len(points)} points but the linear system has {n}; "
                         "give one name per DOF or shape column")
    for p in points:
        if not isinstance(p, str) or not p.strip():
            raise ModelError(f"points: {short(p)} is not a point name (a non-empty string)")
    dup = sorted({p for p in points if points.count(p) > 1})
    if dup:
        raise ModelError(f"points: {', '.join(map(repr, dup))} named twice; point names must "
                         "be unique")
    return points


def shapes_table(value: Any, n_q: int) -> np.ndarray:
    """Validated point map ``T``: ``n_points x n_q`` finite numbers, at most `MAX_DOF` rows."""
    arr = np.array(value, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != n_q or arr.shape[0] == 0:
        raise ModelError(f"shapes must be n_points x {n_q}, got shape {arr.shape}")
    if arr.shape[0] > MAX_DOF:
        raise ModelError(f"{arr.shape[0]} points, more than {MAX_DOF}")
    if not np.all(np.isfinite(arr)):
        raise ModelError("shapes hold NaN or infinite values")
    return arr


def modal_table(freqs: Any, zeta: Any, shapes: Any, where: str, n_points: int | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validated modal table: frequencies (Hz), damping ratios, shapes (n_modes, n_points)."""
    residual = where.endswith("residual")
    pre = "residual_" if residual else ""
    f = vector(freqs, f"{where.split('.')[0]}.{pre}frequencies_hz")
    z = vector(zeta, f"{where.split('.')[0]}.{pre}damping_ratios")
    if f.size != z.size:
        raise ModelError(f"{where}: {f.size} frequencies but {z.size} damping ratios; give one "
                         "per mode")
    if f.size > MAX_MODES:
        raise ModelError(f"{where}: {f.size} modes, more than {MAX_MODES}")
    if not np.all(f > 0) or f.max(initial=0) > MAX_RATE_HZ:
        raise ModelError(f"{where}: frequencies must be > 0 Hz and <= {MAX_RATE_HZ:g} Hz, got "
                         f"{f.min():g}..{f.max():g}")
    lo_ok = (z >= 0) if residual else (z > 0)
    if not np.all(lo_ok & (z < 1)):
        raise ModelError(f"{where}: damping ratios must lie in {'[0' if residual else '(0'}, 1) "
                         f"(fractions of critical, not %), got {z.min():g}..{z.max():g}")
    try:
        phi = np.array(shapes, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {pre}shapes must be a list of equal-length rows of "
                         "numbers, one row per mode and one value per point") from None
    if phi.ndim != 2 or phi.shape[0] != f.size or (n_points is not None
                                                   and phi.shape[1] != n_points):
        want = f"{f.size} x {n_points if n_points is not None else 'n_points'}"
        raise ModelError(f"{where}: {pre}shapes must be {want} (one row per mode, one value "
                         f"per point), got shape {phi.shape}")
    if not np.all(np.isfinite(phi)) or np.abs(phi).max(initial=0) > MAX_ENTRY:
        raise ModelError(f"{where}: {pre}shapes must be finite numbers below {MAX_ENTRY:g}")
    if np.any(np.all(phi == 0, axis=1)):
        raise ModelError(f"{where}: mode {int(np.flatnonzero(np.all(phi == 0, axis=1))[0])} "
                         "has a zero shape at every point; drop it or give its shape")
    return f, z, phi


def vector(value: Any, name: str) -> np.ndarray:
    """A list of finite numbers as a 1-D array (``name`` for the error)."""
    if not isinstance(value, (list, tuple, np.ndarray)) or not all(
            is_number(x) or isinstance(x, np.number) for x in np.ravel(value)):
        raise ModelError(f"{name} = {short(value)} must be a list of numbers")
    arr = np.array(value, dtype=float).ravel()
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name} holds NaN or infinite values")
    return arr


def matrix(value: Any, name: str, n: int | None = None, max_size: int = MAX_DOF
            ) -> np.ndarray:
    """A square ``n x n`` matrix of finite numbers in SI, at most ``max_size`` rows
    (``n`` None: any size; ``name`` for the error)."""
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
    if arr.shape[0] > max_size:
        raise ModelError(f"{name} is {arr.shape[0]} x {arr.shape[0]}: more than {max_size} "
                         "DOFs; reduce the model (e.g. to the measured DOFs)")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name} holds NaN or infinite values")
    big = np.abs(arr).max()
    if big > MAX_ENTRY:
        raise ModelError(f"{name} has an entry of magnitude {big:.3g}, above {MAX_ENTRY:g}; "
                         "give SI units (kg, N s/m, N/m)")
    return arr


def coupling_table(value: Any, n: int) -> np.ndarray:
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
