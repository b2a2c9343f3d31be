"""Memory kinds (sliders) on stepped-sine levels: slip-displacement grid, continuous fit and
harmonic-balance refit.

A slider's force at a fixed slip displacement ``d = fd / kd`` is ``kd J(u; d)``: linear in
``kd``. Along the measured motion the level FRF of the candidate model is linear in ``kd``
too (`transfer`), so every ``d`` of a log grid spanning the measured deformation amplitudes
(`slip_grid`) gets its ``kd`` in closed form and the best grid point is the start; the
misfit of a slider over ``(kd, fd)`` is narrow and curved (the resonance moves by many
half-power bandwidths between the levels), and starts tied to the linear stiffness alone
land in far minima. From there the parameters are fitted continuously on the same
measured-motion residual (`refine`), and finally by harmonic balance at each step's own force
(`hbm_refit`: the model is simulated, not fed the measured motion). A *compensated*
candidate (its stuck stiffness taken from the linear part, as a model fitted at a low level
holds it) is fitted the same way: its transfer carries the element's force less ``kd u``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np
from scipy.optimize import least_squares

from ..backbone import (BackbonePoint, LinearMode, backbone, fit_joint, fit_single_mode,
                        free_bounds, free_interval, from_free, held_out, reference_correction,
                        reference_residuals, to_free)
from ..errors import EstimationError, ModelError
from ..hbm import HBMError, HBMSystem
from ..models import KINDS, Candidate, Element, Model, restoring_force
from ..recordings import Control, StepTable
from ..spectral import SteppedSineFRF
from ._compare import LevelFRF, chi2, stuck_linear
from ._select import MARGIN, Fit, corrected_model

HARMONICS = (1, 3, 5, 7)
N_TIME = 256
PERIODS_MEMORY = 3
SLIP_GRID = 16
"""Slip displacements tried (the best one starts a continuous fit), log-spaced from `SLIP_SPAN` [0] times the smallest fundamental
deformation amplitude of the fitting levels to [1] times the largest (a slider that slips
at every level down to one that sticks at all but the top one)."""
SLIP_SPAN = (0.05, 1.2)
LOG_REACH = 3.0
"""Continuous fits stay within ``exp(LOG_REACH)`` of their start (a factor 20)."""


def transfer(frf: SteppedSineFRF, kind: str, params: dict[str, float], w: np.ndarray,
             compensated: bool = False) -> np.ndarray:
    """``G_1 / F_1`` of every step, shape (n_steps, 1): the fundamental of the element force
    along the steady periodic motion (memory kinds: the last of `PERIODS_MEMORY` periods);
    ``compensated``: less the stuck stiffness times the deformation."""
    n_s, h = frf.freqs.size, np.asarray(frf.harmonics)
    Uh = frf.X @ w                                                        # (n_s, n_h)
    spec = np.zeros((2, n_s, N_TIME // 2 + 1), dtype=complex)
    spec[0][:, h] = Uh * (N_TIME / 2)
    spec[1][:, h] = 1j * h * 2 * np.pi * frf.freqs[:, None] * Uh * (N_TIME / 2)
    # FFTs, not small matrix products: BLAS threads stall on a busy machine.
    u, v = np.fft.irfft(spec, N_TIME, axis=-1)                            # (n_s, N) each
    # All steps in one call of the force law (per-call overhead dominates otherwise); a
    # memory element carries its state into the next step and settles there in two periods.
    reps = PERIODS_MEMORY if KINDS[kind].memory else 1
    g = restoring_force(kind, params, np.tile(u, reps).ravel(), np.tile(v, reps).ravel())[0]
    g1 = np.fft.rfft(g.reshape(n_s, reps * N_TIME)[:, -N_TIME:], axis=-1)[:, 1] * (2 / N_TIME)
    if compensated:
        g1 = g1 - params[KINDS[kind].initial_stiffness] * Uh[:, list(h).index(1)]
    return (g1 / frf.force)[:, None]


def slip_grid(frfs: list[SteppedSineFRF], w: np.ndarray) -> list[float]:
    """Slip displacements screened for a slider along ``w`` (`SLIP_GRID`, `SLIP_SPAN`)."""
    amps = [np.abs(f.X[:, list(f.harmonics).index(1)] @ w) for f in frfs]
    lo, hi = min(float(a.min()) for a in amps), max(float(a.max()) for a in amps)
    if not lo > 0:
        lo = hi * 1e-3
    return np.geomspace(SLIP_SPAN[0] * lo, SLIP_SPAN[1] * hi, SLIP_GRID).tolist()


def _params(c: Candidate, z: np.ndarray) -> dict[str, float]:
    """Physical parameters of ``c`` from free coordinates (`analysis.backbone.from_free`:
    logarithms of the positive ones, logits of the bounded signed ones)."""
    return from_free(c.kind, z)


def _start(fit: Fit) -> np.ndarray:
    return to_free(fit.cand.kind, fit.params)


def stuck_limit(model: Model, c: Candidate) -> float:
    """Largest stuck stiffness a compensated candidate may take from the linear part:
    `MARGIN` of the static stiffness at its location, ``1 / (w^T K^-1 w)`` (more leaves the
    stiffness indefinite); infinite for other candidates or a free structure."""
    if not c.compensated:
        return np.inf
    try:
        flex = float((c.w @ model.linear_frf(np.zeros(1))[0] @ c.w).real)
    except np.linalg.LinAlgError:
        return np.inf
    return MARGIN / flex if flex > 0 else np.inf


def _bounds(c: Candidate, z0: np.ndarray, kd_max: float = np.inf
            ) -> tuple[np.ndarray, np.ndarray]:
    """Free-coordinate bounds: `LOG_REACH` around the start, within the kind's own parameter
    bounds and a compensated stuck stiffness below ``kd_max``."""
    flo, fhi = free_bounds(c.kind)
    lo, hi = np.maximum(z0 - LOG_REACH, flo), np.minimum(z0 + LOG_REACH, fhi)
    names = KINDS[c.kind].params
    k = names.index(KINDS[c.kind].initial_stiffness)
    hi[k] = min(hi[k], np.log(kd_max))
    return lo, np.maximum(hi, lo + 1e-6)


def _inside(z0: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.clip(z0, lo + 1e-9, hi - 1e-9)


def refine(fit: Fit, levels: list[LevelFRF], frfs: list[SteppedSineFRF],
           H_lins: list[np.ndarray], H0s: list[np.ndarray], kd_max: float = np.inf
           ) -> tuple[dict[str, float], float]:
    """Every parameter of a screened slider fitted continuously on the measured-motion
    residual (`transfer`), from its best grid point; returns the parameters and their
    ``chi2``."""
    c = fit.cand

    def resid(z: np.ndarray) -> np.ndarray:
        params = _params(c, z)
        out = []
        for lf, hl, h0, frf in zip(levels, H_lins, H0s, frfs):
            d = (hl @ c.w)[:, :, None] * transfer(frf, c.kind, params, c.w,
                                                  c.compensated)[:, None, :]
            r = (lf.H - h0 + d) / np.sqrt(lf.var / 2)
            out += [r.real.ravel(), r.imag.ravel()]
        return np.concatenate(out)

    lo, hi = _bounds(c, _start(fit), kd_max)
    sol = least_squares(resid, _inside(_start(fit), lo, hi), bounds=(lo, hi), method="trf",
                        x_scale=1.0, max_nfev=60)
    params = _params(c, sol.x)
    return params, motion_chi2(c, params, levels, frfs, H_lins, H0s)


def motion_chi2(c: Candidate, params: dict[str, float], levels: list[LevelFRF],
                frfs: list[SteppedSineFRF], H_lins: list[np.ndarray], H0s: list[np.ndarray]
                ) -> float:
    """``chi2`` of the levels with ``c`` at ``params`` along the measured motion."""
    return float(sum(chi2(lf, h0 - (hl @ c.w)[:, :, None]
                          * transfer(frf, c.kind, params, c.w, c.compensated)[:, None, :])
                     for lf, hl, h0, frf in zip(levels, H_lins, H0s, frfs)))


BACKBONE_ESTIMATOR = "backbone fit (single nonlinear mode)"


def backbone_applies(tables: list, c: Candidate) -> bool:
    """A nonlinear element (a slider, or a law linear in one coefficient) can be fitted to
    the backbone of response-controlled table levels when it acts from the held point
    (driven there) to ground."""
    if c.linear or not all(isinstance(t, StepTable) and t.control == Control.RESPONSE
                           for t in tables):
        return False
    spec = KINDS[c.kind]
    fits = (spec.search.grid is not None and spec.initial_stiffness is not None
            ) or spec.coef is not None
    dof = tables[0].control_dof
    return (len(c.dofs) == 1 and c.dofs[0] == dof and fits
            and all(t.control_dof == dof and list(t.force_dofs) == [dof] for t in tables))


def held_elements(model: Model, dof: int) -> list[Element] | None:
    """The model's elements when every one acts from DOF ``dof`` to ground (unit
    deformation there: what a backbone fit can hold beside a new element); None otherwise."""
    unit = np.eye(model.n_dof)[dof]
    if all(np.array_equal(el.w, unit) for el in model.elements):
        return list(model.elements)
    return None


@dataclass(frozen=True)
class HeldMode:
    """The model's own mode at the held point (the stuck linear part,
    `.compare.stuck_linear`), the measured backbone of the levels and the elements the model
    holds there (stuck form)."""

    mode: LinearMode
    points: list[BackbonePoint]
    fixed: list[Element]

    def correction(self, elements: list[tuple[str, dict[str, float], bool]]
                   ) -> tuple[float, float]:
        """Stiffness (N/m) and damping (N s/m) to add to the linear part at the point so
        that the mode with ``elements`` (kind, parameters, compensated) beside the fixed
        ones reproduces the lowest level (`analysis.backbone.reference_correction`)."""
        return reference_correction(self.points, self.mode, elements, self.fixed)


def held_mode(model: Model, tables: list[StepTable]) -> HeldMode | None:
    """`HeldMode` of response-controlled ``tables``; None when the model holds elements
    away from the held point or its mode there cannot be found."""
    dof = tables[0].control_dof
    fixed = held_elements(model, dof)
    if fixed is None:
        return None
    freqs = np.unique(np.concatenate([t.freqs for t in tables]))
    try:
        mf = fit_single_mode(freqs, stuck_linear(model).linear_frf(freqs)[:, dof, dof], 0)
        points = list(backbone(tables, dof).points)
    except (EstimationError, ValueError):
        return None
    return HeldMode(LinearMode(mf.frequency_hz, mf.damping_ratio,
                               float(mf.modal_constant.real)), points, fixed)


def correction_fits(fit: Fit, correction: tuple[float, float]) -> list[Fit]:
    """The linear part's correction at ``fit``'s location (`HeldMode.correction`) as the
    stiffness and damping errors that carry it into a model (`._select.corrected_model`),
    with ``fit``'s evidence; no interval: it is no free parameter, it follows from the
    elements and the lowest level."""
    c = fit.cand
    ev = dict(fit.evidence, estimator=f"linear part corrected with {c.kind} at the lowest level")
    return [Fit(Candidate(kind, c.dofs, c.n_dof, names=c.names), {name: float(v)}, {},
                0.0, 0.0, ev)
            for kind, name, v in (("stiffness_error", "delta_stiffness", correction[0]),
                                  ("damping_error", "delta_damping", correction[1]))]


class BackboneEvidence(TypedDict, total=False):
    """What a backbone estimate adds to its fit's evidence (`BackboneEstimate.evidence`),
    in this order; the keys of the diagnosis JSON's ``evidence`` of such a fit."""

    frequency_rms: float
    damping_rms: float
    backbone_oos_gain: float
    frequency_rms_oos: float
    damping_rms_oos: float
    linear_correction: dict[str, float]
    beside_kind: str
    beside_params: dict[str, float]
    beside_ci95: dict[str, list[float]]


@dataclass(frozen=True)
class BackboneScore:
    """Out-of-sample backbone score of an element (`backbone_gain`).

    Attributes
    ----------
    gain : float
        Log-likelihood gain over the reference mode, held out.
    frequency_rms, damping_rms : float
        Relative rms of the held-out frequency and damping residuals.
    """

    gain: float
    frequency_rms: float
    damping_rms: float


@dataclass(frozen=True)
class BackboneEstimate:
    """An element fitted to the backbone (`backbone_estimate`).

    Attributes
    ----------
    params : dict
        The element's parameters.
    ci95 : dict
        Their 95 % intervals, ``[lo, hi]``.
    frequency_rms, damping_rms : float
        Relative rms residuals of the fit.
    score : BackboneScore
        Its out-of-sample backbone score.
    correction : tuple of float or None
        Stiffness and damping correction of the linear part (an ``anchored`` fit).
    beside_kind : str or None
        Kind of a pair's second element fitted jointly, with its ``beside_params`` and
        ``beside_ci95``.
    """

    params: dict[str, float]
    ci95: dict[str, list[float]]
    frequency_rms: float
    damping_rms: float
    score: BackboneScore
    correction: tuple[float, float] | None = None
    beside_kind: str | None = None
    beside_params: dict[str, float] = field(default_factory=dict)
    beside_ci95: dict[str, list[float]] = field(default_factory=dict)

    @property
    def anchored(self) -> bool:
        """Whether the linear part was corrected with the element (`correction`)."""
        return self.correction is not None

    def evidence(self) -> BackboneEvidence:
        """The estimate as its fit's evidence (`BackboneEvidence`)."""
        ev = BackboneEvidence(frequency_rms=self.frequency_rms, damping_rms=self.damping_rms,
                              backbone_oos_gain=self.score.gain,
                              frequency_rms_oos=self.score.frequency_rms,
                              damping_rms_oos=self.score.damping_rms)
        if self.correction is not None:
            ev["linear_correction"] = dict(zip(("delta_stiffness", "delta_damping"),
                                               self.correction))
        if self.beside_kind is not None:
            ev.update(beside_kind=self.beside_kind, beside_params=dict(self.beside_params),
                      beside_ci95={n: list(v) for n, v in self.beside_ci95.items()})
        return ev


def backbone_estimate(model: Model, c: Candidate, tables: list[StepTable],
                      beside: Candidate | None = None, anchored: bool = False
                      ) -> BackboneEstimate | None:
    """An element fitted to the backbone of response-controlled levels
    (`analysis.backbone.fit_joint`) on the model's own mode at the held point (the stuck
    linear part, `.compare.stuck_linear`, with the elements the model holds there kept
    beside it); with ``beside``, a second element at the point fitted jointly. None when
    that mode cannot be found or the model holds elements elsewhere. Returns the
    parameters, their 95 % intervals, the fit's relative rms residuals and its
    out-of-sample backbone score (`backbone_gain`), with a pair's partner and its
    parameters.

    A response-controlled level is one quasi-linear mode at its amplitude, so its natural
    frequency and damping are what a joint law must reproduce; levels measured at different
    times also drift in frequency by what no joint law explains (the Brake-Reuss beam: 0.4 Hz
    up and down), and a fit of the whole FRFs lets that drift, many half-power bandwidths
    wide, decide the damping law (docs/backbone.md).

    ``anchored``: the linear mode is corrected with the element so that the lowest level is
    reproduced exactly (`analysis.backbone.fit_joint`), the correction in the estimate
    (``correction``)."""
    held = held_mode(model, tables)
    if held is None:
        return None
    mode, points, fixed = held.mode, held.points, held.fixed
    kd_max = min(stuck_limit(model, c),
                 MARGIN * (2 * np.pi * mode.frequency_hz) ** 2 / mode.modal_constant)
    other = None if beside is None else beside.kind
    try:
        jf = fit_joint(points, mode, c.kind, compensated=c.compensated, kd_max=kd_max,
                       beside=other, fixed=fixed, anchored=anchored)
        rf, rz = held_out(points, mode, c.kind, jf, compensated=c.compensated, kd_max=kd_max,
                          beside=other, fixed=fixed, anchored=anchored)
    except ValueError:
        return None
    score = backbone_gain(reference_residuals(points, mode, fixed, anchored), rf, rz)
    return BackboneEstimate(
        jf.params, {n: list(v) for n, v in jf.ci95.items()}, jf.frequency_rms, jf.damping_rms,
        score, tuple(jf.correction) if anchored else None, other,
        dict(jf.beside) if other is not None else {},
        {n: list(v) for n, v in jf.beside_ci95.items()} if other is not None else {})


def backbone_gain(reference: tuple[np.ndarray, np.ndarray], rf: np.ndarray,
                  rz: np.ndarray) -> BackboneScore:
    """Out-of-sample backbone score of an element from its held-out relative residuals
    ``rf``, ``rz`` (`analysis.backbone.held_out`: each level but the lowest predicted by the
    element fitted to the others) against the ``reference`` ones (the linear mode's, with
    the elements the model already holds: `analysis.backbone.reference_residuals`): the
    log-likelihood gain with an unknown variance per group, ``n/2 (log(ms_f0 / ms_f) +
    log(ms_z0 / ms_z))`` (``ms`` the mean square over the ``n`` levels). Frequency and
    damping count alike: a law that only fits the damping gains in one group."""
    f0, z0 = reference

    def ms(r: np.ndarray) -> float:
        return float(np.mean(r**2)) + 1e-18
    return BackboneScore(rf.size / 2 * (np.log(ms(f0) / ms(rf)) + np.log(ms(z0) / ms(rz))),
                         float(np.sqrt(ms(rf))), float(np.sqrt(ms(rz))))


def with_candidate(model: Model, c: Candidate, params: dict[str, float],
                   beside: Element | None = None,
                   correction: tuple[float, float] | None = None) -> Model:
    """The model with ``c`` at ``params`` added (`._select.corrected_model`), ``beside``,
    the second element of a pair, with it, and the linear part's ``correction`` at ``c``'s
    location (`correction_fits`); raises `ModelError` as that does."""
    fit = Fit(c, params, {}, 0.0, 0.0)
    m = corrected_model(model, fit)
    if beside is not None:
        m = m.with_elements(m.elements + [beside])
    for f in correction_fits(fit, correction) if correction is not None else ():
        m = corrected_model(m, f)
    return m


def simulated_chi2(model: Model, c: Candidate, params: dict[str, float],
                   levels: list[LevelFRF], frfs: list[SteppedSineFRF],
                   beside: Element | None = None,
                   correction: tuple[float, float] | None = None) -> float | None:
    """``chi2`` of the levels simulated by harmonic balance with ``c`` (``beside``, the
    linear ``correction``) added; None when the candidate leaves the model's valid range or
    the balance fails."""
    try:
        m = with_candidate(model, c, params, beside, correction)
        i1 = HARMONICS.index(1)
        return float(sum(chi2(lf, (hbm_sweep(m, frf)[:, i1] / frf.force[:, None])[:, :, None])
                         for lf, frf in zip(levels, frfs)))
    except (ModelError, HBMError):
        return None


def hbm_sweep(model: Model, frf: SteppedSineFRF) -> np.ndarray:
    """Harmonics of a harmonic-balance sweep at each step's own force amplitude (a
    response-controlled level's force varies tenfold across the band, where scaling one
    solution at the mean force would be far off for a nonlinear model): shape
    (n_steps, n_h, n_dof)."""
    system = HBMSystem(model, [frf.force_dof], HARMONICS)
    return system.sweep(frf.freqs, frf.force[:, None]).X


def hbm_refit(model: Model, fit: Fit, levels: list[LevelFRF], frfs: list[SteppedSineFRF]
              ) -> tuple[Fit, list[str]]:
    """Output-error fit of a slider by harmonic balance (paper eq 33 on the fitting levels'
    fundamentals, each step at its own force), from its measured-motion estimate.

    Written here rather than through `analysis.hbm.fit_hbm` because a compensated candidate
    moves ``kd`` out of the linear part, which `fit_hbm` holds fixed. The 95 % intervals are
    the linearised ones (log parameters) with the residual variance estimated from the fit.
    """
    c, i1 = fit.cand, HARMONICS.index(1)
    bad = np.full(2 * sum(lf.H.size for lf in levels), 1e6)

    def resid(z: np.ndarray) -> np.ndarray:
        try:
            m = corrected_model(model, Fit(c, _params(c, z), {}, 0.0, 0.0))
            out = []
            for lf, frf in zip(levels, frfs):
                h = (hbm_sweep(m, frf)[:, i1] / frf.force[:, None])[:, :, None]
                r = (lf.H - h) / np.sqrt(lf.var / 2)
                out += [r.real.ravel(), r.imag.ravel()]
            return np.concatenate(out)
        except (ModelError, HBMError):
            return bad

    lo, hi = _bounds(c, _start(fit), stuck_limit(model, c))
    sol = least_squares(resid, _inside(_start(fit), lo, hi), bounds=(lo, hi), method="trf",
                        x_scale=1.0, max_nfev=40)
    params = _params(c, sol.x)
    dof = max(sol.fun.size - sol.x.size, 1)
    cov = float(sol.fun @ sol.fun) / dof * np.linalg.pinv(sol.jac.T @ sol.jac)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    # an interval reaching a fit bound ends there (its side is then not determined)
    ci = {n: list(free_interval(c.kind, n, z, 1.96 * s, a, b))
          for n, z, s, a, b in zip(KINDS[c.kind].params, sol.x, sd, lo, hi)}
    warnings = [f"{c.kind} {n} reached its fit bound {params[n]:.4g}"
                for n, z, a, b in zip(KINDS[c.kind].params, sol.x, lo, hi)
                if z <= a + 1e-6 or z >= b - 1e-6]
    ev = dict(fit.evidence, estimator="harmonic-balance fit",
              hbm_cost=float(np.linalg.norm(sol.fun)),
              measured_motion_estimate={k: float(v) for k, v in fit.params.items()})
    return Fit(c, params, ci, fit.chi2, fit.delta_bic, ev), warnings
