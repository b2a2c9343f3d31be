"""Numba hot loop of the simulated plant; the method is described in `analysis.plant._plant`.

The plant keeps the stick_slip slip direction (+1/-1, 0 sticking) in element state slot 1
next to the slider position in slot 0 (`element_force` ignores slot 1).

Notation: ``y = [x, v]`` (2n), ``q`` = hold degree, hold nodes at ``s/h = 1-q .. 0, 1``
(the last ``q`` are history, the last one is the end of the substep). ``gh``/``uh`` hold each
element's force and deformation at the history nodes (column ``q-1`` = start of the substep).
The records are in `analysis.plant._records`, the stages of a substep in
`analysis.plant._substep`, the hold polynomial's algebra in `analysis.plant._hold`.
"""

from __future__ import annotations

import numba
import numpy as np

from .._numba_cache import guard
from ._records import Discretisation, Outputs, PlantState, Work, work
from ._substep import commit, correct, known_part, predict

guard(__file__, "..models._elements", "_substep", "_hold", "_records")

# reassociation lets LLVM vectorise the dot products (deterministic all the same)
FASTMATH = {"reassoc", "contract"}
# stats slots
S_SUBSTEPS, S_ITER, S_EVENTS, S_NOCONV = 0, 1, 2, 3


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


@numba.njit(cache=True, inline="always")
def _sample(k: int, d: Discretisation, ps: PlantState, w: Work, out: Outputs) -> None:
    """Output sample ``k``: element forces, deformations and rates, and x, v, a at the
    points (the state less the pending history ``w.z``; one loop per point and operand for
    all three kinds: short loops cost more in set-up and reduction than in arithmetic)."""
    shapes, tax, tav, out_z = d.shapes, d.tax, d.tav, d.out_z
    s, g, uv, z = ps.s, w.g, w.uv, w.z
    n = s.shape[0] // 2
    ne = g.shape[0]
    for e in range(ne):
        out.g[k, e] = g[e]
        out.uv[k, e] = uv[e]
        out.uv[k, ne + e] = uv[ne + e]
    _history(ps.fprev, ps.gh, z)
    for p in range(out.x.shape[1]):
        x, v, ax = 0.0, 0.0, 0.0
        if d.identity:
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
        out.x[k, p] = x
        out.v[k, p] = v
        out.a[k, p] = ax


@numba.njit(cache=True, inline="always")
def _begin(d: Discretisation, ps: PlantState, w: Work) -> None:
    """Start of a chunk: the pending history ``w.z``, the end-node forces ``w.g`` and the
    deformation rates ``w.vh`` of the last node, from the state (as a call of its own)."""
    s, gh = ps.s, ps.gh
    n = s.shape[0] // 2
    ne, q = gh.shape
    _history(ps.fprev, gh, w.z)
    for e in range(ne):
        w.g[e] = gh[e, q - 1]
        tv, tz = 0.0, 0.0
        for c in range(n):
            tv += d.wq[e, c] * s[n + c]
        for c in range(d.r_v.shape[1]):
            tz += d.r_v[e, c] * w.z[c]
        w.vh[e] = tv - tz


@numba.njit(cache=True, inline="always")
def _save(ps: PlantState, start: PlantState) -> None:
    """Copy the state ``ps`` into ``start`` (the start of a chunk, for the check)."""
    for a, b in ((ps.s, start.s), (ps.fprev, start.fprev)):
        for i in range(a.shape[0]):
            b[i] = a[i]
    for a, b in ((ps.gh, start.gh), (ps.uh, start.uh), (ps.es, start.es)):
        for i in range(a.shape[0]):
            for j in range(a.shape[1]):
                b[i, j] = a[i, j]


@numba.njit(cache=True, inline="always")
def _needs_check(i: int, j: int, ps: PlantState, out: Outputs, peak_ok: np.ndarray) -> bool:
    """Whether the chunk ``i:j`` goes back to the caller: the state is not finite, or an
    element's deformation or rate peak over the chunk exceeds ``peak_ok`` (what the
    step-doubling check has cleared)."""
    for r in range(ps.s.shape[0]):
        if not np.isfinite(ps.s[r]):
            return True
    uv = out.uv
    for c in range(uv.shape[1]):
        bound = peak_ok[c]
        for k in range(i, j):
            if abs(uv[k, c]) > bound:
                return True
    return False


def _run(force: np.ndarray, m: int, d: Discretisation, ps: PlantState, out: Outputs,
         stats: np.ndarray, w: Work, chunk: int, peak_ok: np.ndarray,
         start: PlantState) -> int:
    """Advance the plant over ``force.shape[0]`` output samples, ``m`` substeps each, in
    chunks of ``chunk`` samples; stop after the first chunk that `_needs_check` and return
    its first sample (else the number of samples). ``start`` receives the state at the start
    of each chunk.

    ``ps`` is updated in place (``s`` is the accumulated state of `analysis.plant._plant`,
    Method); ``out`` receives each output sample; ``stats`` counts substeps, corrector
    iterations, located events and unconverged substeps. The stages
    (`analysis.plant._substep`) are inlined into this loop.
    """
    s, fprev = ps.s, ps.fprev
    ne = ps.gh.shape[0]
    n_iter = n_noconv = n_events = 0    # counted locally: stores to stats cost in the loop
    n = force.shape[0]
    stop = n
    for i in range(0, n, chunk):
        j = min(i + chunk, n)
        _save(ps, start)
        _begin(d, ps, w)
        for k in range(i, j):
            for jj in range(m):
                known_part(force, k, jj, m, d, ps, w)
                if ne == 0:
                    for r in range(s.shape[0]):
                        s[r] = w.kn[r]
                    continue
                predict(d, ps, w)
                its, converged = correct(d, ps, w)
                n_iter += its
                n_noconv += 0 if converged else 1
                n_events += commit(d, ps, w)
            for r in range(fprev.shape[0]):
                fprev[r] = force[k, r]
            _sample(k, d, ps, w, out)
        stats[S_SUBSTEPS] += m * (j - i)
        if _needs_check(i, j, ps, out, peak_ok):
            stop = i
            break
    stats[S_ITER] += n_iter
    stats[S_NOCONV] += n_noconv
    stats[S_EVENTS] += n_events
    return stop


# The loop compiles without numba's reference counting (``_nrt=False``, a numba compiler
# option): it allocates nothing (`integrate` hands it its scratch), and every record field a
# stage reads would otherwise cost an atomic increment and decrement per substep, which made
# the stages 4.4x slower than one written-out loop (thread CPU, 3-DOF benchmark, same run);
# without them the split loop runs as fast as the written-out one.
_run_fast = numba.njit(cache=True, error_model="numpy", fastmath=FASTMATH, _nrt=False)(_run)
_run_strict = numba.njit(error_model="numpy", _nrt=False)(_run)


@numba.njit(cache=True)
def integrate(force: np.ndarray, m: int, d: Discretisation, ps: PlantState, out: Outputs,
              stats: np.ndarray, chunk: int, peak_ok: np.ndarray, start: PlantState) -> int:
    """`_run` with fast-math."""
    return _run_fast(force, m, d, ps, out, stats, work(d, ps, force.shape[1]), chunk,
                     peak_ok, start)


@numba.njit
def integrate_strict(force: np.ndarray, m: int, d: Discretisation, ps: PlantState,
                     out: Outputs, stats: np.ndarray, chunk: int, peak_ok: np.ndarray,
                     start: PlantState) -> int:
    """`_run` without fast-math."""
    return _run_strict(force, m, d, ps, out, stats, work(d, ps, force.shape[1]), chunk,
                       peak_ok, start)
