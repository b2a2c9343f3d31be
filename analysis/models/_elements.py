"""Element library: restoring-force laws of the nonlinear elements.

Every kind acts on ``u = w.x`` and ``u' = w.v`` of its position vector ``w`` and adds
``w * g`` to the left-hand side of ``M x'' + C x' + K x + sum w g = B f``.

The force laws and their tangents (`element_tangent`, the pieces of the AFT Jacobian) are
written once, as numba kernels with one branch per `Kind.code`, and used by the simulated
plant's integrator, by the harmonic-balance AFT evaluation and by the tests. Everything else
about a kind is its descriptor in `analysis.models._kinds`; `register_kind` adds a kind at run time.

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
iwan (Segalman's four-parameter Iwan joint: a continuum of Jenkins sliders)
    Slider strengths distributed as ``R phi^chi`` on ``(0, phi_max)`` plus a Dirac ``S`` at
    ``phi_max`` (Segalman 2005, ASME J Appl Mech 72:752), from ``kd`` (stiffness while every
    slider sticks), ``fd`` (force when all slip), ``chi`` and ``beta``. Its virgin curve is
    ``F0(u) = kd u - R |u|^(chi+2) sign(u) / ((chi+1)(chi+2))`` up to ``phi_max``, ``fd``
    beyond; reversals follow the same Masing branches and state as ``hysteresis``, which are
    the parallel sliders' exact response while each half-cycle spans the one before (a
    periodic steady state, stepped sine); inner loops of random motion are closed by the
    ``|F| <= fd`` bound instead of by the sliders' full memory.
"""

from __future__ import annotations

from dataclasses import replace

import numba
import numpy as np

from .. import _numba_cache
from ._kinds import KINDS, Kind, lookup

N_PARAM = 4
N_STATE = 4
N_BUILTIN = 9
"""Codes below this are branches of `element_force`; registered kinds get the next ones."""


def pack_params(kind: str, params: dict[str, float]) -> np.ndarray:
    """Return the kernel parameter vector of one element (optional ones defaulted)."""
    spec = lookup(kind)
    values = [float(params[name]) for name in spec.params]
    values += [float(params.get(name, default)) for name, default in spec.optional]
    out = np.zeros(N_PARAM)
    out[: len(values)] = values
    return out


# Run-time kinds. The built-in laws are branches of `element_force` / `element_tangent`,
# which the plant and AFT kernels inline and specialise per kind (a call per sample would cost
# more than the law) and numba caches on disk. A kind registered at run time carries its own
# jitted law and tangent; the laws' last branch calls `_extension_force` / `_extension_tangent`,
# a chain over the registered kinds rebuilt by `register_kind`. Numba binds such globals when
# it compiles, so registering drops the compiled kernels of this process and compiles them
# afresh without the disk cache (which keeps holding the built-in kernels untouched).
@numba.njit(cache=True)
def _no_extension_force(code, p0, p1, p2, u, v):
    return np.nan                       # no kind has this code: poison the result


@numba.njit(cache=True)
def _no_extension_tangent(code, p0, p1, p2, u, v):
    return np.nan, np.nan


_extension_force = _no_extension_force
_extension_tangent = _no_extension_tangent


def _chain(prev, code: int, law):
    @numba.njit
    def dispatch(c, p0, p1, p2, u, v):
        if c == code:
            return law(p0, p1, p2, u, v)
        return prev(c, p0, p1, p2, u, v)
    return dispatch


def register_kind(name: str, spec: Kind) -> Kind:
    """Add an element kind at run time, without editing the package.

    Parameters
    ----------
    name : str
        New kind name.
    spec : Kind
        Its descriptor, memoryless, with at most 3 parameters and with ``law`` and
        ``tangent`` numba functions of ``(p0, p1, p2, u, u')`` (parameters in
        `Kind.all_params` order) returning ``g`` and ``(dg/du, dg/du')``; its ``code`` is
        assigned here.

    Returns
    -------
    Kind
        The registered descriptor (with its code).
    """
    if name in KINDS:
        raise ValueError(f"element kind '{name}' exists already")
    if spec.law is None or spec.tangent is None or spec.memory or len(spec.all_params) > 3:
        raise ValueError("a registered kind needs a jitted law and tangent, no memory and at "
                         "most 3 parameters (memory kinds are branches of element_force)")
    code = max([N_BUILTIN - 1] + [k.code for k in KINDS.values()]) + 1
    KINDS[name] = replace(spec, code=code)
    _rebuild_extensions()
    return KINDS[name]


def unregister_kind(name: str) -> None:
    """Remove a kind added by `register_kind` (the cached kernels are used again)."""
    if lookup(name).code < N_BUILTIN:
        raise ValueError(f"'{name}' is a built-in element kind")
    del KINDS[name]
    _rebuild_extensions()


def _rebuild_extensions() -> None:
    global _extension_force, _extension_tangent
    force, tangent = _no_extension_force, _no_extension_tangent
    extra = [k for k in KINDS.values() if k.code >= N_BUILTIN]
    for k in extra:
        force, tangent = _chain(force, k.code, k.law), _chain(tangent, k.code, k.tangent)
    _extension_force, _extension_tangent = force, tangent
    _numba_cache.recompile_law_kernels(disk_cache=not extra)


@numba.njit(cache=True)
def _virgin(kd: float, fd: float, n: float, x: float) -> float:
    r = abs(kd * x / fd)
    if r <= 1.0:
        return kd * x / (1.0 + r**n) ** (1.0 / n)
    return np.sign(x) * fd / (1.0 + r ** (-n)) ** (1.0 / n)


@numba.njit(cache=True)
def _iwan_phi_max(kd: float, fd: float, chi: float, beta: float) -> float:
    """Slip displacement of the strongest slider (Segalman 2005, eq 8-10)."""
    return fd * (1.0 + beta) / (kd * (beta + (chi + 1.0) / (chi + 2.0)))


@numba.njit(cache=True)
def _iwan_virgin(kd: float, fd: float, chi: float, beta: float, x: float) -> float:
    """Virgin curve of the four-parameter Iwan joint (module docstring), written with
    ``R phi_max^(chi+1) = kd (chi+1) / (1+beta)`` so that no power of ``phi_max`` can
    overflow: ``kd x (1 - (|x| / phi_max)^(chi+1) / ((1+beta)(chi+2)))``."""
    phi_max = _iwan_phi_max(kd, fd, chi, beta)
    a = abs(x)
    if a >= phi_max:
        return np.sign(x) * fd
    return kd * x * (1.0 - (a / phi_max) ** (chi + 1.0) / ((1.0 + beta) * (chi + 2.0)))


@numba.njit(cache=True)
def _iwan_slope(kd: float, fd: float, chi: float, beta: float, x: float) -> float:
    """Derivative of `_iwan_virgin`: the stiffness of the sliders still sticking."""
    phi_max = _iwan_phi_max(kd, fd, chi, beta)
    a = abs(x)
    if a >= phi_max:
        return 0.0
    return kd * (1.0 - (a / phi_max) ** (chi + 1.0) / (1.0 + beta))


@numba.njit(cache=True, inline="always")
def memoryless_force(code: int, p0: float, p1: float, p2: float, u: float, v: float) -> float:
    """Restoring force of a kind without memory (`element_force` with scalars only: a
    caller's loop then binds no arrays, whose reference counts cost more than the law)."""
    if code == 0:
        return p0 * u * u * u
    if code == 1:
        return p0 * u * abs(u)
    if code == 2:
        return p0 * v * abs(v)
    if code == 3:
        return p0 * v * v * v
    if code == 4:
        return p0 * np.tanh(v / p1)
    if code == 7:
        if u > p1:
            return p0 * (u - p1)
        if u < -p1:
            return p0 * (u + p1)
        return 0.0
    return _extension_force(code, p0, p1, p2, u, v)


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
    if code == 6 or code == 8:
        kd, fd, n = p[0], p[1], p[2]
        # state: 0 reversal displacement, 1 reversal force, 2 direction (+1/-1, 0 unknown),
        # 3 virgin flag (0 on the virgin curve, 1 on a Masing branch)
        ur, fr, direction, branch = s_in[0], s_in[1], s_in[2], s_in[3]
        x = u if branch == 0.0 else 0.5 * (u - ur)
        if code == 6:
            f = _virgin(kd, fd, n, x)
        else:
            f = _iwan_virgin(kd, fd, n, p[3], x)
        if branch != 0.0:
            f = min(max(fr + 2.0 * f, -fd), fd)
        d = np.sign(v)
        if d != 0.0 and direction != 0.0 and d != direction:
            s_out[0] = u
            s_out[1] = f
            s_out[3] = 1.0
        if d != 0.0:
            s_out[2] = d
        return f
    return memoryless_force(code, p[0], p[1], p[2], u, v)


@numba.njit(cache=True, inline="always")
def _virgin_slope(kd, fd, n, x):
    """Derivative of the eq 34 virgin curve ``F0``: ``kd (1 + r^n)^(-1 - 1/n)``."""
    r = abs(kd * x / fd)
    if r <= 1.0:
        return kd * (1.0 + r ** n) ** (-1.0 - 1.0 / n)
    return kd * r ** (-n - 1.0) * (1.0 + r ** (-n)) ** (-1.0 - 1.0 / n)


@numba.njit(cache=True)
def element_tangent(code, p0, p1, p2, p3, u, v, s0, s2, s3, z_new, g):
    """Coefficients of the forward derivative of one step of the law (scalars only, the
    packed parameters ``p0 .. p3``):
    ``dg = cu du + cv dv + c0 ds0 + c1 ds1``, ``ds0' = a0 du + b0 ds0``,
    ``ds1' = a1 dg + b1 ds1`` (``s0``, ``s1``: the continuous memory state; ``s2``, ``s3``
    the state before the step, ``z_new`` slot 0 after it, ``g`` the force).

    Memoryless kinds: ``cu = dg/du``, ``cv = dg/du'`` and the state passes through.
    """
    if code == 5:                                   # stick-slip
        if z_new != s0:                             # slipped: the slider follows u
            return 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0
        return p0, 0.0, -p0, 0.0, 0.0, 1.0, 0.0, 1.0
    if code == 6 or code == 8:                      # Masing branches: eq 34 hysteresis, Iwan
        cu, c0, c1 = 0.0, 0.0, 0.0
        x = u if s3 == 0.0 else 0.5 * (u - s0)
        if s3 == 0.0 or abs(g) < p1:                # not clipped at the asymptote
            cu = _virgin_slope(p0, p1, p2, x) if code == 6 else _iwan_slope(p0, p1, p2, p3, x)
            if s3 != 0.0:
                c0, c1 = -cu, 1.0
        d = np.sign(v)
        if d != 0.0 and s2 != 0.0 and d != s2:      # reversal stored: (u, g)
            return cu, 0.0, c0, c1, 1.0, 0.0, 1.0, 0.0
        return cu, 0.0, c0, c1, 0.0, 1.0, 0.0, 1.0
    gu, gv = 0.0, 0.0
    if code == 0:
        gu = 3.0 * p0 * u * u
    elif code == 1:
        gu = 2.0 * p0 * abs(u)
    elif code == 2:
        gv = 2.0 * p0 * abs(v)
    elif code == 3:
        gv = 3.0 * p0 * v * v
    elif code == 4:
        t = np.tanh(v / p1)
        gv = p0 * (1.0 - t * t) / p1
    elif code == 7:
        gu = p0 if abs(u) > p1 else 0.0
    else:
        gu, gv = _extension_tangent(code, p0, p1, p2, u, v)
    return gu, gv, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0


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
    return _force_series(lookup(kind).code, pack_params(kind, params), u, v, s0)
