"""Multi-harmonic balance with alternating frequency–time (AFT) evaluation (paper chapter 4).

The periodic response to ``f(t) = Re(F e^{jωt})`` is ``x(t) = Re(sum_k X_k e^{j h_k ω t})`` over
the chosen harmonic orders ``h_k`` (0 allowed for a static offset). With the receptance
``H(ω) = Z(ω)^-1`` of the underlying linear system (from a model or a measured FRF, paper eq 32),
the balance is condensed onto the element deformations ``U_k = w_m . X_k``::

    R_k(U) = U_k - W^T H(h_k ω) B F δ(h_k, 1) + W^T H(h_k ω) W G_k(U) = 0

``G_k`` are the Fourier coefficients of the element forces over one period, with their exact
derivatives ``dG/dU`` (`analysis.hbm._aft`). Each frequency point is solved by Newton's method in one
compiled function (``J = I + W^T H W dG/dU``, backtracking when the residual grows), starting
from a quadratic extrapolation of the previous points of the sweep. The sensitivities with
respect to element parameters (for fitting) follow from the implicit-function theorem.

Unknown vector layout (real): ``y[e * 2H + part * H + i]`` with part 0 = Re, 1 = Im of ``U_i``
of element ``e``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numba
import numpy as np

from ._aft import aft_tables, periodic_forces
from ..models import KINDS, N_PARAM, Model, pack_params, restoring_force
from ..errors import InputError
from .._numba_cache import guard

guard(__file__, "_aft", "..models._elements")

Receptance = Callable[[np.ndarray], np.ndarray]  # freqs (n,) Hz -> (n, n_dof, n_dof)

# AFT samples per period = _OVERSAMPLE x the highest order, rounded up to a power of two
# (at least 32). Slip onsets fall between samples, so the AFT error of friction laws decays
# only as 1/n_time^2: 16x keeps it below 0.25 % (or below the truncation error at order 7)
# on the Jenkins sweeps of tests/analysis/hbm/test_hbm.py, where 8x reaches 1 %.
_OVERSAMPLE = 16
_MIN_ALPHA = 1e-3       # smallest damping factor of a Newton step


class HBMError(InputError):
    """Bad harmonic-balance input (harmonic orders, forces, frequencies)."""


@numba.njit(cache=True)
def _evaluate(y, ylin, Hr, codes, P, mem, omega, harm, phi, dphi, dft, max_periods, tol,
              G, dGb):
    """Condensed residual ``y - ylin + Hr G(y)``; fills ``G`` and the per-element blocks
    ``dGb`` = dG/dy (n_el, 2H, 2H), unless they are empty (n_el, 0, 0)."""
    nb = 2 * harm.shape[0]
    for e in range(codes.shape[0]):
        periodic_forces(codes[e], P[e], mem[e], y[e * nb:(e + 1) * nb], omega, phi, dphi, dft,
                        harm, max_periods, tol, G[e * nb:(e + 1) * nb], dGb[e])
    return y - ylin + Hr @ G


@numba.njit(cache=True)
def _jacobian(Hr, dGb):
    """Condensed Jacobian ``I + Hr blockdiag(dG/dy)``."""
    m = Hr.shape[0]
    nb = dGb.shape[1]
    J = np.eye(m)
    for e in range(dGb.shape[0]):
        J[:, e * nb:(e + 1) * nb] += np.ascontiguousarray(Hr[:, e * nb:(e + 1) * nb]) @ dGb[e]
    return J


@numba.njit(cache=True)
def _norm(x):
    return np.sqrt(np.sum(x * x))


@numba.njit(cache=True)
def _newton(y0, ylin, Hr, codes, P, mem, omega, harm, phi, dphi, dft, max_periods, tol,
            scale, max_iter, min_alpha):
    """Newton's method from ``y0`` with the exact AFT Jacobian; the step is halved while
    the residual grows, down to ``min_alpha`` (1: full steps, which usually converge where a
    kink of the map is crossed and damping is slow: the sweep tries them first).

    Converged when the step, or the next one estimated from the contraction of the last two
    (θ/(1 - θ) |dy|, θ = |dy_k| / |dy_k-1| < 1/2), is below ``tol (|y| + scale)``; that
    last step is applied to ``y`` and, to first order, to ``G``. Returns y, converged,
    evaluations, G, dG/dy blocks and the Jacobian at the last evaluated point.
    """
    m = y0.shape[0]
    nb = 2 * harm.shape[0]
    n_el = codes.shape[0]
    y = y0.copy()
    G = np.zeros(m)
    dGb = np.zeros((n_el, nb, nb))
    r = _evaluate(y, ylin, Hr, codes, P, mem, omega, harm, phi, dphi, dft, max_periods, tol,
                  G, dGb)
    rn = _norm(r)
    n_eval = 1
    Gt = np.zeros(m)
    dGt = np.zeros((n_el, nb, nb))
    J = _jacobian(Hr, dGb)
    last = np.inf
    while n_eval < max_iter and np.isfinite(rn):
        dy = np.linalg.solve(J, -r)
        step = _norm(dy)
        theta = step / last if np.isfinite(last) else 1.0
        if step <= tol * (_norm(y) + scale) or (
                theta < 0.5 and theta / (1.0 - theta) * step <= tol * (_norm(y) + scale)):
            y += dy
            for e in range(n_el):
                G[e * nb:(e + 1) * nb] += dGb[e] @ dy[e * nb:(e + 1) * nb]
            return y, True, n_eval, G, dGb, J
        alpha = 1.0
        while True:
            yt = y + alpha * dy
            rt = _evaluate(yt, ylin, Hr, codes, P, mem, omega, harm, phi, dphi, dft,
                           max_periods, tol, Gt, dGt)
            n_eval += 1
            rtn = _norm(rt)
            if rtn < rn or alpha <= min_alpha or n_eval >= max_iter:
                break
            alpha *= 0.5
        last = alpha * step
        y, r, rn = yt, rt, rtn
        G[:] = Gt
        dGb[:] = dGt
        J = _jacobian(Hr, dGb)
    return y, False, n_eval, G, dGb, J


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
def _ramp(ylin, Hr, codes, P, mem, omega, harm, phi, dphi, dft, max_periods, tol, scale,
          max_iter):
    """Restart: continuation in the force amplitude from 1/1024 of it (where the elements
    act with their initial tangent) up to the full force, doubling it each time."""
    lam = 1.0 / 1024.0
    y = lam * ylin
    total = 0
    while True:
        y, conv, it, G, dGb, J = _newton(y, lam * ylin, Hr, codes, P, mem, omega, harm, phi,
                                         dphi, dft, max_periods, tol, scale * lam, max_iter,
                                         _MIN_ALPHA)
        total += it
        if not conv or lam == 1.0:
            return y, conv, total, G, dGb, J
        new = min(1.0, 2.0 * lam)
        y = y * (new / lam)
        lam = new


@numba.njit(cache=True)
def _predict(Y, ok, omegas, j):
    """Start of point ``j`` of a sweep: the constant, linear or quadratic (Lagrange)
    extrapolation through the converged points just before it; rest if there is none (the
    first Newton step is then the response with the elements' initial tangents, e.g. stick)."""
    k = 0
    while k < 3 and j - k - 1 >= 0 and ok[j - k - 1]:
        k += 1
    w = omegas[j]
    if k == 0:
        return np.zeros(Y.shape[1])
    if k == 1 or omegas[j - 1] == omegas[j - 2]:
        return Y[j - 1].copy()
    w1, w2 = omegas[j - 1], omegas[j - 2]
    if k == 2 or omegas[j - 3] == w1 or omegas[j - 3] == w2:
        return Y[j - 1] + (Y[j - 1] - Y[j - 2]) * ((w - w1) / (w1 - w2))
    w3 = omegas[j - 3]
    l1 = (w - w2) * (w - w3) / ((w1 - w2) * (w1 - w3))
    l2 = (w - w1) * (w - w3) / ((w2 - w1) * (w2 - w3))
    l3 = (w - w1) * (w - w2) / ((w3 - w1) * (w3 - w2))
    return l1 * Y[j - 1] + l2 * Y[j - 2] + l3 * Y[j - 3]


@numba.njit(cache=True)
def _sweep(Hr_all, ylin_all, omegas, codes, P, mem, harm, phi, dphi, dft, max_periods, tol,
           scale, max_iter, sens_el, sens_slot, Y0, use_Y0):
    """Points in the given order, each from the extrapolation of the previous ones (or from
    the guesses ``Y0``); optional parameter sensitivities dG/dθ."""
    nf, m = ylin_all.shape
    nb = 2 * harm.shape[0]
    ns = sens_el.shape[0]
    Y = np.zeros((nf, m))
    G = np.zeros((nf, m))
    dGp = np.zeros((nf, m, ns))
    ok = np.zeros(nf, dtype=np.bool_)
    iters = np.zeros(nf, dtype=np.int64)
    for j in range(nf):
        y0 = Y0[j].copy() if use_Y0 else _predict(Y, ok, omegas, j)
        # full Newton steps first, then damped ones from the same start
        y, conv, it, Gv, dGb, J = _newton(y0, ylin_all[j], Hr_all[j], codes, P, mem,
                                          omegas[j], harm, phi, dphi, dft, max_periods, tol,
                                          scale, min(max_iter, 16), 1.0)
        if not conv:
            y, conv, it2, Gv, dGb, J = _newton(y0, ylin_all[j], Hr_all[j], codes, P, mem,
                                               omegas[j], harm, phi, dphi, dft, max_periods,
                                               tol, scale, max_iter, _MIN_ALPHA)
            it += it2
        if not conv and j == 0 and not use_Y0:
            y, conv, it2, Gv, dGb, J = _ramp(ylin_all[j], Hr_all[j], codes, P, mem, omegas[j],
                                             harm, phi, dphi, dft, max_periods, tol, scale,
                                             max_iter)
            it += it2
        # a sweep past a fold jumps to another branch: try scaled and phase-shifted copies
        # of the last converged point
        base = ylin_all[j].copy()
        for i in range(j - 1, -1, -1):
            if ok[i]:
                base = Y[i].copy()
                break
        for factor in (1.0, 2.0, 0.5, 4.0):
            for phase in (0.0, -0.5 * np.pi, 0.5 * np.pi, -0.25 * np.pi, 0.25 * np.pi):
                if conv:
                    break
                y, conv, it2, Gv, dGb, J = _newton(_rotate(base, harm, factor, phase),
                                                   ylin_all[j], Hr_all[j], codes, P, mem,
                                                   omegas[j], harm, phi, dphi, dft,
                                                   max_periods, tol, scale,
                                                   min(max_iter, 20), _MIN_ALPHA)
                it += it2
        if not conv:
            y, conv, it2, Gv, dGb, J = _ramp(ylin_all[j], Hr_all[j], codes, P, mem, omegas[j],
                                             harm, phi, dphi, dft, max_periods, tol, scale,
                                             max_iter)
            it += it2
        Y[j] = y
        G[j] = Gv
        ok[j] = conv
        iters[j] = it
        if ns:
            dth = np.zeros((m, ns))  # explicit dG/dθ, by perturbing each parameter
            G0 = np.empty(m)         # G at y itself (Gv is its first-order update)
            Gq = np.empty(nb)
            none = np.empty((0, 0))
            for e in range(codes.shape[0]):
                periodic_forces(codes[e], P[e], mem[e], y[e * nb:(e + 1) * nb], omegas[j],
                                phi, dphi, dft, harm, max_periods, tol,
                                G0[e * nb:(e + 1) * nb], none)
            for q in range(ns):
                e = sens_el[q]
                pq = P[e].copy()
                h = 1e-7 * max(abs(pq[sens_slot[q]]), 1e-12)
                pq[sens_slot[q]] += h
                periodic_forces(codes[e], pq, mem[e], y[e * nb:(e + 1) * nb], omegas[j], phi,
                                dphi, dft, harm, max_periods, tol, Gq, none)
                for i in range(nb):
                    dth[e * nb + i, q] = (Gq[i] - G0[e * nb + i]) / h
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
    return model.receptance()


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
        Residual and Jacobian evaluations (AFT periods with derivatives) per point.
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
        AFT samples per period (default: power of two >= 16 x the highest order, at least
        32: 128 for orders up to 7).
    tol : float
        Relative Newton and periodicity tolerance.
    max_iter : int
        Newton evaluations per attempt at a point.
    max_periods : int
        Periods run at most for a memory element to become periodic.
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
        self.n_time = int(n_time or max(32, 1 << int(np.ceil(np.log2(_OVERSAMPLE * hmax)))))
        if self.n_time < 2 * hmax + 2:
            raise HBMError(f"n_time {self.n_time} is too small for harmonic {hmax}; use at "
                           f"least {2 * hmax + 2}")
        self.receptance = receptance or model_receptance(model)
        self.tol, self.max_iter, self.max_periods = tol, max_iter, max_periods
        self._tables = aft_tables(self.harmonics, self.n_time)
        els = model.elements
        self.W = np.array([el.w for el in els]).T.reshape(model.n_dof, len(els))
        self.B = np.zeros((model.n_dof, self.force_dofs.size))
        self.B[self.force_dofs, np.arange(self.force_dofs.size)] = 1.0
        self.n_el = len(els)
        self.codes = np.array([KINDS[el.kind].code for el in els], dtype=np.int64)
        self.memory = np.array([KINDS[el.kind].memory for el in els], dtype=np.bool_)
        self._i1 = int(np.flatnonzero(self.harmonics == 1)[0])   # the fundamental's index
        self._complete = all(el.known for el in els)
        self._blocks = self._block_index()
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
        i1 = self._i1
        ulin[:, i1] = np.einsum("dm,fde,fe->fm", self.W, H[:, i1], force @ self.B.T)
        nb = 2 * nh
        m = nb * n_el
        # [[Re, -Im], [Im, Re]] blocks of every element pair, placed in one assignment
        Hr = np.zeros((freqs.size, m * m))
        re, im = Hc.real.reshape(freqs.size, -1), Hc.imag.reshape(freqs.size, -1)
        Hr[:, self._blocks] = np.concatenate([re, -im, im, re], axis=1)
        ylin = np.concatenate([ulin.real, ulin.imag], axis=1).transpose(0, 2, 1)
        return H, Hr.reshape(freqs.size, m, m), ylin.reshape(freqs.size, m).copy()

    def _block_index(self) -> np.ndarray:
        """Flat indices into the (m, m) real operator of ``[[Re, -Im], [Im, Re]]`` of each
        element pair's receptance, in the order of `_linear`'s blocks, each over
        (harmonic, element a, element b)."""
        nh, ne = self.harmonics.size, self.n_el
        nb = 2 * nh
        h, a, b = (x.ravel() for x in np.meshgrid(np.arange(nh), np.arange(ne), np.arange(ne),
                                                  indexing="ij"))
        return np.concatenate([((a * nb + h + r) * ne + b) * nb + h + c
                               for r, c in ((0, 0), (0, nh), (nh, 0), (nh, nh))])

    def _check(self, freqs, force, params):
        # array methods rather than np.any/np.all/np.broadcast_to: a continuation checks
        # one point per call, thousands of times (same checks, less Python)
        freqs = np.atleast_1d(np.asarray(freqs, dtype=float))
        if freqs.ndim != 1 or freqs.size == 0 or not np.isfinite(freqs).all() \
                or (freqs <= 0).any():
            raise HBMError("frequencies must be a non-empty list of positive numbers (Hz)")
        force = np.atleast_1d(np.asarray(force, dtype=float))
        n_in = self.force_dofs.size
        if force.shape not in ((n_in,), (freqs.size, n_in)) or not np.isfinite(force).all():
            raise HBMError(f"force amplitude needs {n_in} finite value(s) (one per force DOF) "
                           f"or one such row per frequency, got shape {force.shape}")
        force = force[None, :] if force.ndim == 1 and freqs.size == 1 else \
            np.broadcast_to(force, (freqs.size, n_in))
        P = self.params if params is None else np.asarray(params, dtype=float)
        if params is None and not self._complete:
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
            *self._tables, self.max_periods, self.tol, scale, self.max_iter,
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
        r, J, Gv = self._at(y, freq, ylin[0], Hr[0], P, jac)
        return H[0], force[0], ylin[0], r, J, Gv

    def _at(self, y, freq, ylin, Hr, P, jac):
        """Residual, Jacobian dr/dy (None unless ``jac``) and element forces at one point."""
        nb = 2 * self.harmonics.size
        Gv, dGb = np.zeros(nb * self.n_el), np.zeros((self.n_el, nb, nb) if jac else
                                                     (self.n_el, 0, 0))
        r = _evaluate(np.asarray(y, dtype=float), ylin, Hr, self.codes, P, self.memory,
                      2 * np.pi * freq, self.harmonics, *self._tables, self.max_periods,
                      self.tol, Gv, dGb)
        return r, _jacobian(Hr, dGb) if jac else None, Gv

    def linear_state(self, freq: float, force: Sequence[float] | float) -> np.ndarray:
        """Condensed state of the underlying linear response (no element forces)."""
        return self._point(np.zeros(2 * self.harmonics.size * self.n_el), freq, force,
                           False)[2]

    def residual(self, y: np.ndarray, freq: float, force: Sequence[float] | float,
                 jac: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Condensed residual and its Jacobian dr/dy at ``(y, freq)``."""
        return self._point(y, freq, force, jac)[3:5]

    def residual_and_slope(self, y: np.ndarray, freq: float, force: Sequence[float] | float,
                           rel_step: float = 1e-7
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Condensed residual, its Jacobian dr/dy and its frequency derivative dr/df at
        ``(y, freq)``; dr/df by a forward difference of step ``rel_step * freq`` (the linear
        operators of both frequencies built in one call)."""
        df = rel_step * freq
        freqs, force, P = self._check([freq, freq + df], force, None)
        _, Hr, ylin = self._linear(freqs, force)
        r, J, _ = self._at(y, freq, ylin[0], Hr[0], P, True)
        r2, _, _ = self._at(y, freq + df, ylin[1], Hr[1], P, False)
        return r, J, (r2 - r) / df

    def response(self, y: np.ndarray, freq: float, force: Sequence[float] | float
                 ) -> np.ndarray:
        """Displacement coefficients X (n_h, n_dof) of the condensed state ``y``."""
        return self.responses(np.asarray(y)[None], [freq], force)[0]

    def responses(self, Y: np.ndarray, freqs: Sequence[float],
                  force: Sequence[float] | float) -> np.ndarray:
        """Displacement coefficients X (n, n_h, n_dof) of condensed states ``Y`` (n, m) at
        ``freqs`` (n,), one force for all."""
        freqs, force, P = self._check(freqs, force, None)
        H, Hr, ylin = self._linear(freqs, force)
        Gv = np.array([self._at(y, f, yl, hr, P, False)[2]
                       for y, f, yl, hr in zip(Y, freqs, ylin, Hr)])
        G = _to_complex(Gv.reshape(freqs.size, -1), self.n_el, self.harmonics.size)
        x = np.einsum("fhde,fe->fhd", H, force @ self.B.T) * (self.harmonics == 1)[:, None]
        return x - np.einsum("fhde,em,fhm->fhd", H, self.W, G)


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
