"""The hold polynomial's algebra inside a substep: evaluating it, locating where a stick-slip
joint changes branch (`_root_poly`, `_root_velocity`) and the end-state weights of a force
jump there (`jump_coeffs`). Numba functions called from the plant kernel
(`analysis.plant._plant_kernels`); notation of its module docstring."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def _poly(coef: np.ndarray, x: float) -> float:
    """``sum_i coef[i] x^i`` (Horner)."""
    out = 0.0
    for i in range(coef.shape[0] - 1, -1, -1):
        out = out * x + coef[i]
    return out


@numba.njit(cache=True)
def hermite(u0: float, v0: float, u1: float, v1: float, h: float,
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
def root_poly(coef: np.ndarray, target: float) -> float:
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
def root_velocity(u0: float, v0: float, u1: float, v1: float, h: float) -> float:
    """Time fraction where the Hermite interpolant's velocity changes sign: the root in
    [0, 1] of the quadratic ``a t^2 + b t + v0`` (`hermite`'s ``du``)."""
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
def matvec(a: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ x`` (small: no BLAS call, no allocation)."""
    for r in range(a.shape[0]):
        t = 0.0
        for c in range(a.shape[1]):
            t += a[r, c] * x[c]
        out[r] = t


@numba.njit(cache=True)
def jump_coeffs(dnodes: np.ndarray, theta: float, vinv: np.ndarray, h: float,
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
    matvec(vinv, dnodes, dmono)
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
