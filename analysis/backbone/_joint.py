"""A joint element fitted to a backbone (single nonlinear mode theory).

At a held amplitude ``a`` a joint acts on the mode through its first-harmonic (describing)
stiffness ``N(a) = G_1 / a`` (complex: the imaginary part is its loss). On a mode of natural
frequency ``w0``, damping ratio ``zeta0`` and receptance modal constant ``A`` at the joint's
point (``phi^2`` for a mass-normalised shape) the mode at amplitude ``a`` is (Szemplinska-
Stupnicka 1979; Krack 2015)::

    wn(a)^2 = w0^2 + A (Re N(a) - kd_c),      2 zeta(a) wn(a) = 2 zeta0 w0 + A Im N(a) / wn(a)

with ``kd_c`` the element's stuck stiffness when the linear mode already holds it (a mode
fitted at a low level: *compensated*), else 0. `fit_joint` fits the element's parameters
to the measured backbone points. Frequency and damping are two residual groups with their
own unknown scatter (maximum likelihood: each group's relative residuals weighted by their own
rms, re-estimated until it settles): levels measured at different times move in frequency
by what no joint law explains (temperature, the bolt's state), and a common weight would
let that drift decide the damping law. The lowest level is the reference the linear mode was
fitted to: its residuals are weighted by its own statistical intervals (the element may not
change that level beyond them).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np
from scipy.optimize import least_squares

from ..models import KINDS, restoring_force
from ._backbone import BackbonePoint

N_TIME = 512
PERIODS = 3
"""Periods of ``a cos`` run through a memory element; the last one is its steady loop."""
REWEIGHT = 5
"""Rounds of residual reweighting (the group weights settle within a few)."""


@dataclass(frozen=True)
class LinearMode:
    """The linear mode a joint acts on: natural frequency (Hz), damping ratio and the
    receptance modal constant at the joint's point (1/kg)."""

    frequency_hz: float
    damping_ratio: float
    modal_constant: float


@dataclass(frozen=True)
class JointFit:
    """A joint element fitted to a backbone.

    Attributes
    ----------
    params : dict
        The element's parameters.
    frequency_rms, damping_rms : float
        Relative rms residual of the natural frequencies and damping ratios over the levels.
    ci95 : dict
        95 % intervals of the parameters (linearised in their logarithms, each residual group
        scaled by its own rms: the scatter the law does not explain sets the width).
    """

    params: dict[str, float]
    frequency_rms: float
    damping_rms: float
    ci95: dict[str, tuple[float, float]]


def describing(kind: str, params: dict[str, float], amplitudes: np.ndarray) -> np.ndarray:
    """First-harmonic stiffness ``N(a)`` (complex, N/m) of an element along ``a cos(t)``."""
    a = np.asarray(amplitudes, dtype=float)
    theta = 2 * np.pi * np.arange(N_TIME) / N_TIME
    u = (a[:, None] * np.cos(theta)[None, :])
    v = -(a[:, None] * np.sin(theta)[None, :])          # rate per unit angular frequency
    reps = PERIODS if KINDS[kind].memory else 1
    g = restoring_force(kind, params, np.tile(u, reps).ravel(), np.tile(v, reps).ravel())[0]
    g1 = np.fft.rfft(g.reshape(a.size, reps * N_TIME)[:, -N_TIME:], axis=-1)[:, 1]
    return g1 * (2 / N_TIME) / a


def joint_backbone(mode: LinearMode, kind: str, params: dict[str, float],
                   amplitudes: np.ndarray, compensated: bool) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency (Hz) and damping ratio of ``mode`` with the element at each
    displacement amplitude (module docstring)."""
    N = describing(kind, params, amplitudes)
    kd = params[KINDS[kind].initial_stiffness] if compensated else 0.0
    w0, A = 2 * np.pi * mode.frequency_hz, mode.modal_constant
    wn = np.sqrt(np.maximum(w0**2 + A * (N.real - kd), 1e-12 * w0**2))
    zeta = (2 * mode.damping_ratio * w0 + A * N.imag / wn) / (2 * wn)
    return wn / (2 * np.pi), zeta


def _grid(kind: str, amplitudes: np.ndarray, kd_max: float) -> list[dict[str, float]]:
    """Starts of a slider kind: stiffness from 1e-3 to 1 of ``kd_max``, slip displacement
    from 0.1 of the smallest amplitude to twice the largest, the other parameters at 0.5,
    1 and 2 times their screening value."""
    grid = KINDS[kind].search.grid
    stiff = KINDS[kind].initial_stiffness
    fixed = dict(grid.fixed)
    others = [[(n, f * v) for f in (0.5, 1.0, 2.0)] for n, v in fixed.items()]
    slips = np.geomspace(0.1 * amplitudes.min(), 2 * amplitudes.max(), 10)
    out = []
    for kd, d, more in product(np.geomspace(1e-3, 0.95, 8) * kd_max, slips, product(*others)):
        out.append({stiff: float(kd), grid.param: float(kd * d), **dict(more)})
    return out


def fit_joint(points: list[BackbonePoint], mode: LinearMode, kind: str, *,
              compensated: bool, kd_max: float) -> JointFit:
    """Parameters of a slider ``kind`` (`analysis.models.KINDS` with a stuck stiffness and a
    slip-displacement grid) reproducing the backbone ``points``.

    Parameters
    ----------
    points : list of BackbonePoint
        Levels of one mode (held-response levels: each a single-mode fit).
    mode : LinearMode
        The linear mode the element acts on.
    kind : str
    compensated : bool
        The mode holds the element's stuck stiffness.
    kd_max : float
        Largest stuck stiffness (the structure's static stiffness at the point, or the
        mode's own ``w0^2 / A``).

    Returns
    -------
    JointFit
    """
    a = np.array([p.displacement_amplitude for p in points])
    f = np.array([p.frequency_hz for p in points])
    z = np.array([p.damping_ratio for p in points])
    names = KINDS[kind].params
    ref = int(np.argmin(a))
    sd_ref = [max((p.frequency_ci95[1] - p.frequency_ci95[0]) / (2 * 1.96 * p.frequency_hz),
                  1e-9) for p in points[ref:ref + 1]]
    sd_ref += [max((points[ref].damping_ci95[1] - points[ref].damping_ci95[0])
                   / (2 * 1.96 * points[ref].damping_ratio), 1e-9)]
    rest = np.arange(a.size) != ref

    def groups(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fm, zm = joint_backbone(mode, kind, dict(zip(names, np.exp(x))), a, compensated)
        return fm / f - 1, zm / z - 1

    def weighted(x: np.ndarray, sf: float, sz: float) -> np.ndarray:
        rf, rz = groups(x)
        return np.concatenate([rf[rest] / sf, rz[rest] / sz,
                               [rf[ref] / sd_ref[0], rz[ref] / sd_ref[1]]])

    def likelihood(x: np.ndarray) -> float:
        rf, rz = groups(x)
        return float(np.log(np.mean(rf[rest]**2) + 1e-18) + np.log(np.mean(rz[rest]**2) + 1e-18)
                     + (rf[ref] / sd_ref[0]) ** 2 / rest.sum()
                     + (rz[ref] / sd_ref[1]) ** 2 / rest.sum())

    starts = [np.log([p[n] for n in names]) for p in _grid(kind, a, kd_max)]
    x = min(starts, key=likelihood)
    hi = np.full(x.size, np.inf)
    hi[names.index(KINDS[kind].initial_stiffness)] = np.log(kd_max)
    lo = np.full(x.size, -np.inf)
    for i, n in enumerate(names):
        b = KINDS[kind].param(n).bounds
        if b is not None:
            lo[i], hi[i] = np.log(b[0]), min(hi[i], np.log(b[1]))
    x = np.clip(x, lo + 1e-9, hi - 1e-9)
    for _ in range(REWEIGHT):
        rf, rz = groups(x)
        sf, sz = (max(float(np.sqrt(np.mean(r[rest]**2))), 1e-9) for r in (rf, rz))
        sol = least_squares(weighted, x, args=(sf, sz), bounds=(lo, hi), method="trf",
                            max_nfev=200)
        x = sol.x
    sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(sol.jac.T @ sol.jac)), 0.0, None))
    # an interval reaching a bound ends there (its side is then not determined)
    ci = {n: (float(np.exp(max(v - 1.96 * s, a, -700.0))),
              float(np.exp(min(v + 1.96 * s, b, 700.0))))
          for n, v, s, a, b in zip(names, x, sd, lo, hi)}
    rf, rz = groups(x)
    return JointFit({n: float(v) for n, v in zip(names, np.exp(x))},
                    float(np.sqrt(np.mean(rf**2))), float(np.sqrt(np.mean(rz**2))), ci)
