"""The stages of one plant substep, inlined into the kernel loop
(`analysis.plant._plant_kernels.integrate`): the known part of the end state, the
predictor, the element laws (the stick-slip joint's with its located events), the
corrector with its tangent closing, and the commit of the accepted substep.

Each stage takes the records of `analysis.plant._records` (``d`` the discretisation, ``ps``
the plant state, ``w`` the scratch) and is inlined by numba (``inline="always"``): compiled
inside the loop with the loop's flags (fast-math or strict), no call and no array
reference passed per substep. The hot loops are written out: a call with array arguments or
row views costs atomic reference counts, more than the arithmetic.
"""

from __future__ import annotations

import numba
import numpy as np

from .._numba_cache import guard
from ..models import element_force, element_tangent, memoryless_force
from ._hold import hermite, jump_coeffs, matvec, root_poly, root_velocity
from ._records import Discretisation, PlantState, Work

guard(__file__, "..models._elements")

# The same force law compiled for inlining into the hot loop (a call with array arguments
# costs more than the law itself).
_element_force = numba.njit(inline="always", cache=True)(element_force.py_func)
_element_tangent = numba.njit(inline="always", cache=True)(element_tangent.py_func)

STICK_SLIP = 5
MAX_ITER = 30
RTOL = 1e-12
_INLINE = {"inline": "always", "cache": True}


@numba.njit(**_INLINE)
def known_part(force: np.ndarray, k: int, j: int, m: int, d: Discretisation,
               ps: PlantState, w: Work) -> None:
    """``w.kn``: the end state of substep ``j`` of sample ``k`` without the end node's
    element force (free response, first-order-hold drive, injected history); ``w.fa``,
    ``w.fb``: the drive at the substep's start and end."""
    phi, phi_d, inj_f, inj_g = d.phi, d.phi_d, d.inj_f, d.inj_g
    s, gh, fprev = ps.s, ps.gh, ps.fprev
    kn, fa, fb = w.kn, w.fa, w.fb
    ny, nin = s.shape[0], fa.shape[0]
    n = ny // 2
    ne, q = gh.shape
    for i in range(nin):
        df = (force[k, i] - fprev[i]) / m
        fa[i] = fprev[i] + j * df
        fb[i] = fa[i] + df
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
            wa = gh[e, q - 1 - a]
            for r in range(ny):
                kn[r] += wa * inj_g[a, e, r]


@numba.njit(**_INLINE)
def predict(d: Discretisation, ps: PlantState, w: Work) -> None:
    """The known part of the element deformations and rates (``w.pk``, less the pending
    history) and the predictor of the end node: ``w.gc`` extrapolated from the history (a
    sticking stick-slip joint solved on its linear law), ``w.uv`` from it."""
    wq, corr, pwe, xpred, codes, prm = d.wq, d.corr, d.pwe, d.xpred, d.codes, d.prm
    gh, es = ps.gh, ps.es
    kn, pk, z, gc, sigma0, uv, fb = w.kn, w.pk, w.z, w.gc, w.sigma0, w.uv, w.fb
    n = kn.shape[0] // 2
    ne, q = gh.shape
    nin = fb.shape[0]
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
        sigma0[e] = es[e, 1] if codes[e] == STICK_SLIP else 0.0
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


@numba.njit(**_INLINE)
def stick_slip(e: int, u1: float, v1: float, d: Discretisation, ps: PlantState,
               w: Work) -> None:
    """The stick-slip law of element ``e`` at the end-node deformation ``u1`` and rate
    ``v1``: ``w.g``, ``w.gc``, ``w.st``, and a branch change located inside the substep
    (``w.event``, ``w.ev_theta``, ``w.ev_ut``, the jump's difference to the hold polynomial
    at the nodes in ``w.dnodes``)."""
    gh, uh, es = ps.gh, ps.uh, ps.es
    g, gc, st, dnodes = w.g, w.gc, w.st, w.dnodes
    q = gh.shape[1]
    kd, fd = d.prm[e, 0], d.prm[e, 1]
    z0 = es[e, 0]
    if w.sigma0[e] == 0.0:
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
            matvec(d.vinv, dnodes, w.dmono)
            w.ev_theta[e] = root_poly(w.dmono, sg * fd)
            for nd in range(q + 1):
                dnodes[nd] = sg * fd - dnodes[nd]
            g[e] = sg * fd
            st[e, 0] = u1 - sg * fd / kd
            st[e, 1] = sg
            w.event[e] = 1
    else:
        sg = w.sigma0[e]
        gc[e] = sg * fd
        if sg * v1 >= 0.0:  # still slipping
            g[e] = sg * fd
            st[e, 0] = u1 - sg * fd / kd
            st[e, 1] = sg
        else:  # slip -> stick where the velocity reverses
            u0, v0 = uh[e, q - 1], w.vh[e]
            th = root_velocity(u0, v0, u1, v1, d.h)
            ut = hermite(u0, v0, u1, v1, d.h, th)[0]
            w.ev_theta[e] = th
            w.ev_ut[e] = ut
            for nd in range(q):
                dnodes[nd] = kd * (uh[e, nd] - ut)
            dnodes[q] = kd * (u1 - ut)
            g[e] = min(max(sg * fd + kd * (u1 - ut), -fd), fd)
            st[e, 0] = ut - sg * fd / kd
            st[e, 1] = 0.0
            w.event[e] = 2


@numba.njit(**_INLINE)
def law_pass(d: Discretisation, ps: PlantState, w: Work) -> None:
    """One corrector evaluation: every element's law at ``w.uv``, the deformations and
    rates they give in ``w.acc`` (with the effect of located force jumps)."""
    codes, smooth, prm, pwe, pab = d.codes, d.smooth, d.prm, d.pwe, d.pab
    es = ps.es
    uv, acc, g, gc, st, event, ev_c = w.uv, w.acc, w.g, w.gc, w.st, w.event, w.ev_c
    pscr, sin, sout = w.pscr, w.sin, w.sout
    ne, nt = ev_c.shape
    for r in range(2 * ne):
        acc[r] = w.pk[r]
    for e in range(ne):
        u1, v1 = uv[e], uv[ne + e]
        event[e] = 0
        if codes[e] == STICK_SLIP:
            stick_slip(e, u1, v1, d, ps, w)
            if event[e] != 0:
                jump_coeffs(w.dnodes, w.ev_theta[e], d.vinv, d.h, d.inv_fact, ev_c[e],
                            w.dmono, w.dsh)
                for r in range(2 * ne):
                    t = 0.0
                    for i in range(nt):
                        t += pab[e, i, r] * ev_c[e, i]
                    acc[r] += t
        elif smooth[e]:     # no memory: the law of scalars (no array binding)
            g[e] = memoryless_force(codes[e], prm[e, 0], prm[e, 1], prm[e, 2], u1, v1)
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


@numba.njit(**_INLINE)
def settled(it: int, dprev: float, w: Work) -> tuple[bool, bool, float]:
    """Take ``w.acc`` as the new iterate. Returns whether the corrector may stop, whether
    the branch choices are those of the previous iterate, and the change relative to the
    tolerance. The iteration contracts linearly, so it stops when the change or the next
    one (ratio estimated from the last two) is below the tolerance, branches settled."""
    pk, uv, acc, delta, event, ev_prev = w.pk, w.uv, w.acc, w.delta, w.event, w.ev_prev
    dmax = 0.0
    for r in range(uv.shape[0]):
        delta[r] = acc[r] - uv[r]
        dd = abs(delta[r]) / (RTOL * (abs(pk[r]) + abs(acc[r])) + 1e-300)
        dmax = max(dmax, dd)
        uv[r] = acc[r]
    same = True
    for e in range(event.shape[0]):
        if event[e] != ev_prev[e]:
            same = False
        ev_prev[e] = event[e]
    return same and (dmax <= 1.0 or (it > 0 and dmax * dmax <= dprev)), same, dmax


@numba.njit(**_INLINE)
def tangents(d: Discretisation, w: Work) -> bool:
    """``w.lin``: each element's force change over the last corrector change ``w.delta``
    by the trapezoid rule of its law's tangents at both ends (exact for a stick-slip joint
    on its branch), the rule's error bound (half the tangent change times delta, a bound for
    one kink too) and the end tangents. False where an element has none (a located event,
    a law with memory other than stick-slip)."""
    codes, smooth, prm = d.codes, d.smooth, d.prm
    uv, delta, g, lin = w.uv, w.delta, w.g, w.lin
    ne = g.shape[0]
    for e in range(ne):
        if w.event[e] != 0:
            return False
        if codes[e] == STICK_SLIP:
            kd = prm[e, 0] if w.sigma0[e] == 0.0 else 0.0
            lin[0, e], lin[1, e], lin[2, e], lin[3, e] = kd * delta[e], 0.0, kd, 0.0
        elif smooth[e]:
            u1, v1, du, dv = uv[e], uv[ne + e], delta[e], delta[ne + e]
            t0 = _element_tangent(codes[e], prm[e, 0], prm[e, 1], prm[e, 2], prm[e, 3],
                                  u1 - du, v1 - dv, 0.0, 0.0, 0.0, 0.0, g[e])
            t1 = _element_tangent(codes[e], prm[e, 0], prm[e, 1], prm[e, 2], prm[e, 3],
                                  u1, v1, 0.0, 0.0, 0.0, 0.0, g[e])
            lin[0, e] = 0.5 * ((t0[0] + t1[0]) * du + (t0[1] + t1[1]) * dv)
            lin[1, e] = 0.5 * (abs((t1[0] - t0[0]) * du) + abs((t1[1] - t0[1]) * dv))
            lin[2, e], lin[3, e] = t1[0], t1[1]
        else:
            return False
    return True


@numba.njit(**_INLINE)
def close(d: Discretisation, ps: PlantState, w: Work) -> bool:
    """Close the corrector with the laws' tangents instead of another evaluation: the laws
    were evaluated at ``uv - delta``; the force changes of `tangents` add ``pwe dg`` to
    ``uv``. Accepted (and applied) when what remains is below the tolerance: the next
    linear change (end tangents times ``pwe dg``) plus the trapezoid's error bound, with no
    stick-slip joint leaving its branch."""
    codes, prm, pwe = d.codes, d.prm, d.pwe
    pk, uv, acc, g, gc, lin, sigma0 = w.pk, w.uv, w.acc, w.g, w.gc, w.lin, w.sigma0
    ne = g.shape[0]
    if not tangents(d, w):
        return False
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
            return False
    for e in range(ne):
        if codes[e] == STICK_SLIP:
            kd, fd = prm[e, 0], prm[e, 1]
            if sigma0[e] == 0.0:
                if not abs(kd * (uv[e] + acc[e] - ps.es[e, 0])) <= fd:
                    return False
            elif not sigma0[e] * (uv[ne + e] + acc[ne + e]) >= 0.0:
                return False
    for r in range(2 * ne):
        uv[r] += acc[r]
    for e in range(ne):
        g[e] += lin[0, e]
        gc[e] += lin[0, e]
        if codes[e] == STICK_SLIP and sigma0[e] != 0.0:
            w.st[e, 0] = uv[e] - sigma0[e] * prm[e, 1] / prm[e, 0]
    return True


@numba.njit(**_INLINE)
def correct(d: Discretisation, ps: PlantState, w: Work) -> tuple[int, bool]:
    """Fixed-point iteration of the end node's element forces from the predictor; returns
    the evaluations made and whether it converged (to ``RTOL``, or closed by `close`)."""
    dprev = 0.0
    for e in range(w.ev_prev.shape[0]):
        w.ev_prev[e] = 0
    for it in range(MAX_ITER):
        law_pass(d, ps, w)
        stop, same, dmax = settled(it, dprev, w)
        if stop or (same and close(d, ps, w)):
            return it + 1, True
        dprev = dmax
    return MAX_ITER, False


@numba.njit(**_INLINE)
def commit(d: Discretisation, ps: PlantState, w: Work) -> int:
    """Accept the substep: the end state (the hold used ``gc`` at the end node, the history
    keeps ``g``; located jumps added), element memory and hold history shifted by one node
    (continued on the new branch after an event). Returns the events located."""
    u_g, we, ab, r_g, prm = d.u_g, d.we, d.ab, d.r_g, d.prm
    s, gh, uh, es = ps.s, ps.gh, ps.uh, ps.es
    kn, g, gc, uv, event, ev_c, gold = w.kn, w.g, w.gc, w.uv, w.event, w.ev_c, w.gold
    ny = s.shape[0]
    ne, q = gh.shape
    nt = ev_c.shape[1]
    for e in range(ne - 1):   # the last element's pass writes the new state: no copy of kn
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
    n_events = 0
    for e in range(ne):
        for i in range(es.shape[1]):
            es[e, i] = w.st[e, i]
        for nd in range(q - 1):
            gh[e, nd] = gh[e, nd + 1]
            uh[e, nd] = uh[e, nd + 1]
        gh[e, q - 1] = g[e]
        uh[e, q - 1] = uv[e]
        w.vh[e] = uv[ne + e]
        if event[e] == 0:
            continue
        n_events += 1
        for nd in range(q - 1):
            gold[nd] = gh[e, nd]
        for nd in range(q - 1):
            gh[e, nd] = g[e] if event[e] == 1 else (  # the slip branch, or the new stick one
                w.sigma0[e] * prm[e, 1] + prm[e, 0] * (uh[e, nd] - w.ev_ut[e]))
        for nd in range(q - 1):  # the accumulated state holds the old history
            _axpy(gh[e, nd] - gold[nd], r_g[q - 1 - nd, e], s)
    return n_events


@numba.njit(**_INLINE)
def _axpy(a: float, x: np.ndarray, out: np.ndarray) -> None:
    """``out += a x``."""
    for r in range(out.shape[0]):
        out[r] += a * x[r]
