"""Frequency-response curves by pseudo-arclength continuation of the harmonic balance.

Natural continuation (step the frequency, reuse the last solution) jumps at a fold, as a
stepped-sine test does; arc-length continuation follows the curve around the fold through the
unstable branch. Each step predicts along the unit tangent of ``R(y, ω) = 0`` and corrects with
Newton's method on ``R = 0`` plus the arc-length constraint (Keller's pseudo-arclength), in
scaled variables (``y`` by the linear response amplitude, frequency by the start frequency).

Stability: along a forced-response curve without secondary (Neimark–Sacker) bifurcations, the
periodic solution changes stability exactly at the folds, where the determinant of the balance
Jacobian ``dR/dy`` changes sign; a point is marked stable when that sign equals the sign at the
start of the curve, which must lie on a stable branch (e.g. far below resonance).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Sequence

import numpy as np
from scipy.linalg.lapack import dgetrf, dgetrs

from ..errors import EstimationError
from ._hbm import HBMError, HBMSystem


@dataclass
class Branch:
    """A continued response curve.

    Attributes
    ----------
    freqs : ndarray, shape (n,)
        Frequency at each point (not monotonic across folds), Hz.
    X : ndarray, complex, shape (n, n_h, n_dof)
        Displacement harmonics.
    stable : ndarray of bool, shape (n,)
    folds : ndarray of int
        Indices where stability changes (turning points).
    fold_freqs : ndarray, shape (len(folds),)
        Frequency of each fold between its two points, Hz: the turning point of the cubic
        Hermite interpolation of the frequency along the arc with the continuation's
        tangents (error ~ step^4; the point ``freqs[folds]`` is off by ~ step^2). Empty when
        not traced by continuation.
    """

    freqs: np.ndarray
    X: np.ndarray
    stable: np.ndarray
    folds: np.ndarray
    fold_freqs: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def amplitude(self, dof: int, harmonic_index: int = 0) -> np.ndarray:
        """Amplitude ``|X_k|`` of one DOF along the branch."""
        return np.abs(self.X[:, harmonic_index, dof])


#: points of a linear model's curve (no element: nothing to continue, no fold)
LINEAR_POINTS = 2001


def _linear_branch(system: HBMSystem, f_start: float, f_end: float,
                   force: np.ndarray) -> Branch:
    """The curve of a model without elements: its receptance times the force, stable."""
    freqs = np.linspace(f_start, f_end, LINEAR_POINTS)
    H = system.model.linear_frf(freqs, list(system.force_dofs))        # (n, n_dof, n_in)
    X = np.zeros((freqs.size, system.harmonics.size, system.model.n_dof), complex)
    X[:, int(np.flatnonzero(system.harmonics == 1)[0])] = H @ force
    return Branch(freqs, X, np.ones(freqs.size, bool), np.zeros(0, int))


def continue_frf(system: HBMSystem, f_start: float, f_end: float, force: float | np.ndarray,
                 *, step: float = 0.02, min_step: float = 1e-5, max_step: float = 0.1,
                 max_points: int = 2000, tol: float = 1e-9, max_iter: int = 12) -> Branch:
    """Trace the response curve from ``f_start`` to ``f_end`` by arc-length continuation.

    Parameters
    ----------
    system : HBMSystem
        Prepared balance (all element parameters known).
    f_start, f_end : float
        Sweep range, Hz (either direction).
    force : float or ndarray, shape (n_in,)
        Force amplitudes.
    step : float
        Initial arc-length step in scaled units (relative amplitude and frequency).
    min_step, max_step : float
        Step-size limits; the step adapts to the corrector's iteration count.
    """
    if f_start <= 0 or f_end <= 0 or f_start == f_end:
        raise HBMError("continuation needs two different positive frequencies")
    force = np.atleast_1d(np.asarray(force, dtype=float))
    if system.n_el == 0:
        return _linear_branch(system, f_start, f_end, force)
    first = system.sweep([f_start], force)
    if not first.converged[0]:
        raise EstimationError(f"no periodic solution found at the start {f_start} Hz")
    y = np.concatenate([first.U[0].real.T, first.U[0].imag.T], axis=1).ravel()
    ylin = system.linear_state(f_start, force)
    ys = max(float(np.abs(ylin).max()), 1e-300)     # amplitude scale
    ws = f_start                                      # frequency scale
    direction = np.sign(f_end - f_start)

    def aug(z):
        """Residual, its Jacobian in y and its frequency derivative in scaled variables
        z = (y / ys, f / ws)."""
        r, J, dr_df = system.residual_and_slope(z[:-1] * ys, z[-1] * ws, force)
        return r / ys, J, dr_df * ws / ys

    z = np.append(y / ys, f_start / ws)
    r, J, dr_df = aug(z)
    A = np.column_stack([J, dr_df])
    tangent = _tangent(A, None, direction)
    points, signs, tangents = [z.copy()], [_det_sign(J)], [tangent]
    h = step
    while len(points) < max_points:
        zp = z + h * tangent
        zc, ok, iters, last = _correct(aug, zp, tangent, tol, max_iter)
        if not ok:
            h *= 0.5
            if h < min_step:
                break
            continue
        # the tangent and the stability sign from the corrector's last iterate, whose
        # distance to zc is below the tolerance (no separate evaluation at zc)
        zl, r, J, dr_df, lu = last
        tangent = _tangent(np.column_stack([J, dr_df]), tangent, None, lu)
        z = zc
        points.append(z.copy())
        signs.append(_det_sign(J))
        tangents.append(tangent)
        h = min(max_step, h * (1.5 if iters <= 3 else 0.7 if iters >= 6 else 1.0))
        if (z[-1] * ws - f_end) * direction >= 0:
            break
    Z = np.array(points)
    freqs = Z[:, -1] * ws
    X = system.responses(Z[:, :-1] * ys, freqs, force)
    signs = np.array(signs)
    stable = signs == signs[0]
    folds = np.flatnonzero(np.diff(stable.astype(int)) != 0) + 1
    turns = np.array([_turning_frequency(Z[i - 1:i + 1], np.array(tangents[i - 1:i + 1]))
                      for i in folds]) * ws
    return Branch(freqs, X, stable, folds, turns.reshape(-1))


def _turning_frequency(z: np.ndarray, t: np.ndarray) -> float:
    """Frequency (last coordinate) where it turns between two points ``z`` (2, m) with unit
    tangents ``t`` (2, m): the extremum of its cubic Hermite interpolation over the chord
    (hand-written: a quadratic's root); the nearer point's frequency when it does not turn."""
    chord = math.sqrt(float((z[1] - z[0]) @ (z[1] - z[0])))
    p0, p1, m0, m1 = z[0, -1], z[1, -1], chord * t[0, -1], chord * t[1, -1]
    a, b, c = 6 * (p0 - p1) + 3 * (m0 + m1), 6 * (p1 - p0) - 4 * m0 - 2 * m1, m0
    roots = np.roots([a, b, c]) if abs(a) + abs(b) > 0 else np.zeros(0)
    sigma = [r.real for r in roots if abs(r.imag) < 1e-12 and 0.0 <= r.real <= 1.0]
    if m0 * m1 >= 0 or not sigma:
        return float(z[int(abs(m1) < abs(m0)), -1])
    u = sigma[0]
    h = (2 * u ** 3 - 3 * u ** 2 + 1, u ** 3 - 2 * u ** 2 + u, -2 * u ** 3 + 3 * u ** 2,
         u ** 3 - u ** 2)
    return float(h[0] * p0 + h[1] * m0 + h[2] * p1 + h[3] * m1)


def _tangent(A: np.ndarray, previous: np.ndarray | None, direction: float | None,
             lu: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Unit null vector of the augmented Jacobian, oriented along ``previous`` (or so that
    the frequency moves in ``direction``).

    Along the curve, the solution of ``[A; previous] t = e_last`` (the bordered system) is
    that null vector scaled, oriented along ``previous``: that matrix is the corrector's
    last one, so its LU ``lu`` (`_factor`) is reused; the first point, or a bordered system
    that is singular, takes it from the SVD."""
    if previous is not None and lu is not None:
        rhs = np.zeros(A.shape[1])
        rhs[-1] = 1.0
        t = dgetrs(*lu, rhs)[0]
        t = t / math.sqrt(t @ t)
        return t if t @ previous >= 0 else -t
    t = np.linalg.svd(A)[2][-1]
    if previous is not None:
        return t if t @ previous >= 0 else -t
    return t if np.sign(t[-1]) == direction or t[-1] == 0 else -t


# LAPACK's getrf/getrs called directly: `np.linalg.solve` and `det` spend most of their
# time on type checks for these 7 x 7 systems (one per corrector iteration and point).
def _factor(K: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """LU factors of ``K`` (LAPACK getrf), None when it is singular."""
    lu, piv, info = dgetrf(K)
    return (lu, piv) if info == 0 else None


def _det_sign(J: np.ndarray) -> float:
    """Sign of ``det(J)`` from its LU factors (0 when singular)."""
    lu, piv, info = dgetrf(J)
    if info != 0:
        return 0.0
    swaps = np.count_nonzero(piv != np.arange(piv.size))
    return float((-1) ** swaps * np.prod(np.sign(np.diagonal(lu))))


def _correct(aug, zp: np.ndarray, t: np.ndarray, tol: float, max_iter: int):
    """Newton on ``R(z) = 0`` and ``t.(z - zp) = 0``. Returns the point, whether it
    converged, the iterations and the last evaluated iterate ``(z, r, dr/dy, dr/df)`` with
    the LU factors of its bordered Jacobian (`_factor`)."""
    z = zp.copy()
    K = np.empty((z.size, z.size))      # the bordered Jacobian, filled in place
    K[-1] = t
    F = np.empty(z.size)
    for it in range(1, max_iter + 1):
        r, J, dr_df = aug(z)
        F[:-1] = r
        F[-1] = t @ (z - zp)
        K[:-1, :-1] = J
        K[:-1, -1] = dr_df
        lu = _factor(K)
        if lu is None:
            return z, False, it, None
        dz = dgetrs(*lu, -F)[0]
        last = (z, r, J, dr_df, lu)
        z = z + dz
        if math.sqrt(dz @ dz) <= tol * max(1.0, math.sqrt(z @ z)):
            return z, True, it, last
    return z, False, max_iter, None


def response_curves(system: HBMSystem, f_start: float, f_end: float,
                    amplitudes: Sequence[float], **options) -> list[Branch]:
    """Forced-response curves at several force amplitudes through their folds.

    Parameters
    ----------
    system : HBMSystem
        Prepared balance with one force input (all element parameters known).
    f_start, f_end : float
        Sweep range, Hz; start where the response is on a stable branch (off resonance).
    amplitudes : sequence of float
        Force amplitudes, N, one curve each.
    **options
        Passed to `continue_frf` (step sizes, point budget, tolerance).

    Returns
    -------
    list of Branch
        One branch per amplitude, in the given order.
    """
    if system.force_dofs.size != 1:
        raise HBMError("response curves take one force input; give a single force DOF")
    values = np.asarray(amplitudes, dtype=float)
    if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)) \
            or np.any(values <= 0):
        raise HBMError("force amplitudes must be positive numbers (N)")
    return [continue_frf(system, f_start, f_end, a, **options) for a in values]
