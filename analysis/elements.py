"""Element library: restoring-force laws of the nonlinear elements.

Every kind acts on ``u = w.x`` and ``u' = w.v`` of its position vector ``w`` and adds
``w * g`` to the left-hand side of ``M x'' + C x' + K x + sum w g = B f``.

The force laws are written once, as numba kernels, and used by the simulated plant's
integrator, by the harmonic-balance AFT evaluation and by the tests.

Kinds with memory carry a state vector of `N_STATE` floats. `element_force` reads the state
before the step (``s_in``) and writes the state after it (``s_out``) so that an integrator can
evaluate trial points without committing them.

Regularisation and memory conventions
-------------------------------------
coulomb_friction
    ``fc * tanh(u' / v_reg)``; ``v_reg`` (m/s, optional parameter, default 1e-3) sets the
    velocity below which friction is treated as viscous.
stick_slip (Jenkins element)
    State ``z`` = slider position. Spring force ``kd (u - z)`` limited to ``|g| <= fd``; when
    the limit is reached the slider moves with ``u``.
hysteresis (paper eq 34 with Masing branches)
    Virgin curve ``F0(u) = kd u / (1 + |kd u / fd|^n)^(1/n)``. A reversal of the velocity sign
    at ``(u_r, F_r)`` starts the branch ``F = F_r + 2 F0((u - u_r) / 2)``; a branch is bounded by
    ``|F| <= fd`` (the skeleton's asymptote), which closes inner loops of random motion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

N_PARAM = 4
N_STATE = 4


@dataclass(frozen=True)
class Kind:
    """Description of one element kind."""

    code: int
    params: tuple[str, ...]
    memory: bool = False
    optional: tuple[tuple[str, float], ...] = ()
    positive: tuple[str, ...] = ()

    @property
    def all_params(self) -> tuple[str, ...]:
        return self.params + tuple(name for name, _ in self.optional)


KINDS: dict[str, Kind] = {
    "cubic_spring": Kind(0, ("p",)),
    "quadratic_spring": Kind(1, ("p",)),
    "quadratic_damping": Kind(2, ("p",)),
    "cubic_damping": Kind(3, ("p",)),
    "coulomb_friction": Kind(4, ("fc",), optional=(("v_reg", 1e-3),), positive=("v_reg",)),
    "stick_slip": Kind(5, ("kd", "fd"), memory=True, positive=("kd", "fd")),
    "hysteresis": Kind(6, ("kd", "fd", "n"), memory=True, positive=("kd", "fd", "n")),
    "gap": Kind(7, ("k", "g"), positive=("k", "g")),
}


def pack_params(kind: str, params: dict[str, float]) -> np.ndarray:
    """Return the kernel parameter vector of one element (optional ones defaulted)."""
    spec = KINDS[kind]
    values = [float(params[name]) for name in spec.params]
    values += [float(params.get(name, default)) for name, default in spec.optional]
    out = np.zeros(N_PARAM)
    out[: len(values)] = values
    return out


@numba.njit(cache=True)
def _virgin(kd: float, fd: float, n: float, x: float) -> float:
    r = abs(kd * x / fd)
    if r <= 1.0:
        return kd * x / (1.0 + r**n) ** (1.0 / n)
    return np.sign(x) * fd / (1.0 + r ** (-n)) ** (1.0 / n)


@numba.njit(cache=True)
def element_force(code: int, p: np.ndarray, u: float, v: float,
                  s_in: np.ndarray, s_out: np.ndarray) -> float:
    """Restoring force ``g`` of one element at ``(u, u')``.

    Parameters
    ----------
    code : int
        `Kind.code` of the element.
    p : ndarray, shape (N_PARAM,)
        Packed parameters (see `pack_params`).
    u, v : float
        Element deformation and its rate.
    s_in, s_out : ndarray, shape (N_STATE,)
        State before and after this point (memory kinds only; others copy it through).

    Returns
    -------
    float
        The restoring force.
    """
    for i in range(s_in.shape[0]):
        s_out[i] = s_in[i]
    if code == 0:
        return p[0] * u * u * u
    if code == 1:
        return p[0] * u * abs(u)
    if code == 2:
        return p[0] * v * abs(v)
    if code == 3:
        return p[0] * v * v * v
    if code == 4:
        return p[0] * np.tanh(v / p[1])
    if code == 5:
        kd, fd = p[0], p[1]
        f = kd * (u - s_in[0])
        if f > fd:
            s_out[0] = u - fd / kd
            return fd
        if f < -fd:
            s_out[0] = u + fd / kd
            return -fd
        return f
    if code == 6:
        kd, fd, n = p[0], p[1], p[2]
        # state: 0 reversal displacement, 1 reversal force, 2 direction (+1/-1, 0 unknown),
        # 3 virgin flag (0 on the virgin curve, 1 on a Masing branch)
        ur, fr, direction, branch = s_in[0], s_in[1], s_in[2], s_in[3]
        if branch == 0.0:
            f = _virgin(kd, fd, n, u)
        else:
            f = fr + 2.0 * _virgin(kd, fd, n, 0.5 * (u - ur))
            f = min(max(f, -fd), fd)
        d = np.sign(v)
        if d != 0.0 and direction != 0.0 and d != direction:
            s_out[0] = u
            s_out[1] = f
            s_out[3] = 1.0
        if d != 0.0:
            s_out[2] = d
        return f
    if code == 7:
        k, g = p[0], p[1]
        if u > g:
            return k * (u - g)
        if u < -g:
            return k * (u + g)
        return 0.0
    return np.nan


@numba.njit(cache=True)
def _force_series(code, p, u, v, state):
    out = np.empty(u.shape[0])
    s_in = state.copy()
    s_out = np.empty_like(state)
    for i in range(u.shape[0]):
        out[i] = element_force(code, p, u[i], v[i], s_in, s_out)
        s_in[:] = s_out
    return out, s_in


def restoring_force(kind: str, params: dict[str, float], u: np.ndarray, v: np.ndarray,
                    state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Restoring force of one element along a time series.

    Parameters
    ----------
    kind : str
        Element kind (a key of `KINDS`).
    params : dict
        Parameter values by name.
    u, v : array_like, shape (n,)
        Deformation and deformation rate, in time order.
    state : ndarray, shape (N_STATE,), optional
        Initial memory state; zeros (virgin element) when omitted.

    Returns
    -------
    g : ndarray, shape (n,)
        Restoring force at each sample.
    state : ndarray, shape (N_STATE,)
        Memory state after the last sample.
    """
    u = np.ascontiguousarray(u, dtype=float)
    v = np.ascontiguousarray(v, dtype=float)
    s0 = np.zeros(N_STATE) if state is None else np.asarray(state, dtype=float).copy()
    return _force_series(KINDS[kind].code, pack_params(kind, params), u, v, s0)
