"""Multi-harmonic balance with alternating frequency–time (AFT) evaluation (paper chapter 4).

The periodic response to ``f(t) = Re(F e^{jωt})`` is ``x(t) = Re(sum_k X_k e^{j h_k ω t})`` over
the chosen harmonic orders ``h_k`` (0 allowed for a static offset). With the receptance
``H(ω) = Z(ω)^-1`` of the underlying linear system (from a model or a measured FRF, paper eq 32),
the balance is condensed onto the element deformations ``U_k = w_m . X_k``::

    R_k(U) = U_k - W^T H(h_k ω) B F δ(h_k, 1) + W^T H(h_k ω) W G_k(U) = 0

``G_k`` are the Fourier coefficients of the element forces, evaluated in the time domain over one
period by the numba kernel of `analysis.elements` (AFT). Elements with memory (stick-slip,
hysteresis) run period after period until the force cycle repeats. Newton's method uses the
AFT-consistent Jacobian: every coefficient is perturbed through the same periodic time loop, so
the Jacobian matches the discrete map exactly, memory kinds included. The sensitivities with
respect to element parameters (for fitting) follow from the implicit-function theorem.

Unknown vector layout (real): ``y[e * 2H + part * H + i]`` with part 0 = Re, 1 = Im of ``U_i``
of element ``e``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numba
import numpy as np

from .elements import KINDS, N_PARAM, N_STATE, element_force, pack_params, restoring_force
from .errors import InputError
from .model import Model

Receptance = Callable[[np.ndarray], np.ndarray]  # freqs (n,) Hz -> (n, n_dof, n_dof)


class HBMError(InputError):
    """Bad harmonic-balance input (harmonic orders, forces, frequencies)."""


@numba.njit(cache=True)
def _time_series(y, omega, harm, cos_t, sin_t, u, v):
    nh = harm.shape[0]
    for n in range(u.shape[0]):
        su = 0.0
        sv = 0.0
        for i in range(nh):
            a = y[i]
            b = y[nh + i]
            c = cos_t[i, n]
            s = sin_t[i, n]
            su += a * c - b * s
            sv += harm[i] * omega * (-a * s - b * c)
        u[n] = su
        v[n] = sv


@numba.njit(cache=True)
def _deformation_at(y, harm, theta):
    nh = harm.shape[0]
    u = 0.0
    for i in range(nh):
        u += y[i] * np.cos(harm[i] * theta) - y[nh + i] * np.sin(harm[i] * theta)
    return u


@numba.njit(cache=True)
def _one_period(code, p, memory, y, harm, u, v, s, g):
    """Element forces over one period from state ``s`` (updated in place). For memory kinds
    the kernel is also called at each turning point of ``u`` (located between samples), so
    the stored reversal state — and the AFT map — is continuous in ``y``: turning points on
    the grid make jumps of O(dθ^2) at which Newton stalls."""
    s_next = np.empty_like(s)
    nt = u.shape[0]
    dtheta = 2 * np.pi / nt
    v_prev = v[nt - 1]
    for n in range(nt):
        if memory and v_prev * v[n] < 0.0:
            frac = v_prev / (v_prev - v[n])
            theta = (n - 1 + frac) * dtheta
            element_force(code, p, _deformation_at(y, harm, theta), 1e-300 * np.sign(v[n]),
                          s, s_next)
            s[:] = s_next
        g[n] = element_force(code, p, u[n], v[n], s, s_next)
        s[:] = s_next
        if v[n] != 0.0:
            v_prev = v[n]


@numba.njit(cache=True)
def _coefficients(g, harm, cos_t, sin_t, out):
    nh = harm.shape[0]
    nt = g.shape[0]
    for i in range(nh):
        c = 0.0
        s = 0.0
        for n in range(nt):
            c += g[n] * cos_t[i, n]
            s += g[n] * sin_t[i, n]
        w = 1.0 / nt if harm[i] == 0 else 2.0 / nt
        out[i] = w * c
        out[nh + i] = -w * s


@numba.njit(cache=True)
def _periodic(code, p, memory, y, harm, u, v, s0, max_periods, tol, g):
    """Run periods from state ``s0`` until the cycle repeats (same state at the start and
    end of a period, or the same forces twice); returns the start state of the last period."""
    s = s0.copy()
    start = s.copy()
    if not memory:
        _one_period(code, p, memory, y, harm, u, v, s, g)
        return start
    g_prev = np.empty_like(g)
    for k in range(max_periods):
        start[:] = s
        _one_period(code, p, memory, y, harm, u, v, s, g)
        same = True
        for i in range(s.shape[0]):
            if abs(s[i] - start[i]) > tol * max(abs(s[i]), abs(start[i])):
                same = False
        if same:
            return start
        if k > 0:
            diff = 0.0
            big = 0.0
            for n in range(g.shape[0]):
                diff = max(diff, abs(g[n] - g_prev[n]))
                big = max(big, abs(g[n]))
            if diff <= tol * big + 1e-300:
                return start
        g_prev[:] = g
    return start


@numba.njit(cache=True)
def _element_aft(code, p, memory, y, omega, harm, cos_t, sin_t, max_periods, tol, scale,
                 G, dG, jac):
    """Fourier coefficients ``G`` (2H) of one element and, if ``jac``, dG/dy (2H, 2H)."""
    nt = cos_t.shape[1]
    m = y.shape[0]
    u = np.empty(nt)
    v = np.empty(nt)
    g = np.empty(nt)
    _time_series(y, omega, harm, cos_t, sin_t, u, v)
    start = _periodic(code, p, memory, y, harm, u, v, np.zeros(N_STATE), max_periods,
                      tol, g)
    _coefficients(g, harm, cos_t, sin_t, G)
    if not jac:
        return start
    norm = 0.0
    for i in range(m):
        norm += y[i] * y[i]
    eps = 1e-7 * max(np.sqrt(norm), scale)
    yp = y.copy()
    up = np.empty(nt)
    vp = np.empty(nt)
    Gp = np.empty(m)
    reps = 2 if memory else 1
    for d in range(m):
        yp[d] = y[d] + eps
        _time_series(yp, omega, harm, cos_t, sin_t, up, vp)
        s = start.copy()
        for _ in range(reps):
            _one_period(code, p, memory, yp, harm, up, vp, s, g)
        _coefficients(g, harm, cos_t, sin_t, Gp)
        for i in range(m):
            dG[i, d] = (Gp[i] - G[i]) / eps
        yp[d] = y[d]
    return start


@numba.njit(cache=True)
def _evaluate(y, ylin, Hr, codes, P, mem, omega, harm, cos_t, sin_t, max_periods, tol,
              scale, jac):
    """Condensed residual ``r`` and (if ``jac``) its Jacobian, plus the block dG/dy."""
    m = y.shape[0]
    nb = 2 * harm.shape[0]
    n_el = codes.shape[0]
    Gv = np.zeros(m)
    dGb = np.zeros((n_el, nb, nb))
    for e in range(n_el):
        sl = slice(e * nb, (e + 1) * nb)
        _element_aft(codes[e], P[e], mem[e], y[sl], omega, harm, cos_t, sin_t, max_periods,
                     tol, scale, Gv[sl], dGb[e], jac)
    r = y - ylin + Hr @ Gv
    J = _assemble(Hr, dGb) if jac else np.zeros((m, m))
    return r, J, Gv, dGb


@numba.njit(cache=True)
def _assemble(Hr, dGb):
    """Condensed Jacobian ``I + Hr blockdiag(dG/dy)``."""
    m = Hr.shape[0]
    nb = dGb.shape[1]
    J = np.eye(m)
    for e in range(dGb.shape[0]):
        J[:, e * nb:(e + 1) * nb] += np.ascontiguousarray(Hr[:, e * nb:(e + 1) * nb]) @ dGb[e]
    return J


@numba.njit(cache=True)
def _newton(y0, dGb0, ylin, Hr, codes, P, mem, omega, harm, cos_t, sin_t, max_periods, tol,
            scale, max_iter, need_jac):
    """Newton–chord iteration from ``y0`` with the (possibly stale) AFT blocks ``dGb0``.

    The AFT Jacobian costs 2H+1 time loops per element, a residual one, so the Jacobian is
    kept while each step at least halves the residual and refreshed (then backtracked) when
    it does not. Returns y, converged, iterations, G, dG/dy blocks and the Jacobian (fresh
    at the solution if ``need_jac``, else the last one used).
    """
    y = y0.copy()
    J = _assemble(Hr, dGb0)
    r, _j, Gv, _d = _evaluate(y, ylin, Hr, codes, P, mem, omega, harm, cos_t, sin_t,
                              max_periods, tol, scale, False)
    dGb = dGb0.copy()
    rn = np.sqrt(np.sum(r * r))
    fresh = False
    converged = False
    it = 0
    while it < max_iter:
        it += 1
        dy = np.linalg.solve(J, -r)
        step = np.sqrt(np.sum(dy * dy))
        yt = y + dy
        rt, _j, Gt, _d = _evaluate(yt, ylin, Hr, codes, P, mem, omega, harm, cos_t, sin_t,
                                   max_periods, tol, scale, False)
        rtn = np.sqrt(np.sum(rt * rt))
        small = step <= tol * (np.sqrt(np.sum(yt * yt)) + scale)
        if not small and rtn > 0.5 * rn:
            if not fresh:  # re-linearise at y and retry
                r, J, Gv, dGb = _evaluate(y, ylin, Hr, codes, P, mem, omega, harm, cos_t,
                                          sin_t, max_periods, tol, scale, True)
                fresh = True
                continue
            alpha = 1.0
            for _ in range(12):
                alpha *= 0.5
                yt = y + alpha * dy
                rt, _j, Gt, _d = _evaluate(yt, ylin, Hr, codes, P, mem, omega, harm, cos_t,
                                           sin_t, max_periods, tol, scale, False)
                rtn = np.sqrt(np.sum(rt * rt))
                if rtn < rn:
                    break
        y, r, Gv, rn = yt, rt, Gt, rtn
        fresh = False
        if small:
            converged = True
            break
    if need_jac:
        r, J, Gv, dGb = _evaluate(y, ylin, Hr, codes, P, mem, omega, harm, cos_t, sin_t,
                                  max_periods, tol, scale, True)
    return y, converged, it, Gv, dGb, J


@numba.njit(cache=True)
def _rotate(y, harm, factor, phi):
    """Guess ``factor * U_k e^{j h_k phi}`` for every element and harmonic."""
    nh = harm.shape[0]
    out = np.empty_like(y)
    for e in range(y.shape[0] // (2 * nh)):
        for i in range(nh):
            a = y[e * 2 * nh + i]
            b = y[e * 2 * nh + nh + i]
            c = np.cos(harm[i] * phi)
            s = np.sin(harm[i] * phi)
            out[e * 2 * nh + i] = factor * (a * c - b * s)
            out[e * 2 * nh + nh + i] = factor * (a * s + b * c)
    return out


@numba.njit(cache=True)
def _ramp(ylin, Hr, codes, P, mem, omega, harm, cos_t, sin_t, max_periods, tol, scale,
          max_iter, need_jac):
    """Restart: continuation in the force amplitude from 1/1024 of it (where the elements
    act with their initial tangent) up to the full force, doubling it each time."""
    lam = 1.0 / 1024.0
    y = lam * ylin
    total = 0
    while True:
        _r, _j, _g, dGb = _evaluate(y, lam * ylin, Hr, codes, P, mem, omega, harm, cos_t,
                                    sin_t, max_periods, tol, scale * lam, True)
        y, conv, it, Gv, dGb, J = _newton(y, dGb, lam * ylin, Hr, codes, P, mem, omega, harm,
                                          cos_t, sin_t, max_periods, tol, scale * lam,
                                          max_iter, need_jac)
        total += it
        if not conv or lam == 1.0:
            return y, conv, total, Gv, dGb, J
        new = min(1.0, 2.0 * lam)
        y = y * (new / lam)
        lam = new


@numba.njit(cache=True)
def _sweep(Hr_all, ylin_all, omegas, codes, P, mem, harm, cos_t, sin_t, max_periods, tol,
           scale, max_iter, sens_el, sens_slot, Y0, use_Y0):
    """Natural continuation over frequencies (or from the guesses ``Y0``); optional
    parameter sensitivities dG/dθ."""
    nf, m = ylin_all.shape
    nb = 2 * harm.shape[0]
    ns = sens_el.shape[0]
    Y = np.zeros((nf, m))
    G = np.zeros((nf, m))
    dGp = np.zeros((nf, m, ns))
    ok = np.zeros(nf, dtype=np.bool_)
    iters = np.zeros(nf, dtype=np.int64)
    y = Y0[0].copy() if use_Y0 else ylin_all[0].copy()
    _r, _j, _g, dGb = _evaluate(y, ylin_all[0], Hr_all[0], codes, P, mem, omegas[0], harm,
                                cos_t, sin_t, max_periods, tol, scale, True)
    for j in range(nf):
        if use_Y0:
            y = Y0[j].copy()
        elif j >= 2:  # secant predictor along the sweep
            y = Y[j - 1] + (Y[j - 1] - Y[j - 2]) * ((omegas[j] - omegas[j - 1])
                                                    / (omegas[j - 1] - omegas[j - 2]))
        y, conv, it, Gv, dGb, J = _newton(y, dGb, ylin_all[j], Hr_all[j], codes, P, mem,
                                          omegas[j], harm, cos_t, sin_t, max_periods, tol,
                                          scale, max_iter, ns > 0)
        # a sweep past a fold jumps to another branch: try scaled and phase-shifted guesses
        base = Y[j - 1].copy() if j > 0 else ylin_all[j].copy()
        for factor in (1.0, 2.0, 0.5, 4.0):
            for phi in (-0.5 * np.pi, 0.5 * np.pi, -0.25 * np.pi, 0.25 * np.pi):
                if conv:
                    break
                y, conv, it2, Gv, dGb, J = _newton(_rotate(base, harm, factor, phi), dGb,
                                                   ylin_all[j], Hr_all[j], codes, P, mem,
                                                   omegas[j], harm, cos_t, sin_t,
                                                   max_periods, tol, scale, 20, ns > 0)
                it += it2
        if not conv:
            y, conv, it2, Gv, dGb, J = _ramp(ylin_all[j], Hr_all[j], codes, P, mem,
                                             omegas[j], harm, cos_t, sin_t, max_periods, tol,
                                             scale, max_iter, ns > 0)
            it += it2
        Y[j] = y
        G[j] = Gv
        ok[j] = conv
        iters[j] = it
        if ns:
            dth = np.zeros((m, ns))  # explicit dG/dθ, by perturbing each parameter
            Gq = np.empty(nb)
            dummy = np.empty((nb, nb))
            for q in range(ns):
                e = sens_el[q]
                pq = P[e].copy()
                h = 1e-7 * max(abs(pq[sens_slot[q]]), 1e-12)
                pq[sens_slot[q]] += h
                _element_aft(codes[e], pq, mem[e], y[e * nb:(e + 1) * nb], omegas[j], harm,
                             cos_t, sin_t, max_periods, tol, scale, Gq, dummy, False)
                for i in range(nb):
                    dth[e * nb + i, q] = (Gq[i] - Gv[e * nb + i]) / h
            dy = np.linalg.solve(J, -(Hr_all[j] @ dth))
            tot = dth.copy()
            for e in range(codes.shape[0]):
                tot[e * nb:(e + 1) * nb] += dGb[e] @ np.ascontiguousarray(
                    dy[e * nb:(e + 1) * nb])
            dGp[j] = tot
    return Y, G, dGp, ok, iters


# --- Python interface ----------------------------------------------------------------------

def model_receptance(model: Model) -> Receptance:
    """Receptance function of a model's underlying linear system."""
    def receptance(freqs: np.ndarray) -> np.ndarray:
        return model.linear_frf(np.asarray(freqs, dtype=float))
    return receptance


def parse_harmonics(harmonics: Sequence[int] | str) -> np.ndarray:
    """Validated, sorted harmonic orders from a sequence or a string such as ``"1,3,5,7"``."""
    if isinstance(harmonics, str):
        try:
            harmonics = [int(h) for h in harmonics.replace(" ", "").split(",") if h]
        except ValueError:
            raise HBMError(f"harmonics '{harmonics}' must be comma-separated integers, "
                           "e.g. 1,3,5,7") from None
    h = np.asarray(sorted(set(int(k) for k in harmonics)), dtype=np.int64)
    if h.size == 0 or h.min() < 0 or 1 not in h:
        raise HBMError(f"harmonics {h.tolist()} must be orders >= 0 that include 1 "
                       "(the drive frequency), e.g. 1,3,5,7")
    return h


@dataclass
class HBMResult:
    """Periodic responses over a set of frequencies at one force amplitude.

    Attributes
    ----------
    freqs : ndarray, shape (n_f,)
    harmonics : ndarray of int, shape (n_h,)
    X : ndarray, complex, shape (n_f, n_h, n_dof)
        Displacement coefficients: ``x(t) = Re(sum_k X_k e^{j h_k ω t})``.
    U : ndarray, complex, shape (n_f, n_h, n_el)
        Element deformation coefficients.
    G : ndarray, complex, shape (n_f, n_h, n_el)
        Element force coefficients.
    converged : ndarray of bool, shape (n_f,)
    iterations : ndarray of int, shape (n_f,)
    dG : ndarray, complex, shape (n_f, n_h, n_el, n_sens), optional
        Total derivative of ``G`` with respect to the requested parameters.
    """

    freqs: np.ndarray
    harmonics: np.ndarray
    X: np.ndarray
    U: np.ndarray
    G: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    dG: np.ndarray | None = None

    def frf(self, dof: int, amplitude: float) -> np.ndarray:
        """Fundamental receptance ``X_1[dof] / F`` (complex, shape (n_f,))."""
        i1 = int(np.flatnonzero(self.harmonics == 1)[0])
        return self.X[:, i1, dof] / amplitude


class HBMSystem:
    """A model prepared for harmonic balance at chosen harmonics and force DOFs.

    Parameters
    ----------
    model : Model
        Underlying linear system plus elements (parameters may be set later via ``params``).
    force_dofs : sequence of int
        DOF of each force input.
    harmonics : sequence of int or str
        Harmonic orders, e.g. ``(1, 3, 5, 7)``; include even ones (and 0) for asymmetric laws.
    receptance : callable, optional
        Underlying linear receptance ``H(freqs) -> (n, n_dof, n_dof)``; the model's by default.
    n_time : int, optional
        AFT samples per period (default: power of two >= 16 * max harmonic, at least 64).
    tol : float
        Relative Newton and periodicity tolerance.
    """

    def __init__(self, model: Model, force_dofs: Sequence[int] = (0,),
                 harmonics: Sequence[int] | str = (1, 3, 5, 7), *,
                 receptance: Receptance | None = None, n_time: int | None = None,
                 tol: float = 1e-9, max_iter: int = 60, max_periods: int = 50) -> None:
        self.model = model
        self.harmonics = parse_harmonics(harmonics)
        self.force_dofs = np.atleast_1d(np.asarray(force_dofs, dtype=int))
        if np.any(self.force_dofs < 0) or np.any(self.force_dofs >= model.n_dof):
            raise HBMError(f"force_dofs {self.force_dofs.tolist()} outside 0..{model.n_dof - 1}")
        hmax = int(self.harmonics.max())
        self.n_time = int(n_time or max(64, 1 << int(np.ceil(np.log2(16 * hmax)))))
        if self.n_time < 2 * hmax + 2:
            raise HBMError(f"n_time {self.n_time} is too small for harmonic {hmax}; use at "
                           f"least {2 * hmax + 2}")
        self.receptance = receptance or model_receptance(model)
        self.tol, self.max_iter, self.max_periods = tol, max_iter, max_periods
        theta = 2 * np.pi * np.arange(self.n_time) / self.n_time
        self._cos = np.ascontiguousarray(np.cos(np.outer(self.harmonics, theta)))
        self._sin = np.ascontiguousarray(np.sin(np.outer(self.harmonics, theta)))
        els = model.elements
        self.W = np.array([el.w for el in els]).T.reshape(model.n_dof, len(els))
        self.B = np.zeros((model.n_dof, self.force_dofs.size))
        self.B[self.force_dofs, np.arange(self.force_dofs.size)] = 1.0
        self.n_el = len(els)
        self.codes = np.array([KINDS[el.kind].code for el in els], dtype=np.int64)
        self.memory = np.array([KINDS[el.kind].memory for el in els], dtype=np.bool_)
        self.params = np.zeros((len(els), N_PARAM))
        for e, el in enumerate(els):
            if el.known:
                self.params[e] = pack_params(el.kind, el.params)

    # --- linear operators ----------------------------------------------------------------
    def _linear(self, freqs: np.ndarray, force: np.ndarray):
        """Receptances at every harmonic: (n_f, n_h, n_dof, n_dof), real block operators,
        linear deformation vectors and the force vector."""
        nh, n_el = self.harmonics.size, self.n_el
        hk = np.outer(freqs, self.harmonics).ravel()
        H = np.asarray(self.receptance(hk), dtype=complex).reshape(
            freqs.size, nh, self.model.n_dof, self.model.n_dof)
        Hc = np.einsum("dm,fhde,en->fhmn", self.W, H, self.W)   # W^T H W
        ulin = np.zeros((freqs.size, nh, n_el), dtype=complex)
        i1 = int(np.flatnonzero(self.harmonics == 1)[0])
        ulin[:, i1] = np.einsum("dm,fde,fe->fm", self.W, H[:, i1], force @ self.B.T)
        nb = 2 * nh
        Hr = np.zeros((freqs.size, n_el, nb, n_el, nb))
        idx = np.arange(nh)
        for a in range(n_el):
            for b in range(n_el):
                re, im = Hc[:, :, a, b].real, Hc[:, :, a, b].imag
                Hr[:, a, idx, b, idx] = re
                Hr[:, a, idx, b, nh + idx] = -im
                Hr[:, a, nh + idx, b, idx] = im
                Hr[:, a, nh + idx, b, nh + idx] = re
        m = nb * n_el
        ylin = np.concatenate([ulin.real, ulin.imag], axis=1).transpose(0, 2, 1)
        return H, Hr.reshape(freqs.size, m, m), ylin.reshape(freqs.size, m).copy()

    def _check(self, freqs, force, params):
        freqs = np.atleast_1d(np.asarray(freqs, dtype=float))
        if freqs.ndim != 1 or freqs.size == 0 or np.any(~np.isfinite(freqs)) \
                or np.any(freqs <= 0):
            raise HBMError("frequencies must be a non-empty list of positive numbers (Hz)")
        force = np.atleast_1d(np.asarray(force, dtype=float))
        n_in = self.force_dofs.size
        if force.shape not in ((n_in,), (freqs.size, n_in)) or not np.all(np.isfinite(force)):
            raise HBMError(f"force amplitude needs {n_in} finite value(s) (one per force DOF) "
                           f"or one such row per frequency, got shape {force.shape}")
        force = np.broadcast_to(force, (freqs.size, n_in))
        P = self.params if params is None else np.asarray(params, dtype=float)
        if params is None:
            self.model.require_complete("harmonic balance")
        return freqs, force, np.ascontiguousarray(P)

    def sweep(self, freqs: Sequence[float], force: Sequence[float] | float, *,
              params: np.ndarray | None = None,
              sensitivities: Sequence[tuple[int, int]] = (),
              guess: np.ndarray | None = None) -> HBMResult:
        """Periodic responses at ``freqs`` (solved in the given order, each point starting
        from the previous one — a stepped-sine sweep) for force amplitudes ``force``,
        shape (n_in,) or (n_f, n_in).

        ``params`` overrides the packed element parameters (n_el, N_PARAM);
        ``sensitivities`` lists (element, parameter slot) pairs whose total derivatives
        dG/dθ are returned in ``HBMResult.dG``; ``guess`` (complex (n_f, n_h, n_el), e.g. a
        previous result's ``U``) starts every point from its own guess instead.
        """
        freqs, force, P = self._check(freqs, force, params)
        H, Hr, ylin = self._linear(freqs, force)
        nh, n_el = self.harmonics.size, self.n_el
        x_lin = np.einsum("fhde,fe->fhd", H, force @ self.B.T) \
            * (self.harmonics == 1)[:, None]
        if n_el == 0:
            empty = np.zeros((freqs.size, nh, 0), dtype=complex)
            return HBMResult(freqs, self.harmonics, x_lin, empty, empty,
                             np.ones(freqs.size, bool), np.zeros(freqs.size, int))
        sens = np.array(list(sensitivities), dtype=np.int64).reshape(-1, 2)
        scale = max(float(np.abs(ylin).max()), 1e-300)
        Y, Gv, dGp, ok, iters = _sweep(
            Hr, ylin, 2 * np.pi * freqs, self.codes, P, self.memory, self.harmonics,
            self._cos, self._sin, self.max_periods, self.tol, scale, self.max_iter,
            np.ascontiguousarray(sens[:, 0]), np.ascontiguousarray(sens[:, 1]),
            ylin if guess is None else _to_real(np.asarray(guess)), guess is not None)
        U = _to_complex(Y, n_el, nh)
        G = _to_complex(Gv, n_el, nh)
        X = x_lin - np.einsum("fhde,em,fhm->fhd", H, self.W, G)
        dG = None
        if sens.size:
            d = dGp.reshape(freqs.size, n_el, 2, nh, -1)
            dG = (d[:, :, 0] + 1j * d[:, :, 1]).transpose(0, 2, 1, 3)
        return HBMResult(freqs, self.harmonics, X, U, G, ok, iters, dG)

    # --- single-point access for continuation -------------------------------------------
    def _point(self, y, freq, force, jac):
        freqs, force, P = self._check([freq], force, None)
        H, Hr, ylin = self._linear(freqs, force)
        scale = max(float(np.abs(ylin).max()), 1e-300)
        r, J, Gv, _ = _evaluate(np.asarray(y, dtype=float), ylin[0], Hr[0], self.codes, P,
                                self.memory, 2 * np.pi * freq, self.harmonics, self._cos,
                                self._sin, self.max_periods, self.tol, scale, jac)
        return H[0], force[0], ylin[0], r, J, Gv

    def linear_state(self, freq: float, force: Sequence[float] | float) -> np.ndarray:
        """Condensed state of the underlying linear response (no element forces)."""
        return self._point(np.zeros(2 * self.harmonics.size * self.n_el), freq, force,
                           False)[2]

    def residual(self, y: np.ndarray, freq: float, force: Sequence[float] | float,
                 jac: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Condensed residual and its Jacobian dr/dy at ``(y, freq)``."""
        return self._point(y, freq, force, jac)[3:5]

    def response(self, y: np.ndarray, freq: float, force: Sequence[float] | float
                 ) -> np.ndarray:
        """Displacement coefficients X (n_h, n_dof) of the condensed state ``y``."""
        H, f, _, _, _, Gv = self._point(y, freq, force, False)
        G = _to_complex(Gv[None], self.n_el, self.harmonics.size)[0]
        x = H @ (self.B @ f) * (self.harmonics == 1)[:, None]
        return x - np.einsum("hde,em,hm->hd", H, self.W, G)


def _to_real(U: np.ndarray) -> np.ndarray:
    """(n_f, n_h, n_el) complex -> (n_f, m) real layout."""
    U = U.transpose(0, 2, 1)
    return np.ascontiguousarray(np.stack([U.real, U.imag], axis=2).reshape(U.shape[0], -1))


def _to_complex(Y: np.ndarray, n_el: int, nh: int) -> np.ndarray:
    """(n_f, m) real layout -> (n_f, n_h, n_el) complex."""
    Y = Y.reshape(Y.shape[0], n_el, 2, nh)
    return (Y[:, :, 0] + 1j * Y[:, :, 1]).transpose(0, 2, 1)



def loop(kind: str, params: dict[str, float], amplitude: float,
         n: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """Steady loop of one element under ``u = amplitude cos θ`` (paper fig 4.7): deformation
    and force over the last of three periods (closed: n + 1 points)."""
    theta = 2 * np.pi * np.arange(3 * n) / n
    u = amplitude * np.cos(theta)
    g, _ = restoring_force(kind, params, u, -amplitude * np.sin(theta))
    return u[-n - 1:], g[-n - 1:]
