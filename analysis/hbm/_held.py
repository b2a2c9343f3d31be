"""Harmonic balance with a held response amplitude (response-controlled stepped sine).

The balance of `analysis.hbm._hbm` at a force ``s F0`` whose complex scale ``s`` is unknown,
with two more equations: the fundamental of one DOF equals the held amplitude ``a`` at phase
0 (a periodic state is defined up to a time shift, so its phase can be pinned; the force's
phase is solved for instead and every phase referenced to it afterwards). Unknowns
``(y, Re s, Im s)`` and equations::

    r(y, s) = y - (Re s ylin + Im s ylin_i) + Hr G(y) = 0     (ylin_i: the state of i F0)
    X_1[dof] = s x_lin - c . G_1(y) = a

(the response-controlled formulation, e.g. Karaagacli & Ozguven 2021; Scheel et al. 2020).
At a fixed amplitude the response is single-valued in frequency: the folds of a force-
controlled curve (a stiffening joint's three responses at one force) are not met, so each
step is one Newton solve from the previous step's solution, no continuation. Every step
reuses the compiled residual and Jacobian of `_hbm` (`_evaluate`, `_jacobian`).
"""

from __future__ import annotations

from typing import Sequence

import numba
import numpy as np

from ._hbm import (HBMError, HBMResult, HBMSystem, _MIN_ALPHA, _evaluate, _jacobian, _predict,
                   _rotate, _to_complex)
from .._numba_cache import guard

guard(__file__, "_hbm", "_aft", "..models._elements")


@numba.njit(cache=True)
def _newton_held(y0, f0, ylin, Hr, cx, ax, target, codes, P, mem, omega, harm, phi, dphi,
                 dft, max_periods, tol, max_iter):
    """Newton's method on the augmented balance from ``(y0, f0)`` (``f`` = Re, Im of the force
    scale) with the exact AFT Jacobian, the step halved while the scaled residual grows.
    Converged when the scaled step, or the next one estimated from the contraction of the
    last two (as in `_hbm._newton`), is below ``tol``. Returns y, f, converged, evaluations
    and G."""
    m = y0.shape[0]
    nb = 2 * harm.shape[0]
    n_el = codes.shape[0]
    ylin_i = _rotate(ylin, harm, 1.0, 0.5 * np.pi)       # the state of force i F0
    Lf = np.empty((m, 2))
    Lf[:, 0], Lf[:, 1] = ylin, ylin_i
    Af = np.array([[ax[0], -ax[1]], [ax[1], ax[0]]])     # (Re, Im) X_1[dof] of force f F0
    scale = max(np.sqrt(np.sum(ylin * ylin) * np.sum(f0 * f0)), 1e-300)
    y, f = y0.copy(), f0.copy()
    G, dGb = np.zeros(m), np.zeros((n_el, nb, nb))
    Gt, dGt = np.zeros(m), np.zeros((n_el, nb, nb))
    A = np.zeros((m + 2, m + 2))
    b = np.zeros(m + 2)
    r = _evaluate(y, Lf @ f, Hr, codes, P, mem, omega, harm, phi, dphi, dft, max_periods,
                  tol, G, dGb)
    x = Af @ f - cx @ G
    x[0] -= target
    merit = np.sqrt(np.sum(r * r)) / scale + np.sqrt(np.sum(x * x)) / target
    n_eval, last = 1, np.inf
    while n_eval < max_iter and np.isfinite(merit):
        A[:m, :m] = _jacobian(Hr, dGb)
        A[:m, m:] = -Lf
        for e in range(n_el):                            # d X_1[dof] / dy = -c . dG_1/dy
            A[m:, e * nb:(e + 1) * nb] = -cx[:, e * nb:(e + 1) * nb] @ dGb[e]
        A[m:, m:] = Af
        b[:m], b[m:] = -r, -x
        d = np.linalg.solve(A, b)
        step = np.sqrt(np.sum(d[:m] * d[:m]) / (np.sqrt(np.sum(y * y)) + scale) ** 2
                       + np.sum(d[m:] * d[m:]) / np.sum(f * f))
        theta = step / last if np.isfinite(last) else 1.0
        if step <= tol or (theta < 0.5 and theta / (1.0 - theta) * step <= tol):
            y += d[:m]
            f += d[m:]
            for e in range(n_el):
                G[e * nb:(e + 1) * nb] += dGb[e] @ d[e * nb:(e + 1) * nb]
            return y, f, True, n_eval, G
        alpha = 1.0
        while True:
            yt, ft = y + alpha * d[:m], f + alpha * d[m:]
            rt = _evaluate(yt, Lf @ ft, Hr, codes, P, mem, omega, harm, phi, dphi, dft,
                           max_periods, tol, Gt, dGt)
            n_eval += 1
            xt = Af @ ft - cx @ Gt
            xt[0] -= target
            mt = np.sqrt(np.sum(rt * rt)) / scale + np.sqrt(np.sum(xt * xt)) / target
            if mt < merit or alpha <= _MIN_ALPHA or n_eval >= max_iter:
                break
            alpha *= 0.5
        last = alpha * step
        y, f, r, x, merit = yt, ft, rt, xt, mt
        G[:] = Gt
        dGb[:] = dGt
    return y, f, False, n_eval, G


@numba.njit(cache=True)
def _held_sweep(Hr_all, ylin_all, cx_all, ax_all, target, omegas, codes, P, mem, harm, phi,
                dphi, dft, max_periods, tol, max_iter):
    """Held steps in the given order, the held response's phase fixed at 0 (the force's
    phase is solved for with its amplitude). The start of a step: the extrapolation of the
    previous steps' ``(y, f)`` per unit amplitude (`_hbm._predict`); then the last converged
    step's; then the underlying linear response at the held amplitude."""
    nf, m = ylin_all.shape
    Z = np.zeros((nf, m + 2))               # (y, f) / held amplitude
    G = np.zeros((nf, m))
    ok = np.zeros(nf, dtype=np.bool_)
    iters = np.zeros(nf, dtype=np.int64)
    for j in range(nf):
        a = target[j]
        starts = []
        z = _predict(Z, ok, omegas, j)
        if np.any(z[m:] != 0.0):
            starts.append(z * a)
        for i in range(j - 1, -1, -1):
            if ok[i]:
                starts.append(Z[i] * a)
                break
        lin = a / (ax_all[j, 0] + 1j * ax_all[j, 1])      # force scale of the linear response
        z = np.zeros(m + 2)
        z[:m] = lin.real * ylin_all[j] + lin.imag * _rotate(ylin_all[j], harm, 1.0,
                                                             0.5 * np.pi)
        z[m], z[m + 1] = lin.real, lin.imag
        starts.append(z)
        for z0 in starts:
            y, f, conv, it, Gv = _newton_held(z0[:m], z0[m:], ylin_all[j], Hr_all[j],
                                              cx_all[j], ax_all[j], a, codes, P, mem,
                                              omegas[j], harm, phi, dphi, dft, max_periods,
                                              tol, max_iter)
            iters[j] += it
            if conv:
                break
        Z[j, :m] = y / a
        Z[j, m:] = f / a
        G[j] = Gv
        ok[j] = conv
    return Z, G, ok, iters


def sweep_held(system: HBMSystem, freqs: Sequence[float], force: Sequence[float],
               dof: int, amplitude: Sequence[float]) -> tuple[HBMResult, np.ndarray]:
    """Periodic responses at ``freqs`` (solved in order) with the fundamental displacement
    amplitude of ``dof`` held at ``amplitude``, the force amplitudes found alongside.

    Parameters
    ----------
    system : HBMSystem
        A complete model prepared for harmonic balance.
    freqs : sequence of float
        Step frequencies, Hz (n_f,).
    force : sequence of float
        Force amplitudes per input (n_in,) or per step (n_f, n_in): their ratios are kept,
        their scale is solved for.
    dof : int
        The held DOF.
    amplitude : sequence of float
        Held fundamental displacement amplitude per step (n_f,), > 0.

    Returns
    -------
    HBMResult
        The responses (``converged`` per step).
    ndarray, shape (n_f, n_in)
        The force amplitudes that hold them.
    """
    freqs, force, P = system._check(freqs, force, None)
    # a writable copy: a read-only view (``broadcast_to`` of a full array) is another numba
    # type, a second compilation of `_held_sweep` (~10 CPU s) beside the one `warmup` caches
    amplitude = np.array(np.broadcast_to(np.asarray(amplitude, dtype=float), freqs.shape))
    if not 0 <= dof < system.model.n_dof or not (np.isfinite(amplitude).all()
                                                 and (amplitude > 0).all()):
        raise HBMError(f"held DOF {dof} must be in 0..{system.model.n_dof - 1} and every held "
                       "amplitude a positive number")
    H, Hr, ylin = system._linear(freqs, force)
    nh, n_el, i1 = system.harmonics.size, system.n_el, system._i1
    x_lin = np.einsum("fhde,fe->fhd", H, force @ system.B.T) * (system.harmonics == 1)[:, None]
    a = x_lin[:, i1, dof]
    if n_el == 0:
        s = amplitude / np.abs(a)
        empty = np.zeros((freqs.size, nh, 0), dtype=complex)
        return (HBMResult(freqs, system.harmonics, x_lin * s[:, None, None], empty, empty,
                          np.ones(freqs.size, bool), np.zeros(freqs.size, int)),
                force * s[:, None])
    c = H[:, i1, dof, :] @ system.W                       # (n_f, n_el): X_1[dof] = s a - c . G_1
    nb = 2 * nh
    cx = np.zeros((freqs.size, 2, nb * n_el))
    cx[:, 0, i1::nb], cx[:, 0, nh + i1::nb] = c.real, -c.imag
    cx[:, 1, i1::nb], cx[:, 1, nh + i1::nb] = c.imag, c.real
    ax = np.ascontiguousarray(np.stack([a.real, a.imag], axis=1))
    Z, Gv, ok, iters = _held_sweep(
        Hr, ylin, cx, ax, amplitude, 2 * np.pi * freqs, system.codes, P,
        system.memory, system.harmonics, *system._tables, system.max_periods, system.tol,
        system.max_iter)
    s = (Z[:, -2] + 1j * Z[:, -1]) * amplitude          # complex force scale
    G = _to_complex(Gv, n_el, nh)
    X = x_lin * s[:, None, None] - np.einsum("fhde,em,fhm->fhd", H, system.W, G)
    # phases referenced to the force's (a time shift of the periodic state)
    shift = np.exp(-1j * np.outer(np.angle(s), system.harmonics))[:, :, None]
    U = _to_complex(Z[:, :-2] * amplitude[:, None], n_el, nh) * shift
    return (HBMResult(freqs, system.harmonics, X * shift, U, G * shift, ok, iters),
            force * np.abs(s)[:, None])
