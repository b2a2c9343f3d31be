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
from scipy.optimize import OptimizeResult, least_squares

from ..models import KINDS, restoring_force
from ._backbone import BackbonePoint
from ._free import free_bounds, free_interval, from_free, to_free

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
        95 % intervals of the parameters (linearised in their free coordinates, `to_free`, each residual group
        scaled by its own rms: the scatter the law does not explain sets the width).
    """

    params: dict[str, float]
    frequency_rms: float
    damping_rms: float
    ci95: dict[str, tuple[float, float]]


def describing(kind: str, params: dict[str, float], amplitudes: np.ndarray,
               omega: float = 1.0) -> np.ndarray:
    """First-harmonic stiffness ``N(a)`` (complex, N/m) of an element along ``a cos(omega t)``
    (a rate-independent law, a slider's, does not depend on ``omega``)."""
    a = np.asarray(amplitudes, dtype=float)
    theta = 2 * np.pi * np.arange(N_TIME) / N_TIME
    u = (a[:, None] * np.cos(theta)[None, :])
    v = -(omega * a[:, None] * np.sin(theta)[None, :])
    reps = PERIODS if KINDS[kind].memory else 1
    g = restoring_force(kind, params, np.tile(u, reps).ravel(), np.tile(v, reps).ravel())[0]
    g1 = np.fft.rfft(g.reshape(a.size, reps * N_TIME)[:, -N_TIME:], axis=-1)[:, 1]
    return g1 * (2 / N_TIME) / a


def joint_backbone(mode: LinearMode, kind: str, params: dict[str, float],
                   amplitudes: np.ndarray, compensated: bool) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency (Hz) and damping ratio of ``mode`` with the element at each
    displacement amplitude (module docstring; a rate-dependent law at the mode's own
    frequency). A law that stiffens (a gap, a hardening spring) raises the frequency."""
    w0, A = 2 * np.pi * mode.frequency_hz, mode.modal_constant
    N = describing(kind, params, amplitudes, w0)
    kd = params[KINDS[kind].initial_stiffness] if compensated else 0.0
    wn = np.sqrt(np.maximum(w0**2 + A * (N.real - kd), 1e-12 * w0**2))
    zeta = (2 * mode.damping_ratio * w0 + A * N.imag / wn) / (2 * wn)
    return wn / (2 * np.pi), zeta


def _slider_grid(kind: str, amplitudes: np.ndarray, kd_max: float) -> list[dict[str, float]]:
    """Starts of a slider kind: stiffness from 1e-3 to 1 of ``kd_max``, slip displacement
    from 0.1 of the smallest amplitude to twice the largest, each other parameter at its
    screening value and one step of ``log 2`` either side of it in its free coordinate
    (`to_free`: 0.5 and 2 times a positive one)."""
    grid = KINDS[kind].search.grid
    stiff = KINDS[kind].initial_stiffness
    names = KINDS[kind].params
    fixed = dict(grid.fixed)
    z_fixed = to_free(kind, {n: fixed.get(n, 1.0) for n in names})
    others = [[(n, from_free(kind, z_fixed + dz * (np.array(names) == n))[n])
               for dz in (-np.log(2), 0.0, np.log(2))] for n in fixed]
    slips = np.geomspace(0.1 * amplitudes.min(), 2 * amplitudes.max(), 10)
    out = []
    for kd, d, more in product(np.geomspace(1e-3, 0.95, 8) * kd_max, slips, product(*others)):
        out.append({stiff: float(kd), grid.param: float(kd * d), **dict(more)})
    return out


def _coefficient_grid(kind: str, amplitudes: np.ndarray, kd_max: float, omega: float
                      ) -> list[dict[str, float]]:
    """Starts of a law linear in one coefficient (`Kind.coef`): the coefficient from 1e-4
    to 1 of the one whose describing stiffness reaches ``kd_max`` at the largest amplitude
    (both signs unless it must be positive or dissipate), its grid parameter (a gap's width)
    from 0.1 of the smallest amplitude (rate: times ``omega``) to twice the largest."""
    spec = KINDS[kind]
    grid = spec.search.grid
    names = spec.params
    more: list[dict[str, float]] = [{}]
    if grid is not None and grid.param in names and grid.param != spec.coef:
        span = np.geomspace(0.1 * amplitudes.min(), 2 * amplitudes.max(), 10)
        more = [{grid.param: float(x * (omega if grid.variable == "v" else 1.0))}
                for x in span]
    signed = not (spec.dissipative or spec.param(spec.coef).positive)
    out = []
    for m in more:
        unit = abs(describing(kind, {spec.coef: 1.0, **m}, np.array([amplitudes.max()]),
                              omega)[0])
        if not unit > 0:
            continue
        for c in np.geomspace(1e-4, 1.0, 9) * kd_max / unit:
            out += [{spec.coef: float(sg * c), **m} for sg in ((1, -1) if signed else (1,))]
    return out


@dataclass(frozen=True)
class _Backbone:
    """A backbone to fit: displacement amplitudes, frequencies and damping ratios of the
    levels, the reference (lowest) level and its relative standard deviations."""

    a: np.ndarray
    f: np.ndarray
    z: np.ndarray
    ref: int
    sd_ref: tuple[float, float]

    @classmethod
    def of(cls, points: list[BackbonePoint]) -> "_Backbone":
        a = np.array([p.displacement_amplitude for p in points])
        ref = int(np.argmin(a))
        p = points[ref]
        sd = (max((p.frequency_ci95[1] - p.frequency_ci95[0]) / (2 * 1.96 * p.frequency_hz),
                  1e-9),
              max((p.damping_ci95[1] - p.damping_ci95[0]) / (2 * 1.96 * p.damping_ratio), 1e-9))
        return cls(a, np.array([p.frequency_hz for p in points]),
                   np.array([p.damping_ratio for p in points]), ref, sd)


class _Problem:
    """Residuals of a kind's backbone against the measured one (module docstring)."""

    def __init__(self, bb: _Backbone, mode: LinearMode, kind: str, compensated: bool,
                 kd_max: float) -> None:
        self.bb, self.mode, self.kind, self.compensated = bb, mode, kind, compensated
        self.lo, self.hi = free_bounds(kind)
        spec = KINDS[kind]
        if spec.initial_stiffness is not None:
            k = spec.params.index(spec.initial_stiffness)
            self.hi[k] = min(self.hi[k], np.log(kd_max))
        elif spec.dissipative and not spec.param(spec.coef).positive:
            self.lo[spec.params.index(spec.coef)] = 0.0        # a loss, not a gain

    def groups(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fm, zm = joint_backbone(self.mode, self.kind, from_free(self.kind, x), self.bb.a,
                                self.compensated)
        return fm / self.bb.f - 1, zm / self.bb.z - 1

    def weighted(self, x: np.ndarray, sf: float, sz: float, rest: np.ndarray) -> np.ndarray:
        rf, rz = self.groups(x)
        r = self.bb.ref
        return np.concatenate([rf[rest] / sf, rz[rest] / sz,
                               [rf[r] / self.bb.sd_ref[0], rz[r] / self.bb.sd_ref[1]]])

    def likelihood(self, x: np.ndarray) -> float:
        """Profile log likelihood (two groups of unknown variance, the reference level by
        its own intervals; lower is better)."""
        rf, rz = self.groups(x)
        rest = np.arange(self.bb.a.size) != self.bb.ref
        r, n = self.bb.ref, rest.sum()
        return float(np.log(np.mean(rf[rest]**2) + 1e-18) + np.log(np.mean(rz[rest]**2) + 1e-18)
                     + (rf[r] / self.bb.sd_ref[0]) ** 2 / n + (rz[r] / self.bb.sd_ref[1]) ** 2 / n)

    def settle(self, x: np.ndarray, rest: np.ndarray) -> OptimizeResult:
        """Reweighted least squares from ``x`` on the levels ``rest`` (and the reference)."""
        x = np.clip(x, self.lo + 1e-9, self.hi - 1e-9)
        for _ in range(REWEIGHT):
            rf, rz = self.groups(x)
            sf, sz = (max(float(np.sqrt(np.mean(r[rest]**2))), 1e-9) for r in (rf, rz))
            sol = least_squares(self.weighted, x, args=(sf, sz, rest),
                                bounds=(self.lo, self.hi), method="trf", max_nfev=200)
            x = sol.x
        return sol


def _problem(points: list[BackbonePoint], mode: LinearMode, kind: str, compensated: bool,
             kd_max: float) -> tuple[_Problem, list[np.ndarray]]:
    """The fit problem and its starts in free coordinates."""
    bb = _Backbone.of(points)
    prob = _Problem(bb, mode, kind, compensated, kd_max)
    if KINDS[kind].initial_stiffness is not None:
        starts = _slider_grid(kind, bb.a, kd_max)
    else:
        starts = _coefficient_grid(kind, bb.a, kd_max, 2 * np.pi * mode.frequency_hz)
    return prob, [to_free(kind, p) for p in starts]


def fit_joint(points: list[BackbonePoint], mode: LinearMode, kind: str, *,
              compensated: bool, kd_max: float) -> JointFit:
    """Parameters of an element ``kind`` reproducing the backbone ``points``: a slider
    (`analysis.models.KINDS` with a stuck stiffness and a slip-displacement grid) or a law
    linear in one coefficient (softening or stiffening: a gap, a cubic spring, a damping
    law).

    Parameters
    ----------
    points : list of BackbonePoint
        Levels of one mode (held-response levels: each a single-mode fit).
    mode : LinearMode
        The linear mode the element acts on.
    kind : str
    compensated : bool
        The mode holds the element's stuck stiffness (sliders only).
    kd_max : float
        Largest stuck stiffness (the structure's static stiffness at the point, or the
        mode's own ``w0^2 / A``); for a coefficient law, the largest describing stiffness
        its starts reach.

    Returns
    -------
    JointFit
    """
    prob, starts = _problem(points, mode, kind, compensated, kd_max)
    if not starts:
        raise ValueError(f"{kind}: no start of a backbone fit (its law gives no force)")
    rest = np.arange(prob.bb.a.size) != prob.bb.ref
    sol = prob.settle(min(starts, key=prob.likelihood), rest)
    x = sol.x
    names = KINDS[kind].params
    sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(sol.jac.T @ sol.jac)), 0.0, None))
    # an interval reaching a bound ends there (its side is then not determined)
    ci = {n: free_interval(kind, n, v, 1.96 * s, a, b)
          for n, v, s, a, b in zip(names, x, sd, prob.lo, prob.hi)}
    rf, rz = prob.groups(x)
    return JointFit(from_free(kind, x), float(np.sqrt(np.mean(rf**2))),
                    float(np.sqrt(np.mean(rz**2))), ci)


def held_out(points: list[BackbonePoint], mode: LinearMode, kind: str, fit: JointFit, *,
             compensated: bool, kd_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Out-of-sample residuals of a backbone fit: every level but the reference predicted
    by ``kind`` refitted (from ``fit``) on the other levels; relative frequency and damping
    residuals, one per such level (in ``points`` order, the reference left out)."""
    prob, _ = _problem(points, mode, kind, compensated, kd_max)
    x0 = to_free(kind, fit.params)
    rf_out, rz_out = [], []
    for k in range(prob.bb.a.size):
        if k == prob.bb.ref:
            continue
        rest = (np.arange(prob.bb.a.size) != prob.bb.ref) & (np.arange(prob.bb.a.size) != k)
        x = prob.settle(x0, rest).x if rest.any() else x0
        rf, rz = prob.groups(x)
        rf_out.append(rf[k])
        rz_out.append(rz[k])
    return np.array(rf_out), np.array(rz_out)
