"""Numba hot loop of the simulated plant; the method is described in `analysis.plant._plant`.

The plant keeps the stick_slip slip direction (+1/-1, 0 sticking) in element state slot 1
next to the slider position in slot 0 (`element_force` ignores slot 1).

Notation: ``y = [x, v]`` (2n), ``q`` = hold degree, hold nodes at ``s/h = 1-q .. 0, 1``
(the last ``q`` are history, the last one is the end of the substep). ``gh``/``uh`` hold each
element's force and deformation at the history nodes (column ``q-1`` = start of the substep).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from ..models import element_force, element_tangent, memoryless_force
from .._numba_cache import guard

guard(__file__, "..models._elements")

# The same force law compiled for inlining into the hot loop (a call with array arguments
# costs more than the law itself); `_virgin` is re-jitted alongside since it is called inside.
_element_force = numba.njit(inline="always", cache=True)(element_force.py_func)
_element_tangent = numba.njit(inline="always", cache=True)(element_tangent.py_func)

STICK_SLIP = 5
MAX_ITER = 30
# reassociation lets LLVM vectorise the dot products (deterministic all the same)
FASTMATH = {"reassoc", "contract"}
RTOL = 1e-12
# stats slots
S_SUBSTEPS, S_ITER, S_EVENTS, S_NOCONV = 0, 1, 2, 3


@numba.njit(cache=True)
def _poly(coef: np.ndarray, x: float) -> float:
    out = 0.0
    for i in range(coef.shape[0] - 1, -1, -1):
        out = out * x + coef[i]
    return out


@numba.njit(cache=True)
def _hermite(u0: float, v0: float, u1: float, v1: float, h: float,
             t: float) -> tuple[float, float]:
    """Cubic Hermite interpolant of ``u`` and its time derivative at ``s = t h``."""
    t2 = t * t
    t3 = t2 * t
    u = ((2 * t3 - 3 * t2 + 1) * u0 + (t3 - 2 * t2 + t) * h * v0 + (-2 * t3 + 3 * t2) * u1
         + (t3 - t2) * h * v1)
    du = ((6 * t2 - 6 * t) * u0 / h + (3 * t2 - 4 * t + 1) * v0 + (-6 * t2 + 6 * t) * u1 / h
          + (3 * t2 - 2 * t) * v1)
    return u, du


@numba.njit(cache=True)
def _root_poly(coef: np.ndarray, target: float) -> float:
    """Root of ``poly(t) = target`` on [0, 1] given a sign change (bisection + secant)."""
    lo, hi = 0.0, 1.0
    flo = _poly(coef, lo) - target
    fhi = _poly(coef, hi) - target
    if flo * fhi > 0.0:
        return 0.0 if abs(flo) < abs(fhi) else 1.0
    for _ in range(200):
        t = lo - flo * (hi - lo) / (fhi - flo) if fhi != flo else lo
        if not (lo < t < hi) or hi - lo > 0.25:
            t = 0.5 * (lo + hi)
        f = _poly(coef, t) - target
        if f == 0.0 or hi - lo < 1e-15:
            return t
        if f * flo < 0.0:
            hi, fhi = t, f
        else:
            lo, flo = t, f
    return 0.5 * (lo + hi)


@numba.njit(cache=True)
def _root_velocity(u0: float, v0: float, u1: float, v1: float, h: float) -> float:
    """Time fraction where the Hermite interpolant's velocity changes sign: the root in
    [0, 1] of the quadratic ``a t^2 + b t + v0`` (`_hermite`'s ``du``)."""
    if v0 * v1 > 0.0 or v0 == 0.0:
        return 0.0
    a = 6.0 * (u0 - u1) / h + 3.0 * (v0 + v1)
    b = 6.0 * (u1 - u0) / h - 4.0 * v0 - 2.0 * v1
    c = v0
    if abs(a) <= 1e-12 * (abs(b) + abs(c)):
        return min(max(-c / b, 0.0), 1.0)
    disc = math.sqrt(max(b * b - 4.0 * a * c, 0.0))
    qq = -0.5 * (b + math.copysign(disc, b))      # the stable pair of roots: qq/a, c/qq
    for t in (qq / a, c / qq if qq != 0.0 else -1.0):
        if 0.0 <= t <= 1.0:
            return t
    return min(max(qq / a, 0.0), 1.0)


@numba.njit(cache=True)
def _matvec(a: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ x`` (small: no BLAS call, no allocation)."""
    for r in range(a.shape[0]):
        t = 0.0
        for c in range(a.shape[1]):
            t += a[r, c] * x[c]
        out[r] = t


@numba.njit(cache=True)
def _jump_coeffs(dnodes: np.ndarray, theta: float, vinv: np.ndarray, h: float,
                 inv_fact: np.ndarray, out: np.ndarray, dmono: np.ndarray,
                 dsh: np.ndarray) -> None:
    """Taylor weights ``c_i`` of the end-state effect of a force jump ``D(s) H(s - theta h)``.

    ``D`` is the hold polynomial through ``dnodes``; the effect is
    ``sum_i c_i A^i b`` with ``c_i = sum_k d_k h k! r^(k+1) delta^i / (i+k+1)!``, where
    ``d_k`` are the coefficients of ``D`` in powers of ``(s - theta h)/h``, ``r = 1 - theta``
    and ``delta = r h`` (phi-function series of the exponential integrator). ``dmono``,
    ``dsh``: scratch of ``dnodes``' size (an allocation here costs more than the arithmetic).
    """
    nq = dnodes.shape[0]
    _matvec(vinv, dnodes, dmono)
    dsh[:] = 0.0
    for m in range(nq):  # shift the monomials to the jump time: x = theta + rho
        binom = 1.0
        for k in range(m + 1):
            dsh[k] += dmono[m] * binom * theta ** (m - k)
            binom = binom * (m - k) / (k + 1)
    r = 1.0 - theta
    delta = r * h
    kfact, rk = 1.0, r
    for k in range(nq):        # d_k h k! r^(k+1)
        if k > 0:
            kfact *= k
            rk *= r
        dsh[k] *= h * kfact * rk
    dpow = 1.0
    for i in range(out.shape[0]):
        acc = 0.0
        for k in range(nq):
            acc += dsh[k] * inv_fact[i + k + 1]
        out[i] = acc * dpow
        dpow *= delta


@numba.njit(cache=True, inline="always")
def _axpy(a: float, x: np.ndarray, out: np.ndarray) -> None:
    """``out += a x``."""
    for r in range(out.shape[0]):
        out[r] += a * x[r]


@numba.njit(cache=True, inline="always")
def _copy(a: np.ndarray, out: np.ndarray) -> None:
    """``out[:] = a`` (a copy costs less than swapping the two arrays' references)."""
    for r in range(out.shape[0]):
        out[r] = a[r]


@numba.njit(cache=True, inline="always")
def _dot(a: np.ndarray, b: np.ndarray, lo: int) -> float:
    """``a . b[lo:lo + len(a)]``."""
    s = 0.0
    for c in range(a.shape[0]):
        s += a[c] * b[lo + c]
    return s


@numba.njit(cache=True, inline="always")
def _history(f: np.ndarray, gh: np.ndarray, z: np.ndarray) -> None:
    """``z = [f, g at age 0, ..., g at age q-1]`` (ages in nodes back from the last)."""
    nin, ne, q = f.shape[0], gh.shape[0], gh.shape[1]
    for i in range(nin):
        z[i] = f[i]
    for b in range(q):
        for e in range(ne):
            z[nin + b * ne + e] = gh[e, q - 1 - b]


@numba.njit(cache=True)
def abs_peak(a: np.ndarray) -> np.ndarray:
    """Largest ``|a|`` of each column of ``a`` (n, k): one pass, no temporary (numpy's
    ``abs`` then ``max`` cost the step-doubling check ~8 % of a chunk's time)."""
    out = np.zeros(a.shape[1])
    for i in range(a.shape[0]):
        for c in range(a.shape[1]):
            v = abs(a[i, c])
            if v > out[c]:
                out[c] = v
    return out


class Discretisation(NamedTuple):
    """What `integrate` takes from `analysis.plant._plant.Plant._discretise`: the exact
    discretisation of the linear part for ``m`` substeps per sample, the element tables and
    the output matrices (one numba record instead of positional arrays kept in step)."""

    phi: np.ndarray        # (2n, 2n) state transition; (0, 0) for a decoupled model
    phi_d: np.ndarray      # (4, n) the 2 x 2 blocks' diagonals of a decoupled model, else (4, 0)
    inj_f: np.ndarray      # (1 or 2, n_in, 2n) drive at the substep end (and start)
    inj_g: np.ndarray      # (q or 0, n_e, 2n) element history injected each substep (direct form)
    u_g: np.ndarray        # (n_e, 2n) end-node element force into the state
    we: np.ndarray         # (n_e, 2n) its hold weight (force jumps)
    r_g: np.ndarray        # (q, n_e, 2n) pending part of each history age
    r_v: np.ndarray        # (n_e, n_z) pending part of the deformation rates
    wq: np.ndarray         # (n_e, n) element directions in internal coordinates
    corr: np.ndarray       # (2 n_e, n_z) pending part of the deformations and rates
    pwe: np.ndarray        # (2 n_e, n_e) end-node forces into deformations and rates
    ab: np.ndarray         # (n_e, n_taylor, 2n) A^i b of each element
    pab: np.ndarray        # (n_e, n_taylor, 2 n_e) the same at the elements
    vinv: np.ndarray       # (q + 1, q + 1) hold nodes -> monomials
    xpred: np.ndarray      # (q,) predictor weights of the history
    inv_fact: np.ndarray   # 1 / k!
    codes: np.ndarray      # (n_e,) int64 kind codes
    smooth: np.ndarray     # (n_e,) bool: memoryless kinds
    prm: np.ndarray        # (n_e, N_PARAM) packed parameters
    h: float               # substep, s
    shapes: np.ndarray     # (n_pt, n) T
    identity: bool         # T = I
    tax: np.ndarray        # (n_pt, n) acceleration per displacement at the points
    tav: np.ndarray        # (n_pt, n) acceleration per velocity at the points
    out_z: np.ndarray      # (3, n_pt, n_z) pending part of x, v, a at the points


class PlantState(NamedTuple):
    """The integrator state, updated in place: accumulated state ``s`` (`analysis.plant._plant`,
    Method), element forces ``gh`` and deformations ``uh`` at the hold nodes, element memory
    ``es`` and the last force sample ``fprev``."""

    s: np.ndarray
    gh: np.ndarray
    uh: np.ndarray
    es: np.ndarray
    fprev: np.ndarray


class Outputs(NamedTuple):
    """Per output sample: displacement, velocity and acceleration at the points, element
    forces, element deformations then rates."""

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    g: np.ndarray
    uv: np.ndarray



def _integrate(force: np.ndarray, m: int, d: Discretisation, state: PlantState,
               out: Outputs, stats: np.ndarray) -> None:
    """Advance the plant over ``force.shape[0]`` output samples, ``m`` substeps each.

    ``state`` is updated in place (``s`` is the accumulated state of `analysis.plant._plant`,
    Method); ``out`` receives each output sample; ``stats`` counts substeps, corrector
    iterations, located events and unconverged substeps. ``d.smooth[e]``: element ``e`` is
    memoryless (the corrector may close with its law's tangent).

    A numeric kernel of one piece (~330 lines): split into seven helpers inlined by numba
    (known part, predictor, stick-slip law, law pass, tangent closing, commit, outputs) that
    read the records' fields, it computed the same bits 8x slower on the 3-DOF benchmark
    model (likely reference counts of the arrays read through the records, which numba
    cannot prune around the calls to the laws and root finders). The records are unpacked
    once per call instead, by name.
    """
    phi, phi_d, inj_f, inj_g, u_g, we = d.phi, d.phi_d, d.inj_f, d.inj_g, d.u_g, d.we
    r_g, r_v, wq, corr, pwe, ab, pab = d.r_g, d.r_v, d.wq, d.corr, d.pwe, d.ab, d.pab
    vinv, xpred, inv_fact, codes, smooth = d.vinv, d.xpred, d.inv_fact, d.codes, d.smooth
    prm, h, shapes, identity, tax, tav, out_z = (d.prm, d.h, d.shapes, d.identity, d.tax,
                                                 d.tav, d.out_z)
    s, gh, uh, es, fprev = state.s, state.gh, state.uh, state.es, state.fprev
    out_x, out_v, out_a, out_el, out_uv = out.x, out.v, out.a, out.g, out.uv
    ny = s.shape[0]
    n = ny // 2
    ne = codes.shape[0]
    q = gh.shape[1]
    nin = force.shape[1]
    nt = ab.shape[1]
    npt = out_x.shape[1]
    kn = np.empty(ny)
    pk = np.empty(2 * ne)
    uv = np.empty(2 * ne)
    acc = np.empty(2 * ne)
    g = np.zeros(ne)       # force at the end node (the branch the element is on at the end)
    gc = np.zeros(ne)      # force the hold polynomial uses at the end node (old branch)
    gold = np.empty(q)
    sigma0 = np.zeros(ne)
    st = es.copy()
    pscr = np.empty(prm.shape[1])
    sin = np.empty(es.shape[1])
    sout = np.empty(es.shape[1])
    event = np.zeros(ne, dtype=np.int64)   # 0 none, 1 stick->slip, 2 slip->stick
    ev_prev = np.zeros(ne, dtype=np.int64)
    ev_theta = np.zeros(ne)
    ev_ut = np.zeros(ne)
    ev_c = np.zeros((ne, nt))
    dnodes = np.empty(q + 1)
    dmono = np.empty(q + 1)
    dsh = np.empty(q + 1)
    fa = np.empty(nin)
    fb = np.empty(nin)
    z = np.empty(nin + q * ne)   # drive and hold history that the pending terms act on
    vh = np.empty(ne)            # element deformation rates at the last node
    delta = np.empty(2 * ne)     # last corrector change of the deformations and rates
    lin = np.empty((4, ne))      # closing: force change, its error bound, end tangents
    n_iter = n_noconv = n_events = 0    # counted locally: stores to stats cost in the loop
    _history(fprev, gh, z)
    for e in range(ne):
        g[e] = gh[e, q - 1]
        vh[e] = _dot(wq[e], s, n) - _dot(r_v[e], z, 0)
    for k in range(force.shape[0]):
        for j in range(m):
            for i in range(nin):
                df = (force[k, i] - fprev[i]) / m
                fa[i] = fprev[i] + j * df
                fb[i] = fa[i] + df
            # known part of the end state: free response, drive, injected history. The hot
            # loops are written out: passing arrays (or row views) to helpers costs atomic
            # reference counts, more than the arithmetic.
            first = 0               # drive inputs already injected
            if phi.shape[0] == 0:   # per-mode 2 x 2 blocks: the four diagonals of phi_d
                f0, first = fb[0], 1    # and the first drive input in the same pass
                for i in range(n):
                    x, v = s[i], s[n + i]
                    kn[i] = phi_d[0, i] * x + phi_d[1, i] * v + f0 * inj_f[0, 0, i]
                    kn[n + i] = phi_d[2, i] * x + phi_d[3, i] * v + f0 * inj_f[0, 0, n + i]
            else:
                for r in range(ny):
                    t = 0.0
                    for c in range(ny):
                        t += phi[r, c] * s[c]
                    kn[r] = t
            for i in range(nin):
                if i >= first:
                    for r in range(ny):
                        kn[r] += fb[i] * inj_f[0, i, r]
                if inj_f.shape[0] > 1:
                    for r in range(ny):
                        kn[r] += fa[i] * inj_f[1, i, r]
            for a in range(inj_g.shape[0]):
                for e in range(ne):
                    w = gh[e, q - 1 - a]
                    for r in range(ny):
                        kn[r] += w * inj_g[a, e, r]
            if ne == 0:
                _copy(kn, s)
                continue
            # element deformations and rates of the known part (less the pending history)
            for e in range(ne):
                t, tv = 0.0, 0.0
                for c in range(n):
                    t += wq[e, c] * kn[c]
                    tv += wq[e, c] * kn[n + c]
                pk[e], pk[ne + e] = t, tv
            for i in range(nin):
                z[i] = fb[i]
            for a in range(1, q):
                for e in range(ne):
                    z[nin + (a - 1) * ne + e] = gh[e, q - a]
            for r in range(2 * ne):
                t = 0.0
                for c in range(corr.shape[1]):
                    t += corr[r, c] * z[c]
                pk[r] += t
            for e in range(ne):
                sigma0[e] = 0.0
                if codes[e] == STICK_SLIP:
                    sigma0[e] = es[e, 1]
                gp = 0.0  # predictor: extrapolate the history to the end node
                for nd in range(q):
                    gp += xpred[nd] * gh[e, nd]
                gc[e] = gp
            for e in range(ne):
                if codes[e] == STICK_SLIP and sigma0[e] == 0.0:
                    # sticking, the law is linear: solve its own deformation exactly
                    kd, z0 = prm[e, 0], es[e, 0]
                    t = pk[e] - pwe[e, e] * gc[e]
                    for f in range(ne):
                        t += pwe[e, f] * gc[f]
                    a = pwe[e, e] * kd
                    gc[e] = kd * ((t - a * z0) / (1.0 - a) - z0)
            for r in range(2 * ne):
                t = pk[r]
                for e in range(ne):
                    t += pwe[r, e] * gc[e]
                uv[r] = t
            converged = False
            dprev = 0.0
            for e in range(ne):
                ev_prev[e] = 0
            for it in range(MAX_ITER):
                n_iter += 1
                for r in range(2 * ne):
                    acc[r] = pk[r]
                for e in range(ne):
                    u1 = uv[e]
                    v1 = uv[ne + e]
                    event[e] = 0
                    if codes[e] == STICK_SLIP:
                        kd, fd = prm[e, 0], prm[e, 1]
                        z0 = es[e, 0]
                        if sigma0[e] == 0.0:
                            r1 = kd * (u1 - z0)
                            gc[e] = r1
                            if abs(r1) <= fd:
                                g[e] = r1
                                st[e, 0] = z0
                                st[e, 1] = 0.0
                            else:  # stick -> slip where the stick branch reaches +-fd
                                sg = np.sign(r1)
                                for nd in range(q):
                                    dnodes[nd] = gh[e, nd]
                                dnodes[q] = r1
                                _matvec(vinv, dnodes, dmono)
                                ev_theta[e] = _root_poly(dmono, sg * fd)
                                for nd in range(q + 1):
                                    dnodes[nd] = sg * fd - dnodes[nd]
                                g[e] = sg * fd
                                st[e, 0] = u1 - sg * fd / kd
                                st[e, 1] = sg
                                event[e] = 1
                        else:
                            sg = sigma0[e]
                            gc[e] = sg * fd
                            if sg * v1 >= 0.0:  # still slipping
                                g[e] = sg * fd
                                st[e, 0] = u1 - sg * fd / kd
                                st[e, 1] = sg
                            else:  # slip -> stick where the velocity reverses
                                u0 = uh[e, q - 1]
                                th = _root_velocity(u0, vh[e], u1, v1, h)
                                ut = _hermite(u0, vh[e], u1, v1, h, th)[0]
                                ev_theta[e] = th
                                ev_ut[e] = ut
                                for nd in range(q):
                                    dnodes[nd] = kd * (uh[e, nd] - ut)
                                dnodes[q] = kd * (u1 - ut)
                                g[e] = min(max(sg * fd + kd * (u1 - ut), -fd), fd)
                                st[e, 0] = ut - sg * fd / kd
                                st[e, 1] = 0.0
                                event[e] = 2
                        if event[e] != 0:
                            _jump_coeffs(dnodes, ev_theta[e], vinv, h, inv_fact, ev_c[e],
                                         dmono, dsh)
                            for r in range(2 * ne):
                                t = 0.0
                                for i in range(nt):
                                    t += pab[e, i, r] * ev_c[e, i]
                                acc[r] += t
                    elif smooth[e]:     # no memory: the law of scalars (no array binding)
                        g[e] = memoryless_force(codes[e], prm[e, 0], prm[e, 1], prm[e, 2], u1,
                                                v1)
                        gc[e] = g[e]
                    else:
                        # scratch copies: passing row views costs more than the force law
                        for i in range(pscr.shape[0]):
                            pscr[i] = prm[e, i]
                        for i in range(sin.shape[0]):
                            sin[i] = es[e, i]
                        g[e] = _element_force(codes[e], pscr, u1, v1, sin, sout)
                        for i in range(sin.shape[0]):
                            st[e, i] = sout[i]
                        gc[e] = g[e]
                    for r in range(2 * ne):
                        acc[r] += pwe[r, e] * gc[e]
                # change relative to the tolerance; the iteration contracts linearly, so stop
                # when the change or the next one (ratio estimated from the last two) is below
                dmax = 0.0
                for r in range(2 * ne):
                    delta[r] = acc[r] - uv[r]
                    d = abs(delta[r]) / (RTOL * (abs(pk[r]) + abs(acc[r])) + 1e-300)
                    dmax = max(dmax, d)
                    uv[r] = acc[r]
                same = True   # the branch choice must be settled before stopping
                for e in range(ne):
                    if event[e] != ev_prev[e]:
                        same = False
                    ev_prev[e] = event[e]
                if same and (dmax <= 1.0 or (it > 0 and dmax * dmax <= dprev)):
                    converged = True
                    break
                # Close with the laws' tangents instead of another evaluation: the laws were
                # evaluated at uv - delta; each force change over delta is taken by the
                # trapezoid rule of the tangents at both ends (exact for a stick-slip joint on
                # its branch), its effect pwe dg added to uv. Accepted when what remains is
                # below the tolerance: the next linear change (end tangents times pwe dg) plus
                # the trapezoid's error bound (half the tangent change times delta, a bound
                # for one kink too), with no stick-slip joint leaving its branch.
                closed = same
                for e in range(ne):
                    if not closed or event[e] != 0:
                        closed = False
                    elif codes[e] == STICK_SLIP:
                        kd = prm[e, 0] if sigma0[e] == 0.0 else 0.0
                        lin[0, e], lin[1, e], lin[2, e], lin[3, e] = kd * delta[e], 0.0, kd, 0.0
                    elif smooth[e]:
                        u1, v1, du, dv = uv[e], uv[ne + e], delta[e], delta[ne + e]
                        t0 = _element_tangent(codes[e], prm[e, 0], prm[e, 1], prm[e, 2],
                                              prm[e, 3], u1 - du, v1 - dv, 0.0, 0.0, 0.0, 0.0,
                                              g[e])
                        t1 = _element_tangent(codes[e], prm[e, 0], prm[e, 1], prm[e, 2],
                                              prm[e, 3], u1, v1, 0.0, 0.0, 0.0, 0.0, g[e])
                        lin[0, e] = 0.5 * ((t0[0] + t1[0]) * du + (t0[1] + t1[1]) * dv)
                        lin[1, e] = 0.5 * (abs((t1[0] - t0[0]) * du) + abs((t1[1] - t0[1]) * dv))
                        lin[2, e], lin[3, e] = t1[0], t1[1]
                    else:
                        closed = False
                if closed:
                    for r in range(2 * ne):    # acc: the change pwe dg of uv
                        t = 0.0
                        for e in range(ne):
                            t += pwe[r, e] * lin[0, e]
                        acc[r] = t
                    for r in range(2 * ne):
                        t, bound = 0.0, 0.0
                        for e in range(ne):
                            t += pwe[r, e] * (lin[2, e] * acc[e] + lin[3, e] * acc[ne + e])
                            bound += abs(pwe[r, e]) * lin[1, e]
                        if abs(t) + bound > RTOL * (abs(pk[r]) + abs(uv[r] + acc[r])):
                            closed = False
                    for e in range(ne):
                        if closed and codes[e] == STICK_SLIP:
                            kd, fd = prm[e, 0], prm[e, 1]
                            if sigma0[e] == 0.0:
                                closed = abs(kd * (uv[e] + acc[e] - es[e, 0])) <= fd
                            else:
                                closed = sigma0[e] * (uv[ne + e] + acc[ne + e]) >= 0.0
                if closed:
                    for r in range(2 * ne):
                        uv[r] += acc[r]
                    for e in range(ne):
                        g[e] += lin[0, e]
                        gc[e] += lin[0, e]
                        if codes[e] == STICK_SLIP and sigma0[e] != 0.0:
                            st[e, 0] = uv[e] - sigma0[e] * prm[e, 1] / prm[e, 0]
                    converged = True
                    break
                dprev = dmax
            if not converged:
                n_noconv += 1
            # end state: the hold used gc at the end node, the history keeps g
            # (the last element's pass writes the new state: no copy of kn)
            for e in range(ne - 1):
                for r in range(ny):
                    kn[r] += g[e] * u_g[e, r]
            gl = g[ne - 1]
            for r in range(ny):
                s[r] = kn[r] + gl * u_g[ne - 1, r]
            for e in range(ne):
                if event[e] != 0:
                    _axpy(gc[e] - g[e], we[e], s)
                    for i in range(nt):
                        _axpy(ev_c[e, i], ab[e, i], s)
            for e in range(ne):
                for i in range(es.shape[1]):
                    es[e, i] = st[e, i]
                for nd in range(q - 1):
                    gh[e, nd] = gh[e, nd + 1]
                    uh[e, nd] = uh[e, nd + 1]
                gh[e, q - 1] = g[e]
                uh[e, q - 1] = uv[e]
                vh[e] = uv[ne + e]
                if event[e] == 0:
                    continue
                n_events += 1
                for nd in range(q - 1):
                    gold[nd] = gh[e, nd]
                if event[e] == 1:      # history continues on the slip branch
                    for nd in range(q - 1):
                        gh[e, nd] = g[e]
                else:                  # history continues on the new stick branch
                    for nd in range(q - 1):
                        gh[e, nd] = sigma0[e] * prm[e, 1] + prm[e, 0] * (uh[e, nd]
                                                                         - ev_ut[e])
                for nd in range(q - 1):  # the accumulated state holds the old history
                    _axpy(gh[e, nd] - gold[nd], r_g[q - 1 - nd, e], s)
        stats[S_SUBSTEPS] += m
        for i in range(nin):
            fprev[i] = force[k, i]
        for e in range(ne):
            out_el[k, e] = g[e]
            out_uv[k, e] = uv[e]
            out_uv[k, ne + e] = uv[ne + e]
        _history(fprev, gh, z)
        # outputs at the points: one loop per point and operand for all three kinds (short
        # loops cost more in set-up and final reduction than in their arithmetic)
        for p in range(npt):
            x, v, ax = 0.0, 0.0, 0.0
            if identity:
                x, v = s[p], s[n + p]
                for c in range(n):
                    ax += tax[p, c] * s[c] + tav[p, c] * s[n + c]
            else:
                for c in range(n):
                    sx, sv = s[c], s[n + c]
                    x += shapes[p, c] * sx
                    v += shapes[p, c] * sv
                    ax += tax[p, c] * sx + tav[p, c] * sv
            for c in range(out_z.shape[2]):
                zc = z[c]
                x += out_z[0, p, c] * zc
                v += out_z[1, p, c] * zc
                ax += out_z[2, p, c] * zc
            out_x[k, p] = x
            out_v[k, p] = v
            out_a[k, p] = ax
    stats[S_ITER] += n_iter
    stats[S_NOCONV] += n_noconv
    stats[S_EVENTS] += n_events


integrate = numba.njit(cache=True, error_model="numpy", fastmath=FASTMATH)(_integrate)
# The same loop without fast-math, for runs with kinds registered at run time: the fast-math
# flags reach the built-in laws inlined here but not a registered law (a call), which would
# then differ from an identical built-in law in the last bits (tests/analysis/models/test_kinds.py). Not
# cached on disk: its cache entries would share `integrate`'s index (same function), and
# registered kinds are compiled off the disk cache anyway (`_numba_cache`).
integrate_strict = numba.njit(error_model="numpy")(_integrate)
