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
change that level beyond them); or, *anchored*, the linear mode itself is corrected with the
element so that the lowest level is reproduced exactly (``w0^2 = w_ref^2 - A Re N(a_ref)``,
``2 zeta0 w0 = 2 zeta_ref w_ref - A Im N(a_ref) / w_ref``): a mode fitted at a level where
the element already slips holds its share of that level (`reference_correction`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Sequence

import numpy as np
from scipy.optimize import OptimizeResult, least_squares

from ..models import KINDS, Element, memory_force_series, restoring_force
from ._backbone import BackbonePoint
from ._free import free_bounds, free_interval, from_free, to_free

N_TIME = 512
PERIODS = 3
"""Periods of ``a cos`` run through a memory element; the last one is its steady loop."""
_COS = np.cos(2 * np.pi * np.arange(N_TIME) / N_TIME)
_SIN = np.sin(2 * np.pi * np.arange(N_TIME) / N_TIME)
"""One period of the describing function's motion (`describing`), computed once."""
FREE_SPAN = 100.0
"""Logarithms of positive parameters stay within +-`FREE_SPAN` (e^+-100): a
degenerate direction (a slider that never slips) would otherwise run its slip force to an
underflow that the law divides by."""
PAIR_STARTS = 6
"""Starts of a pair's fit settled (the best of its product grid); a single kind settles one."""
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
    beside, beside_ci95 : dict or None
        The second element's parameters and intervals when a pair was fitted (``beside``).
    """

    params: dict[str, float]
    frequency_rms: float
    damping_rms: float
    ci95: dict[str, tuple[float, float]]
    beside: dict[str, float] | None = None
    beside_ci95: dict[str, tuple[float, float]] | None = None
    correction: tuple[float, float] = (0.0, 0.0)
    """Anchored fits: stiffness (N/m) and damping (N s/m) added to the linear part at the
    point (`reference_correction`); else zero."""


def describing(kind: str, params: dict[str, float], amplitudes: np.ndarray,
               omega: float = 1.0) -> np.ndarray:
    """First-harmonic stiffness ``N(a)`` (complex, N/m) of an element along ``a cos(omega t)``
    (a rate-independent law, a slider's, does not depend on ``omega``)."""
    a = np.asarray(amplitudes, dtype=float)
    u = (a[:, None] * _COS[None, :])
    v = -(omega * a[:, None] * _SIN[None, :])
    memory = KINDS[kind].memory
    reps = PERIODS if memory else 1
    u, v = np.tile(u, reps).ravel(), np.tile(v, reps).ravel()
    # a memory law from the virgin state, its state in registers: bitwise the forces of
    # `restoring_force`, 2-14x faster (the fits call this ~10^5 times per diagnosis)
    g = memory_force_series(kind, params, u, v) if memory else \
        restoring_force(kind, params, u, v)[0]
    g1 = np.fft.rfft(g.reshape(a.size, reps * N_TIME)[:, -N_TIME:], axis=-1)[:, 1]
    return g1 * (2 / N_TIME) / a


def stuck_form(elements: Sequence[Element], amplitudes: np.ndarray, omega: float
               ) -> np.ndarray:
    """Summed describing stiffness of ``elements`` at the point less their stuck stiffness
    (a mode fitted at a low level holds it), complex, one per amplitude."""
    out = np.zeros(np.size(amplitudes), dtype=complex)
    for el in elements:
        stiff = KINDS[el.kind].initial_stiffness
        kd = el.params[stiff] if stiff is not None else 0.0
        out += describing(el.kind, el.params, amplitudes, omega) - kd
    return out


def _mode_at(mode: LinearMode, N: np.ndarray, linear: tuple[np.ndarray, np.ndarray] | None
             = None) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency (Hz) and damping ratio of ``mode`` with the describing stiffness
    ``N`` (stuck form: compensated stiffness already taken out) added at its point;
    ``linear``: the mode's ``w0^2`` and ``2 zeta0 w0`` replaced (`_anchored`)."""
    w0, A = 2 * np.pi * mode.frequency_hz, mode.modal_constant
    w0sq, tzw = (w0**2, 2 * mode.damping_ratio * w0) if linear is None else linear
    wn = np.sqrt(np.maximum(w0sq + A * N.real, 1e-12 * w0**2))
    zeta = (tzw + A * N.imag / wn) / (2 * wn)
    return wn / (2 * np.pi), zeta


def _anchored(mode: LinearMode, f_ref: float, z_ref: float, N_ref: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """``w0^2`` and ``2 zeta0 w0`` of the linear mode that, with the describing stiffness
    ``N_ref`` at the reference amplitude added, gives the measured reference level
    (``f_ref`` Hz, ``z_ref``) exactly: the linear part fitted at the lowest level holds the
    elements' share there, which comes out of it (issue 24 item 1: the linear part corrected
    jointly with the elements)."""
    w, A = 2 * np.pi * f_ref, mode.modal_constant
    return w**2 - A * N_ref.real, 2 * z_ref * w - A * N_ref.imag / w


def correction_of(mode: LinearMode, linear: tuple[float, float]) -> tuple[float, float]:
    """Stiffness (N/m) and viscous damping (N s/m) at the mode's point that turn ``mode``
    into the one with ``w0^2``, ``2 zeta0 w0`` = ``linear`` (single mode: ``A dk`` moves
    ``w0^2``, ``A dc`` moves ``2 zeta0 w0``)."""
    w0, A = 2 * np.pi * mode.frequency_hz, mode.modal_constant
    return (float(linear[0] - w0**2) / A, float(linear[1] - 2 * mode.damping_ratio * w0) / A)


def joint_backbone(mode: LinearMode, kind: str, params: dict[str, float],
                   amplitudes: np.ndarray, compensated: bool,
                   others: Sequence[Element] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequency (Hz) and damping ratio of ``mode`` with the element at each
    displacement amplitude (module docstring; a rate-dependent law at the mode's own
    frequency). A law that stiffens (a gap, a hardening spring) raises the frequency.
    ``others``: further elements at the same point, in the stuck form (`stuck_form`)."""
    w0 = 2 * np.pi * mode.frequency_hz
    N = describing(kind, params, amplitudes, w0)
    if compensated:
        N = N - params[KINDS[kind].initial_stiffness]
    return _mode_at(mode, N + stuck_form(others, amplitudes, w0))


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
    """Residuals of one kind's backbone, or a pair's (``kinds``: the first one compensated
    when ``compensated``), beside ``fixed`` elements at the point, against the measured one
    (module docstring); ``anchored``: the linear mode corrected so that the reference level
    is reproduced exactly (`_anchored`)."""

    def __init__(self, bb: _Backbone, mode: LinearMode, kinds: tuple[str, ...],
                 compensated: bool, kd_max: float, fixed: Sequence[Element] = (),
                 anchored: bool = False) -> None:
        self.bb, self.mode, self.kinds, self.compensated = bb, mode, kinds, compensated
        self.anchored = anchored
        self.omega = 2 * np.pi * mode.frequency_hz
        self.base = stuck_form(fixed, bb.a, self.omega)
        self.sizes = [len(KINDS[k].params) for k in kinds]
        bounds = [self._bounds(k, kd_max) for k in kinds]
        logs = np.array([KINDS[k].param(n).positive for k in kinds for n in KINDS[k].params])
        self.lo = np.where(logs, np.maximum(np.concatenate([b[0] for b in bounds]), -FREE_SPAN),
                           np.concatenate([b[0] for b in bounds]))
        self.hi = np.where(logs, np.minimum(np.concatenate([b[1] for b in bounds]), FREE_SPAN),
                           np.concatenate([b[1] for b in bounds]))

    @staticmethod
    def _bounds(kind: str, kd_max: float) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = free_bounds(kind)
        spec = KINDS[kind]
        if spec.initial_stiffness is not None:
            k = spec.params.index(spec.initial_stiffness)
            hi[k] = min(hi[k], np.log(kd_max))
        elif spec.dissipative and not spec.param(spec.coef).positive:
            lo[spec.params.index(spec.coef)] = 0.0        # a loss, not a gain
        return lo, hi

    def split(self, x: np.ndarray) -> list[dict[str, float]]:
        """Physical parameters of each kind from the joined free coordinates ``x``."""
        cuts = np.cumsum(self.sizes)[:-1]
        return [from_free(k, z) for k, z in zip(self.kinds, np.split(x, cuts))]

    def stiffness(self, i: int, params: dict[str, float]) -> np.ndarray:
        """Describing stiffness of kind ``i`` at the levels' amplitudes (stuck form)."""
        kind = self.kinds[i]
        N = describing(kind, params, self.bb.a, self.omega)
        if i == 0 and self.compensated:
            N = N - params[KINDS[kind].initial_stiffness]
        return N

    def relative(self, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Relative frequency and damping residuals of the describing stiffness ``N`` (any
        leading shape, the levels last; ``fixed`` added)."""
        N = N + self.base
        fm, zm = _mode_at(self.mode, N, self.linear(N))
        return fm / self.bb.f - 1, zm / self.bb.z - 1

    def linear(self, N: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The anchored linear mode's ``w0^2``, ``2 zeta0 w0`` for the total describing
        stiffness ``N`` (levels last), or None when not anchored."""
        if not self.anchored:
            return None
        r = self.bb.ref
        return _anchored(self.mode, self.bb.f[r], self.bb.z[r], N[..., r:r + 1])

    def correction(self, x: np.ndarray) -> tuple[float, float]:
        """Stiffness and damping added to the linear part at the point (anchored), else 0."""
        if not self.anchored:
            return (0.0, 0.0)
        N = sum(self.stiffness(i, p) for i, p in enumerate(self.split(x))) + self.base
        lin = self.linear(N)
        return correction_of(self.mode, (float(lin[0][0]), float(lin[1][0])))

    def groups(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.relative(sum(self.stiffness(i, p) for i, p in enumerate(self.split(x))))

    def weighted(self, x: np.ndarray, sf: float, sz: float, rest: np.ndarray) -> np.ndarray:
        rf, rz = self.groups(x)
        r = self.bb.ref
        return np.concatenate([rf[rest] / sf, rz[rest] / sz,
                               [rf[r] / self.bb.sd_ref[0], rz[r] / self.bb.sd_ref[1]]])

    def likelihood(self, N: np.ndarray) -> np.ndarray:
        """Profile log likelihood of the describing stiffnesses ``N`` (levels last; two
        groups of unknown variance, the reference level by its own intervals; lower is
        better)."""
        rf, rz = self.relative(N)
        rest = np.arange(self.bb.a.size) != self.bb.ref
        r, n = self.bb.ref, rest.sum()
        return (np.log(np.mean(rf[..., rest]**2, axis=-1) + 1e-18)
                + np.log(np.mean(rz[..., rest]**2, axis=-1) + 1e-18)
                + (rf[..., r] / self.bb.sd_ref[0]) ** 2 / n
                + (rz[..., r] / self.bb.sd_ref[1]) ** 2 / n)

    def best_starts(self, starts: list[list[dict[str, float]]], n: int) -> list[np.ndarray]:
        """The ``n`` best combinations of the kinds' starts, best first (each kind's
        describing stiffness computed once per start, the combinations summed: a pair's
        grid is the product of its kinds' grids)."""
        tables = [np.array([self.stiffness(i, p) for p in st]) for i, st in enumerate(starts)]
        N = tables[0]
        for t in tables[1:]:
            N = N[..., None, :] + t.reshape((1,) * (N.ndim - 1) + t.shape)
        order = np.argsort(self.likelihood(N), axis=None, kind="stable")[:n]
        return [np.concatenate([to_free(k, st[j]) for k, st, j in zip(self.kinds, starts, idx)])
                for idx in zip(*np.unravel_index(order, N.shape[:-1]))]

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


def _starts(kind: str, bb: _Backbone, mode: LinearMode, kd_max: float
            ) -> list[dict[str, float]]:
    if KINDS[kind].initial_stiffness is not None:
        return _slider_grid(kind, bb.a, kd_max)
    return _coefficient_grid(kind, bb.a, kd_max, 2 * np.pi * mode.frequency_hz)


def fit_joint(points: list[BackbonePoint], mode: LinearMode, kind: str, *,
              compensated: bool, kd_max: float, beside: str | None = None,
              fixed: Sequence[Element] = (), anchored: bool = False) -> JointFit:
    """Parameters of an element ``kind`` reproducing the backbone ``points``: a slider
    (`analysis.models.KINDS` with a stuck stiffness and a slip-displacement grid) or a law
    linear in one coefficient (softening or stiffening: a gap, a cubic spring, a damping
    law); with ``beside``, a second such kind at the same point fitted jointly with it.

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
    beside : str, optional
        A second kind fitted with it (its starts the product of both kinds' grids).
    fixed : sequence of Element
        Elements the model already holds at the point (their parameters kept; stuck form,
        the mode holds their stuck stiffness).
    anchored : bool
        The linear mode is corrected with the elements (its frequency and damping), so that
        the lowest level is reproduced exactly: the mode was fitted where the element already
        acts (`JointFit.correction`); else the lowest level is held by its own intervals.

    Returns
    -------
    JointFit
    """
    prob, starts = _problem(points, mode, kind, compensated, kd_max, beside, fixed, anchored)
    if not all(starts):
        raise ValueError(f"{kind}: no start of a backbone fit (its law gives no force)")
    rest = np.arange(prob.bb.a.size) != prob.bb.ref
    # a pair's product grid is coarse in each kind: the best few combinations are settled
    sols = [prob.settle(x0, rest) for x0 in prob.best_starts(starts, PAIR_STARTS if beside
                                                                    else 1)]
    sol = min(sols, key=lambda o: float(prob.likelihood(
        sum(prob.stiffness(i, p) for i, p in enumerate(prob.split(o.x))))))
    x = sol.x
    names = [(k, n) for k in prob.kinds for n in KINDS[k].params]
    # columns scaled to their coordinate's size first: a coefficient (a cubic spring's
    # 1e11 N/m^3) would otherwise fall below pinv's cutoff and get a zero-width interval
    sc = np.maximum(np.abs(x), 1.0)
    js = sol.jac * sc
    sd = np.sqrt(np.clip(np.diag(np.linalg.pinv(js.T @ js)), 0.0, None)) * sc
    # an interval reaching a bound ends there (its side is then not determined)
    ci = [free_interval(k, n, v, 1.96 * s, a, b)
          for (k, n), v, s, a, b in zip(names, x, sd, prob.lo, prob.hi)]
    params = prob.split(x)
    cis = [dict(zip(KINDS[k].params, ci[o:o + m]))
           for k, o, m in zip(prob.kinds, np.cumsum([0] + prob.sizes), prob.sizes)]
    rf, rz = prob.groups(x)
    return JointFit(params[0], float(np.sqrt(np.mean(rf**2))), float(np.sqrt(np.mean(rz**2))),
                    cis[0], params[1] if beside else None, cis[1] if beside else None,
                    prob.correction(x))


def _problem(points: list[BackbonePoint], mode: LinearMode, kind: str, compensated: bool,
             kd_max: float, beside: str | None, fixed: Sequence[Element], anchored: bool
             ) -> tuple[_Problem, list[list[dict[str, float]]]]:
    """The fit problem and each kind's starts."""
    bb = _Backbone.of(points)
    kinds = (kind,) if beside is None else (kind, beside)
    prob = _Problem(bb, mode, kinds, compensated, kd_max, fixed, anchored)
    return prob, [_starts(k, bb, mode, kd_max) for k in kinds]


def held_out(points: list[BackbonePoint], mode: LinearMode, kind: str, fit: JointFit, *,
             compensated: bool, kd_max: float, beside: str | None = None,
             fixed: Sequence[Element] = (), anchored: bool = False
             ) -> tuple[np.ndarray, np.ndarray]:
    """Out-of-sample residuals of a backbone fit: every level but the reference predicted
    by ``kind`` (and ``beside``) refitted (from ``fit``) on the other levels, ``fixed`` kept;
    relative frequency and damping residuals, one per such level (in ``points`` order, the
    reference left out)."""
    prob, _ = _problem(points, mode, kind, compensated, kd_max, beside, fixed, anchored)
    x0 = to_free(kind, fit.params)
    if beside is not None:
        x0 = np.concatenate([x0, to_free(beside, fit.beside)])
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


def reference_residuals(points: list[BackbonePoint], mode: LinearMode,
                        fixed: Sequence[Element] = (), anchored: bool = False
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Relative frequency and damping residuals of ``mode`` with ``fixed`` alone at every
    level but the reference (the baseline an added element is scored against; ``anchored``
    as in `fit_joint`)."""
    bb = _Backbone.of(points)
    N = stuck_form(fixed, bb.a, 2 * np.pi * mode.frequency_hz)
    fm, zm = _mode_at(mode, N, _anchored(mode, bb.f[bb.ref], bb.z[bb.ref], N[bb.ref:bb.ref + 1])
                      if anchored else None)
    rest = np.arange(bb.a.size) != bb.ref
    return fm[rest] / bb.f[rest] - 1, zm[rest] / bb.z[rest] - 1


def reference_correction(points: list[BackbonePoint], mode: LinearMode,
                         elements: Sequence[tuple[str, dict[str, float], bool]],
                         fixed: Sequence[Element] = ()) -> tuple[float, float]:
    """Stiffness (N/m) and damping (N s/m) to add to the linear part at the point so that
    ``mode`` with ``elements`` (kind, parameters, compensated) and ``fixed`` (stuck form)
    reproduces the lowest level of ``points`` (an anchored `fit_joint`'s correction, for
    other parameters)."""
    bb = _Backbone.of(points)
    w0, a = 2 * np.pi * mode.frequency_hz, bb.a[bb.ref:bb.ref + 1]
    N = stuck_form(fixed, a, w0)
    for kind, params, compensated in elements:
        N = N + describing(kind, params, a, w0) - (
            params[KINDS[kind].initial_stiffness] if compensated else 0.0)
    lin = _anchored(mode, bb.f[bb.ref], bb.z[bb.ref], N)
    return correction_of(mode, (float(lin[0][0]), float(lin[1][0])))
