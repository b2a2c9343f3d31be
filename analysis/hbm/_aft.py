"""Alternating frequency–time (AFT) evaluation of element forces and their exact derivatives.

One element's deformation over a period is ``u(θ) = Σ_i a_i cos(h_i θ) - b_i sin(h_i θ)`` with
``y = (a, b)`` (2H real coefficients), sampled at ``θ_n = 2πn/N``. `periodic_forces` runs the
element law of `analysis.models._elements` along the samples and returns the Fourier coefficients ``G``
of the force and, on request, the exact derivative ``dG/dy`` of that discrete map, propagated
forward through the time loop together with the memory state (forward-mode differentiation):

* memoryless kinds: ``dg_n = g_u φ_n + g_v ψ_n`` (tangent stiffness and damping at each sample);
* stick-slip: ``dg_n = kd (φ_n - dz)`` in stick, 0 in slip where the slider follows ``dz = φ_n``;
* hysteresis (eq 34, Masing) and the Iwan joint: the branch tangent ``F0'`` plus the
  derivatives of the stored reversal point, 0 where the branch is clipped at ``±fd``.

So ``J = DFT · diag(tangent) · IDFT`` plus the memory terms, as for a piecewise-smooth law the
discrete map is differentiable away from the instants where a sample changes branch.

Memory kinds: each turning point of ``u`` between two samples is located and the law is also
evaluated there, so the stored reversal state is continuous in ``y`` (snapped to the grid it
jumps by O(dθ²) and Newton stalls). Before the period the state is pre-rolled from the virgin
state through the sample at θ = 0, the period's turning points and the last sample: for a
rate-independent law (stick-slip, Masing hysteresis) that is already the periodic state, so one
period suffices; periods are repeated until the state (or the force cycle) repeats otherwise.
"""

from __future__ import annotations

import numba
import numpy as np

from ..models import N_STATE, element_force, element_tangent
from .._numba_cache import guard

guard(__file__, "..models._elements")

# The laws are written once in analysis.elements; their source is compiled inline here and
# specialised per kind by `_run`: a call per sample (array arguments) and the run-time
# dispatch on the kind cost several times the law itself.
_force = numba.njit(inline="always")(element_force.py_func)


def aft_tables(harmonics: np.ndarray, n_time: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sampling tables of the harmonics over one period.

    Returns
    -------
    phi : ndarray, shape (n_time, 2H)
        ``u_n = phi[n] @ y``.
    dphi : ndarray, shape (n_time, 2H)
        ``u'_n = ω dphi[n] @ y``.
    dft : ndarray, shape (2H, n_time)
        ``G = dft @ g`` (the inverse of ``phi`` on the harmonics).
    """
    h = np.asarray(harmonics, dtype=float)
    theta = 2 * np.pi * np.arange(n_time) / n_time
    c, s = np.cos(np.outer(theta, h)), np.sin(np.outer(theta, h))
    phi = np.hstack([c, -s])
    dphi = np.hstack([-s * h, -c * h])
    w = np.where(h == 0, 1.0 / n_time, 2.0 / n_time)
    dft = np.vstack([w[:, None] * c.T, -w[:, None] * s.T])
    return (np.ascontiguousarray(phi), np.ascontiguousarray(dphi),
            np.ascontiguousarray(dft))


@numba.njit(cache=True, inline="always")
def _run_kind(code, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g, DG):
    """Apply the law along ``events`` (sample ``n >= 0`` or turning point ``-1 - k``),
    updating the state ``s`` and its derivative ``ds`` (rows 0, 1) in place; samples store
    their force in ``g`` and its derivative in ``DG`` (unless it is empty). The loop body
    handles the arrays directly: passing them to a helper per sample costs more than the
    law."""
    m = phi.shape[1]
    jac = DG.shape[0] > 0
    s_out = np.empty(N_STATE)
    for e in range(events.shape[0]):
        n = events[e]
        k = -1 - n
        if n >= 0:
            uu, vv = u[n], v[n]
        else:
            uu, vv = tp_u[k], 1e-300 * tp_sign[k]
        s0, s2, s3 = s[0], s[2], s[3]
        gg = _force(code, p, uu, vv, s, s_out)
        for i in range(N_STATE):
            s[i] = s_out[i]
        if n >= 0:
            g[n] = gg
        if jac:
            cu, cv, c0, c1, a0, b0, a1, b1 = element_tangent(code, p[0], p[1], p[2], p[3], uu,
                                                              vv, s0, s2, s3, s_out[0], gg)
            for d in range(m):
                if n >= 0:
                    du = phi[n, d]
                    dv = omega * dphi[n, d]
                else:
                    du = tp_phi[k, d]
                    dv = 0.0
                dg = cu * du + cv * dv + c0 * ds[0, d] + c1 * ds[1, d]
                ds[0, d] = a0 * du + b0 * ds[0, d]
                ds[1, d] = a1 * dg + b1 * ds[1, d]
                if n >= 0:
                    DG[n, d] = dg


@numba.njit(cache=True)
def _run(code, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g, DG):
    """`_run_kind` compiled once per kind: with the code a constant the law's dispatch folds
    away (a run-time dispatch inside the sample loop costs more than the law itself)."""
    if code == 0:
        _run_kind(0, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 1:
        _run_kind(1, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 2:
        _run_kind(2, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 3:
        _run_kind(3, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 4:
        _run_kind(4, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 5:
        _run_kind(5, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 6:
        _run_kind(6, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    elif code == 8:
        _run_kind(8, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)
    else:
        _run_kind(code, p, events, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g,
                  DG)


@numba.njit(cache=True)
def _harmonic_rows(harm, theta, cs, sn):
    """``cos(h θ)``, ``sin(h θ)`` for every order, by powers of ``e^{jθ}`` (one sin/cos)."""
    z = complex(np.cos(theta), np.sin(theta))
    w = 1.0 + 0.0j
    h = 0
    for i in range(harm.shape[0]):
        while h < harm[i]:
            w *= z
            h += 1
        cs[i] = w.real
        sn[i] = w.imag


@numba.njit(cache=True)
def _turning_points(y, harm, u, v, tp_at, tp_u, tp_sign, tp_phi):
    """Turning points of ``u`` between samples (sign changes of ``v``, wrapping around),
    located by Newton's method on ``u'(θ) = 0`` so that ``u`` there is the extremum and its
    derivative is the basis row alone; fills the index of the sample each precedes, ``u``,
    the new direction and the basis row. Returns their count."""
    nt = u.shape[0]
    nh = harm.shape[0]
    dtheta = 2 * np.pi / nt
    cs = np.empty(nh)
    sn = np.empty(nh)
    v_prev = 0.0
    for n in range(nt - 1, -1, -1):
        if v[n] != 0.0:
            v_prev = v[n]
            break
    k = 0
    for n in range(nt):
        if v_prev * v[n] < 0.0:
            lo = (n - 1) * dtheta
            theta = lo + v_prev / (v_prev - v[n]) * dtheta
            for _ in range(3):      # Newton on u'(θ) = 0 from the linear interpolation
                _harmonic_rows(harm, theta, cs, sn)
                up = 0.0
                upp = 0.0
                for i in range(nh):
                    up -= harm[i] * (y[i] * sn[i] + y[nh + i] * cs[i])
                    upp -= harm[i] * harm[i] * (y[i] * cs[i] - y[nh + i] * sn[i])
                if upp == 0.0:
                    break
                step = -up / upp
                if not lo <= theta + step <= lo + dtheta:
                    break
                theta += step
                if abs(step) < 1e-10:
                    break
            _harmonic_rows(harm, theta, cs, sn)
            uu = 0.0
            for i in range(nh):
                tp_phi[k, i] = cs[i]
                tp_phi[k, nh + i] = -sn[i]
                uu += y[i] * cs[i] - y[nh + i] * sn[i]
            tp_at[k] = n
            tp_u[k] = uu
            tp_sign[k] = np.sign(v[n])
            k += 1
        if v[n] != 0.0:
            v_prev = v[n]
    return k


@numba.njit(cache=True)
def _visit_order(tp_at, n_tp, nt):
    """The order a memory kind's law visits samples ``n >= 0`` and turning points ``-1 - k``.

    Parameters
    ----------
    tp_at : ndarray of int, shape (>= n_tp,)
        Index of the sample each turning point precedes (from `_turning_points`).
    n_tp : int
        Number of turning points.
    nt : int
        Samples per period.

    Returns
    -------
    period : ndarray of int, shape (nt + n_tp,)
        One period: each turning point before the sample it precedes.
    pre : ndarray of int
        The pre-roll: virgin state -> sample 0 -> the turning points after it -> last sample.
    """
    period = np.empty(nt + n_tp, dtype=np.int64)
    pre = np.empty(n_tp + 2, dtype=np.int64)
    pre[0] = 0
    e, k, n_pre = 0, 0, 1
    for n in range(nt):
        while k < n_tp and tp_at[k] == n:
            period[e] = -1 - k
            if n > 0:
                pre[n_pre] = -1 - k
                n_pre += 1
            e += 1
            k += 1
        period[e] = n
        e += 1
    pre[n_pre] = nt - 1
    return period, pre[:n_pre + 1]


@numba.njit(cache=True)
def _repeats(s, start, g, g_prev, periods, tol):
    """Whether a memory kind's run has become periodic: its state after a period equals the
    state before it (within ``tol`` relative), or, from the second period on, its force cycle
    ``g`` equals the previous period's ``g_prev`` (within ``tol`` of its largest value)."""
    same = True
    for i in range(N_STATE):
        if abs(s[i] - start[i]) > tol * max(abs(s[i]), abs(start[i])):
            same = False
    if not same and periods > 1:
        diff = 0.0
        big = 0.0
        for n in range(g.shape[0]):
            diff = max(diff, abs(g[n] - g_prev[n]))
            big = max(big, abs(g[n]))
        same = diff <= tol * big
    return same


@numba.njit(cache=True)
def periodic_forces(code, p, memory, y, omega, phi, dphi, dft, harm, max_periods, tol,
                    G, dG):
    """Fourier coefficients of one element's steady periodic force.

    Parameters
    ----------
    code, p, memory : int, ndarray (N_PARAM,), bool
        Element kind code, packed parameters and whether it has memory.
    y : ndarray, shape (2H,)
        Deformation coefficients (Re, Im).
    omega : float
        Drive angular frequency, rad/s.
    phi, dphi, dft : ndarray
        Tables from `aft_tables`.
    harm : ndarray of int, shape (H,)
        Harmonic orders, ascending (as from `analysis.hbm.parse_harmonics`).
    max_periods : int
        Largest number of periods run for a memory kind to become periodic.
    tol : float
        Relative tolerance of the periodicity test.
    G : ndarray, shape (2H,)
        Output coefficients.
    dG : ndarray, shape (2H, 2H) or (0, 0)
        Output ``dG/dy``; not computed if empty. (Flags passed as constants would make
        numba compile one specialisation per value.)

    Returns
    -------
    int
        Number of periods run.
    """
    nt, m = phi.shape
    jac = dG.shape[0] > 0
    u = phi @ y
    v = omega * (dphi @ y)
    g = np.empty(nt)
    DG = np.zeros((nt if jac else 0, m))
    s = np.zeros(N_STATE)
    ds = np.zeros((2, m))
    if not memory:
        _run(code, p, np.arange(nt), u, v, phi, dphi, omega, u, u, phi, s, ds, g, DG)
        G[:] = dft @ g
        if jac:
            dG[:, :] = dft @ DG
        return 1
    tp_at = np.empty(nt, dtype=np.int64)
    tp_u = np.empty(nt)
    tp_sign = np.empty(nt)
    tp_phi = np.empty((nt, m))
    n_tp = _turning_points(y, harm, u, v, tp_at, tp_u, tp_sign, tp_phi)
    period, pre = _visit_order(tp_at, n_tp, nt)
    _run(code, p, pre, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g, DG)
    start = s.copy()
    g_prev = np.empty(0)
    periods = 0
    for periods in range(1, max_periods + 1):
        start[:] = s
        _run(code, p, period, u, v, phi, dphi, omega, tp_u, tp_sign, tp_phi, s, ds, g, DG)
        if _repeats(s, start, g, g_prev, periods, tol):
            break
        g_prev = g.copy()
    G[:] = dft @ g
    if jac:
        dG[:, :] = dft @ DG
    return periods
