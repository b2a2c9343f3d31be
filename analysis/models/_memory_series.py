"""A memory law along a long series, its state in registers (`memory_force_series`).

`restoring_force` steps `element_force`, whose memory state passes through arrays at every
sample (the contract an integrator needs to try points without committing them). Along the
motion the diagnosis interpolates 8x between the samples (`analysis.diagnose._compare`)
those loads and stores cost as much as the law itself, and the law runs there once per
candidate, grid value and refinement step. This kernel steps the same branches of the
built-in memory kinds with the same arithmetic in the same order, on scalar state, calling
the same virgin curves: its forces are bitwise those of `restoring_force` from a virgin
element (`tests/analysis/models/test_memory_series.py`). Numba has no way to keep an
array's few slots in registers across a loop, hence this hand-written loop.
"""

from __future__ import annotations

import numba
import numpy as np

from .. import _numba_cache
from ._elements import _iwan_virgin, _virgin, pack_params
from ._kinds import KINDS, lookup

_numba_cache.guard(__file__, "_elements")

_JENKINS, _HYSTERESIS, _IWAN = 5, 6, 8
"""`Kind.code` of the built-in memory kinds (`element_force`'s branches)."""


@numba.njit(cache=True)
def _jenkins_series(kd: float, fd: float, u: np.ndarray) -> np.ndarray:
    """`element_force`'s stick-slip branch along ``u`` from slider position 0."""
    out = np.empty(u.shape[0])
    z = 0.0
    for i in range(u.shape[0]):
        f = kd * (u[i] - z)
        if f > fd:
            z = u[i] - fd / kd
            f = fd
        elif f < -fd:
            z = u[i] + fd / kd
            f = -fd
        out[i] = f
    return out


@numba.njit(cache=True)
def _masing_series(code: int, p: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """`element_force`'s hysteresis / Iwan branch along ``u``, ``v`` from the virgin state."""
    kd, fd = p[0], p[1]
    out = np.empty(u.shape[0])
    ur = fr = direction = branch = 0.0
    for i in range(u.shape[0]):
        x = u[i] if branch == 0.0 else 0.5 * (u[i] - ur)
        if code == _HYSTERESIS:
            f = _virgin(kd, fd, p[2], x)
        else:
            f = _iwan_virgin(kd, fd, p[2], p[3], x)
        if branch != 0.0:
            f = min(max(fr + 2.0 * f, -fd), fd)
        d = np.sign(v[i])
        if d != 0.0 and direction != 0.0 and d != direction:
            ur, fr, branch = u[i], f, 1.0
        if d != 0.0:
            direction = d
        out[i] = f
    return out


def memory_force_series(kind: str, params: dict[str, float], u: np.ndarray,
                        v: np.ndarray) -> np.ndarray:
    """Restoring force of a virgin memory element along a time series.

    Parameters
    ----------
    kind : str
        A built-in memory kind (``stick_slip``, ``hysteresis``, ``iwan``).
    params : dict
        Parameter values by name.
    u, v : array_like, shape (n,)
        Deformation and deformation rate, in time order.

    Returns
    -------
    ndarray, shape (n,)
        The force at each sample, equal to ``restoring_force(kind, params, u, v)[0]``.
    """
    code = lookup(kind).code
    if not KINDS[kind].memory or code not in (_JENKINS, _HYSTERESIS, _IWAN):
        raise ValueError(f"{kind!r} is not a built-in memory kind")
    p = pack_params(kind, params)
    u = np.ascontiguousarray(u, dtype=float)
    if code == _JENKINS:
        return _jenkins_series(p[0], p[1], u)
    return _masing_series(code, p, u, np.ascontiguousarray(v, dtype=float))
