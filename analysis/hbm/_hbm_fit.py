"""Element parameters from stepped-sine FRFs at several levels (paper eq 33, section 4.2).

The cost is the paper's ``||H_measured - H_analytic||_2`` over every step of every level, with
``H_analytic`` the fundamental receptance of the harmonic-balance solution (`analysis.hbm._hbm`) swept
in the measured step order (so folds are crossed as the measurement crossed them). Positive
parameters are fitted as logarithms. The default optimiser is `scipy.optimize.least_squares`
(trust-region reflective, bounds, Jacobian from the implicit-function sensitivities of the
harmonic balance) from several starting points; Nelder–Mead (the paper's ``fminsearch``) is
available for comparison. Uncertainty: linearised covariance ``s^2 (J^T J)^-1``.

The underlying linear system comes from the model or from a measured FRF (`MeasuredReceptance`,
interpolated in the measured band, extrapolated by a fitted ``K + jωC - ω^2 M`` outside).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy.interpolate import make_interp_spline
from scipy.optimize import least_squares, minimize
from scipy.stats import f as f_dist
from scipy.stats import qmc

from ..errors import EstimationError, InputError
from ._hbm import HBMSystem, Receptance
from ..models import Model, Refs, lookup
from ..spectral import SETTLE_TOL, SteppedSineFRF

_WIDTH = 1.5            # default multi-start spread: decades either side of the nominal start
_BOUND = 4.0            # default bounds: decades either side of the nominal start
_WARM = 0.05            # relative parameter change below which sweeps start from the last one
DELAY_ALPHA = 1e-3
"""Significance of the F test that keeps a delay between force and responses (one
parameter more), as fit-linear's (`analysis.modal`)."""
DELAY_PHASE = np.deg2rad(1.0)
"""Smallest phase (rad) a kept delay turns at the highest step: below, a noise-free fit's
model error (harmonic truncation) reads as a delay the F test passes."""
DELAY_PASSES = 4
MAX_ORDER = 15
"""Highest harmonic order `fit_hbm` adds by itself (`_enough_orders`)."""
TRUNCATION_SHARE = 0.1
"""Shift of a parameter, in its standard errors, that the next harmonic order may cause
before it is added (`_enough_orders`): a truncation bias at or above a tenth of the
interval's half-width is taken out, a smaller one left (it moves coverage by < 1 %)."""


class MeasuredReceptance:
    """Underlying linear receptance from a measured FRF (paper section 4.2).

    Inside the measured band the impedance ``Z = H^-1`` is interpolated (cubic spline; it is
    smooth where the FRF peaks); outside it — the higher harmonics reach up to ``h_max``
    times the band — ``K + jωC - ω^2 M`` fitted to the measured impedance by least squares
    is used.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
    frf : ndarray, complex, shape (n_f,) or (n_f, n_dof, n_dof)
        Receptance; a full square matrix for more than one DOF.
    """

    def __init__(self, freqs: np.ndarray, frf: np.ndarray) -> None:
        freqs = np.asarray(freqs, dtype=float)
        frf = np.asarray(frf, dtype=complex)
        if frf.ndim == 1:
            frf = frf[:, None, None]
        if frf.ndim != 3 or frf.shape[1] != frf.shape[2] or frf.shape[0] != freqs.size:
            raise InputError("a measured underlying FRF must be square (one column per DOF, "
                             f"n_f x n_dof x n_dof), got shape {frf.shape}; measure every DOF "
                             "or take the linear system from the model")
        if freqs.size < 4 or np.any(np.diff(freqs) <= 0):
            raise InputError("the measured underlying FRF needs at least 4 increasing "
                             "frequencies")
        self.band = (float(freqs[0]), float(freqs[-1]))
        w = 2 * np.pi * freqs
        Z = np.linalg.inv(frf).reshape(freqs.size, -1)
        # the impedance is smooth (quadratic in ω for M, C, K) where the FRF has sharp peaks
        self._spline = make_interp_spline(freqs, Z, k=3)
        # Z = K + jωC - ω^2 M: real part in (1, -ω^2), imaginary part in ω.
        kr, *_ = np.linalg.lstsq(np.column_stack([np.ones_like(w), -w ** 2]), Z.real,
                                 rcond=None)
        ci, *_ = np.linalg.lstsq(w[:, None], Z.imag, rcond=None)
        n = frf.shape[1]
        self.stiffness, self.mass = kr[0].reshape(n, n), kr[1].reshape(n, n)
        self.damping = ci[0].reshape(n, n)

    def __call__(self, freqs: np.ndarray) -> np.ndarray:
        freqs = np.asarray(freqs, dtype=float)
        n = self.mass.shape[0]
        w = 2 * np.pi * freqs[:, None, None]
        Z = self.stiffness + 1j * w * self.damping - w ** 2 * self.mass
        inside = (freqs >= self.band[0]) & (freqs <= self.band[1])
        if inside.any():
            Z[inside] = self._spline(freqs[inside]).reshape(-1, n, n)
        return np.linalg.inv(Z)


@dataclass
class FitResult:
    """Outcome of `fit_hbm`.

    ``params`` and ``ci95`` are per unknown ``(element, name)``; ``starts`` lists every start
    with its end point and cost (the multi-start record).
    """

    model: Model
    params: dict[tuple[int, str], float]
    ci95: dict[tuple[int, str], tuple[float, float]]
    cost: float
    method: str
    starts: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    n_evaluations: int = 0
    harmonics: tuple[int, ...] = ()
    """Orders of the balance fitted (those asked for plus any `fit_hbm` added)."""


class HBMFit:
    """Cost (paper eq 33) and its Jacobian for the unknown parameters of a candidate model.

    Parameters
    ----------
    model : Model
        Candidate: elements with omitted parameters are estimated, the rest held fixed.
    levels : sequence of SteppedSineFRF
        Measured levels (one force input each, the same force DOF for all).
    harmonics : sequence of int
    receptance : callable, optional
        Underlying linear receptance; the model's linear part by default.
    dofs : sequence of int, optional
        Response DOFs compared in the cost (default: the force DOF).
    """

    def __init__(self, model: Model, levels: Sequence[SteppedSineFRF],
                 harmonics: Sequence[int] = (1, 3, 5, 7), *,
                 receptance: Receptance | None = None, dofs: Sequence[int] | None = None,
                 n_time: int | None = None) -> None:
        if not levels:
            raise InputError("no stepped-sine levels given; pass at least one run")
        self.levels = list(levels)
        force_dof = {lv.force_dof for lv in self.levels}
        if len(force_dof) != 1:
            raise InputError(f"levels are driven at different DOFs {sorted(force_dof)}; fit "
                             "runs with the same drive point together")
        self.force_dof = force_dof.pop()
        self.dofs = [self.force_dof] if dofs is None else [int(d) for d in dofs]
        self.model = model
        self.system = HBMSystem(model, [self.force_dof], harmonics, receptance=receptance,
                                n_time=n_time)
        self.n_time = n_time
        """The balance's time samples as given (None: its default for the orders)."""
        self.receptance = receptance
        """The underlying linear receptance as given (None: the model's)."""
        self.unknowns = [(e, name) for e, el in enumerate(model.elements)
                         for name in el.missing]
        if not self.unknowns:
            raise InputError("the candidate model has no unknown parameter; omit the ones to "
                             "estimate from its [[element]] tables")
        self.specs = [lookup(model.elements[e].kind).param(name) for e, name in self.unknowns]
        self.slots = [(e, lookup(model.elements[e].kind).all_params.index(name))
                      for e, name in self.unknowns]
        self.log = np.array([spec.positive for spec in self.specs])
        self.scale = self._nominal()
        self.n_evaluations = 0
        self.unconverged = 0
        self._last: tuple[np.ndarray, list[np.ndarray]] | None = None
        self.log_cost = False
        self.delay = 0.0
        """Seconds the responses lag the force, taken out of the measured FRFs
        (`_take_out_delay`)."""

    def extended(self, order: int) -> HBMFit:
        """The same fit with harmonic ``order`` added (above the present ones), its delay and
        counts carried over, each step's balance started from this fit's last solutions with
        the new order at zero: a sweep started afresh can land on the other branch of a fold
        (the campaign example's 8 N level: cubic +8.6 %)."""
        top = max(int(order), int(self.system.harmonics.max()) + 1)
        more = HBMFit(self.model, self.levels, [*self.system.harmonics.tolist(), top],
                      receptance=self.receptance, dofs=self.dofs,
                      n_time=self.n_time if (self.n_time or 0) >= 2 * top + 2 else None)
        more.delay = self.delay
        more.n_evaluations, more.unconverged = self.n_evaluations, self.unconverged
        if self._last is not None:
            more._last = (self._last[0], [np.concatenate(
                [U, np.zeros((U.shape[0], 1, U.shape[2]), dtype=U.dtype)], axis=1)
                for U in self._last[1]])
        return more

    # --- parametrisation -----------------------------------------------------------------
    def _nominal(self) -> np.ndarray:
        """Physical scale of each unknown from the data and the linear system."""
        k_ref, c_ref = _linear_scales(self.model)
        f_ref = max(float(lv.force.max()) for lv in self.levels)
        u_ref = max(float(np.abs(lv.X[:, :, self.force_dof]).max()) for lv in self.levels)
        if not (f_ref > 0 and u_ref > 0):
            raise InputError("the measured force or the response at the force DOF is zero "
                             "at every step: nothing to fit; check the channels")
        v_ref = u_ref * 2 * np.pi * float(np.median(self.levels[0].freqs))
        refs = Refs(k_ref, f_ref, u_ref, c_ref, v_ref)
        return np.array([spec.scale(refs) for spec in self.specs])

    def to_params(self, z: np.ndarray) -> np.ndarray:
        """Optimiser variables -> physical parameter values."""
        return np.where(self.log, self.scale * np.exp(z), self.scale * z)

    def to_z(self, p: np.ndarray) -> np.ndarray:
        """Physical parameter values -> optimiser variables."""
        p = np.asarray(p, dtype=float)
        return np.where(self.log, np.log(np.abs(p) / self.scale), p / self.scale)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the optimiser variables.

        Returns
        -------
        lo, hi : ndarray
            Log-scaled variables within ``10**±_BOUND`` of their scale, linear ones within
            ±10 scales (either: within their parameter's ``bounds`` when it has them).
        """
        lo = np.where(self.log, -_BOUND * np.log(10), -10.0)
        hi = np.where(self.log, _BOUND * np.log(10), 10.0)
        for i, spec in enumerate(self.specs):
            if spec.bounds is not None and self.log[i]:
                lo[i], hi[i] = np.log(np.array(spec.bounds) / self.scale[i])
            elif spec.bounds is not None:
                lo[i], hi[i] = np.array(spec.bounds) / self.scale[i]
        return lo, hi

    def _packed(self, p: np.ndarray) -> np.ndarray:
        P = self.system.params.copy()
        for (e, slot), value in zip(self.slots, p):
            P[e, slot] = value
        return P

    # --- cost -------------------------------------------------------------------------------
    def analytic(self, p: np.ndarray, jac: bool = False):
        """Analytic receptances per level (n_f, n_dofs) and, if ``jac``, dH/dp."""
        P = self._packed(p)
        # Warm start every step from the last solution when the parameters moved little
        # (an optimiser's successive points); otherwise sweep afresh, as the test did.
        near = self._last is not None and np.all(
            np.abs(p - self._last[0]) <= _WARM * np.abs(self._last[0]))
        out, dout, solutions = [], [], []
        for i, lv in enumerate(self.levels):
            force = lv.force[:, None]
            res = self.system.sweep(lv.freqs, force, params=P,
                                    sensitivities=self.slots if jac else (),
                                    guess=self._last[1][i] if near else None)
            solutions.append(res.U)
            self.unconverged += int((~res.converged).sum())
            if not np.all(np.isfinite(res.X)):
                raise EstimationError(f"harmonic balance diverged at level {lv.level:g} for "
                                      f"parameters {p.tolist()}")
            out.append(res.X[:, self._i1, self.dofs] / lv.force[:, None])
            if jac:
                Hk = self.system.receptance(lv.freqs)          # fundamental receptance
                dX = -np.einsum("fde,em,fmq->fdq", Hk, self.system.W, res.dG[:, self._i1])
                dout.append(dX[:, self.dofs] / lv.force[:, None, None])
        self.n_evaluations += 1
        self._last = (np.array(p, dtype=float), solutions)
        return out, dout

    @property
    def _i1(self) -> int:
        return int(np.flatnonzero(self.system.harmonics == 1)[0])

    def residuals(self, z: np.ndarray) -> np.ndarray:
        """Real residual vector of eq 33 (real and imaginary parts, all levels); with
        ``log_cost`` the complex log of H_analytic / H_measured instead (log magnitude and
        phase), whose basin of attraction is much wider — used as the first stage."""
        out, _ = self.analytic(self.to_params(z))
        if self.log_cost:
            diff = np.concatenate([np.log(a / self.measured(lv)).ravel()
                                   for a, lv in zip(out, self.levels)])
        else:
            diff = np.concatenate([(a - self.measured(lv)).ravel()
                                   for a, lv in zip(out, self.levels)])
        return np.concatenate([diff.real, diff.imag])

    def measured(self, lv: SteppedSineFRF) -> np.ndarray:
        """Measured receptances of one level at the compared DOFs, the `delay` taken out."""
        return lv.frf[:, self.dofs] * np.exp(2j * np.pi * lv.freqs * self.delay)[:, None]

    def delay_column(self) -> np.ndarray:
        """Derivative of the eq 33 `residuals` with respect to `delay`."""
        d = np.concatenate([(-2j * np.pi * lv.freqs[:, None] * self.measured(lv)).ravel()
                            for lv in self.levels])
        return np.concatenate([d.real, d.imag])

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Jacobian of `residuals` with respect to the optimiser variables.

        Parameters
        ----------
        z : ndarray
            Optimiser variables.

        Returns
        -------
        ndarray
            ``(2 n_residuals, n_params)``: real parts stacked over imaginary parts.
        """
        p = self.to_params(z)
        out, dout = self.analytic(p, jac=True)
        if self.log_cost:
            dout = [d / a[..., None] for a, d in zip(out, dout)]
        d = np.concatenate([x.reshape(-1, len(p)) for x in dout])
        dpdz = np.where(self.log, p, self.scale)
        return np.concatenate([d.real, d.imag]) * dpdz

    def cost(self, z: np.ndarray) -> float:
        """Paper eq 33: 2-norm of the FRF difference over all levels."""
        return float(np.linalg.norm(self.residuals(z)))


def _starting_points(problem: HBMFit, n_starts: int, seed: int | None,
                     start: np.ndarray | None) -> np.ndarray:
    lo, hi = problem.bounds()
    centre = np.zeros(len(problem.unknowns)) if start is None else problem.to_z(start)
    if n_starts <= 1:
        return np.clip(centre, lo, hi)[None]
    width = np.where(problem.log, _WIDTH * np.log(10), 1.0)
    sample = qmc.LatinHypercube(d=centre.size, seed=seed).random(n_starts - 1)
    pts = centre + (2 * sample - 1) * width
    return np.clip(np.vstack([centre, pts]), lo + 1e-9, hi - 1e-9)


def fit_hbm(model: Model, levels: Sequence[SteppedSineFRF],
            harmonics: Sequence[int] = (1, 3, 5, 7), *, receptance: Receptance | None = None,
            method: str = "least-squares",
            n_starts: int = 4, start: dict[tuple[int, str], float] | None = None,
            starts: np.ndarray | None = None, seed: int | None = 0,
            dofs: Sequence[int] | None = None, n_time: int | None = None,
            max_order: int | None = MAX_ORDER) -> FitResult:
    """Fit the unknown element parameters of ``model`` to measured stepped-sine levels.

    Parameters
    ----------
    model : Model
        Candidate model (omitted parameters are estimated).
    levels : sequence of SteppedSineFRF
        Measured FRFs from `analysis.spectral.stepped_sine_frf`, one per level.
    harmonics : sequence of int
        Harmonic orders of the balance.
    receptance : callable, optional
        Underlying linear receptance (e.g. `MeasuredReceptance`); the model's by default.
    method : {"least-squares", "nelder-mead"}
    n_starts : int
        Multi-start count: the nominal start plus Latin-hypercube points spread
        ±1.5 decades around it (log parameters).
    start : dict, optional
        Nominal start ``{(element, name): value}``; data-derived scales by default.
    starts : ndarray, shape (n, n_unknown), optional
        Explicit physical starting points (overrides ``start`` and ``n_starts``).
    seed : int, optional
        Seed of the start sampling.
    max_order : int, optional
        Orders added to ``harmonics`` up to this one while the next would move a parameter
        (`_enough_orders`, said in the warnings); None or ``(1,)``: ``harmonics`` as given.

    Returns
    -------
    FitResult
    """
    if method not in ("least-squares", "nelder-mead"):
        raise InputError(f"optimizer '{method}' unknown; use least-squares or nelder-mead")
    problem = HBMFit(model, levels, harmonics, receptance=receptance, dofs=dofs,
                     n_time=n_time)
    lo, hi = problem.bounds()
    if starts is not None:
        z0s = np.clip(problem.to_z(np.atleast_2d(starts)), lo + 1e-9, hi - 1e-9)
    else:
        nominal = None if start is None else np.array([start[u] for u in problem.unknowns])
        z0s = _starting_points(problem, n_starts, seed, nominal)
    record, best = [], None
    for z0 in z0s:
        try:
            z, r = _optimise(problem, z0, lo, hi, method)
        except EstimationError as exc:
            record.append({"start": problem.to_params(z0).tolist(), "error": str(exc)})
            continue
        c = float(np.linalg.norm(r))
        record.append({"start": problem.to_params(z0).tolist(),
                       "end": problem.to_params(z).tolist(), "cost": c})
        if best is None or c < best[2]:
            best = (z, r, c)
    if best is None:
        raise EstimationError("no start converged; give a better start or check the model")
    said = []
    if method == "least-squares":  # polish the best start on the paper's eq 33 cost
        z, r = _polish(problem, best[0], lo, hi)
        z, r, said = _take_out_delay(problem, z, r, lo, hi)
        problem, z, r, more = _enough_orders(problem, z, r, lo, hi, max_order)
        said = said + more
        best = (z, r, float(np.linalg.norm(r)))
    z, r, c = best
    p = problem.to_params(z)
    ci, warnings = _uncertainty(problem, z, r, lo, hi)
    warnings = _unsettled(levels) + said + warnings
    elements = [type(el)(el.kind, el.w.copy(), dict(el.params)) for el in model.elements]
    for (e, name), value in zip(problem.unknowns, p):
        elements[e].params[name] = float(value)
    fitted = model.with_elements(elements)
    return FitResult(fitted, dict(zip(problem.unknowns, p.tolist())), ci, c, method, record,
                     warnings, problem.n_evaluations,
                     tuple(int(h) for h in problem.system.harmonics))


def _optimise(problem: HBMFit, z0: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              method: str) -> tuple[np.ndarray, np.ndarray]:
    if method == "least-squares":  # wide-basin log cost; `fit_hbm` polishes on eq 33
        problem.log_cost = True
        sol = least_squares(problem.residuals, z0, jac=problem.jacobian, bounds=(lo, hi),
                            method="dogbox", xtol=1e-4, ftol=1e-6, max_nfev=60)
        problem.log_cost = False
        return sol.x, problem.residuals(sol.x)
    problem.log_cost = False
    sol = minimize(lambda z: float(np.sum(problem.residuals(z) ** 2)), z0,
                   method="Nelder-Mead", bounds=list(zip(lo, hi)),
                   options={"xatol": 1e-6, "fatol": 0.0, "maxfev": 2000, "adaptive": True})
    return sol.x, problem.residuals(sol.x)


def _polish(problem: HBMFit, z: np.ndarray, lo: np.ndarray, hi: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Least squares on the paper's eq 33 cost from ``z``: the end point and its residuals."""
    problem.log_cost = False
    sol = least_squares(problem.residuals, z, jac=problem.jacobian, bounds=(lo, hi),
                        method="trf", xtol=1e-10, ftol=1e-12, gtol=1e-12, max_nfev=100)
    return sol.x, sol.fun


def _take_out_delay(problem: HBMFit, z: np.ndarray, r: np.ndarray, lo: np.ndarray,
                    hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """A delay between the force and the responses (an anti-alias filter's group delay
    differing between channels) turns the measured FRF's phase by ``w tau``, which no element
    explains: the fit bends its parameters instead (a one-sample delay at 512 Hz took the
    stepped twin's cubic to -35 %). Read off a Gauss-Newton step of the residual on the
    parameters and the delay together, the delay is kept when the F test passes at
    `DELAY_ALPHA` and it turns the phase at the highest step by more than `DELAY_PHASE`; it
    is then taken out of the measured FRFs and the fit polished again, until the step
    adds less than 1 % of it."""

    top = max(float(lv.freqs.max()) for lv in problem.levels)
    for _ in range(DELAY_PASSES):
        A = np.hstack([problem.jacobian(z), problem.delay_column()[:, None]])
        step, *_ = np.linalg.lstsq(A, -r, rcond=None)
        dof = max(r.size - A.shape[1], 1)
        rss = float(np.sum((r + A @ step) ** 2))
        big = abs(2 * np.pi * top * (problem.delay + step[-1])) > DELAY_PHASE
        if problem.delay == 0.0 and not (
                big and (float(r @ r) - rss) * dof > f_dist.isf(DELAY_ALPHA, 1, dof) * rss):
            return z, r, []
        problem.delay += float(step[-1])
        z, r = _polish(problem, z, lo, hi)
        if abs(step[-1]) < 0.01 * abs(problem.delay):
            break
    return z, r, [f"the responses lag the force by {1e3 * problem.delay:.3g} ms (the "
                  "measured FRF's phase turns with frequency as a delay between the "
                  "channels' anti-alias filters): taken out of the fit; align the channels "
                  "when importing (response_delay)"]


def _enough_orders(problem: HBMFit, z: np.ndarray, r: np.ndarray, lo: np.ndarray,
                   hi: np.ndarray, max_order: int | None
                   ) -> tuple[HBMFit, np.ndarray, np.ndarray, list[str]]:
    """Add harmonic orders while the next one matters: the balance truncated at order ``h``
    leaves out what the elements put into higher orders, which couples back into the
    fundamental (a cubic spring's orders 9 and up moved the stepped twin's cubic by +0.14 %
    with orders to 7, outside its noise-free interval). The shift the next order causes is
    read off one Gauss-Newton step on the balance with it; the order is added (and the fit
    polished) when a parameter moves by more than `TRUNCATION_SHARE` standard errors."""
    given = problem.system.harmonics
    step = 2 if np.all(given % 2 == 1) else 1
    h = given
    if given.size == 1:     # a single-harmonic (describing-function) fit is kept as asked
        max_order = None
    while max_order is not None and int(h.max()) + step <= max_order:
        sd = _standard_errors(problem, z, r)        # leaves the solutions at z to start from
        more = problem.extended(int(h.max()) + step)
        r_more = more.residuals(z)
        shift, *_ = np.linalg.lstsq(more.jacobian(z), -r_more, rcond=None)
        if np.all(np.abs(shift) <= TRUNCATION_SHARE * sd):
            break
        problem = more
        z, r = _polish(problem, z, lo, hi)
        h = problem.system.harmonics
    if h.size == given.size:
        return problem, z, r, []
    return problem, z, r, [
        f"harmonic orders {', '.join(str(int(k)) for k in h[given.size:])} added to "
        f"{', '.join(str(int(k)) for k in given)}: without them the balance's truncation "
        f"moved a parameter by more than {TRUNCATION_SHARE:g} of its standard error"]


def _standard_errors(problem: HBMFit, z: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Linearised standard errors of the optimiser variables: ``s^2 (J^T J)^-1`` (a delay
    taken out counts as one parameter more) plus what the settling rule leaves in each
    step's FRF (`_settling_variance`), through the same linearisation."""
    J = problem.jacobian(z)
    if problem.delay:
        J = np.hstack([J, problem.delay_column()[:, None]])
    dof = max(r.size - J.shape[1], 1)
    G = np.linalg.pinv(J)
    cov = float(r @ r) / dof * (G @ G.T) + (G * _settling_variance(problem)) @ G.T
    return np.sqrt(np.clip(np.diag(cov)[:z.size], 0.0, None))


def _settling_variance(problem: HBMFit) -> np.ndarray:
    """Variance per residual left by the settling rule: a step recorded in time is fitted
    from where its windows are within `analysis.spectral.SETTLE_TOL` of its last quarter's
    FRF, so the free decay of the previous step may still move it by up to that much (taken
    as uniform within the bound: variance ``SETTLE_TOL^2 |H|^2 / 3``, half in the real
    part, half in the imaginary). It is not noise: it does not shrink with the residual of a
    noise-free fit, and it biased the 2 N stepped twin's cubic by -0.20 %, outside the
    interval from the residual alone. Tables (no time record) carry none."""
    var = [np.zeros(lv.frf[:, problem.dofs].size) if lv.steady_from is None else
           (SETTLE_TOL * np.abs(problem.measured(lv))).ravel() ** 2 / 6
           for lv in problem.levels]
    v = np.concatenate(var)
    return np.concatenate([v, v])


def _unsettled(levels: Sequence[SteppedSineFRF]) -> list[str]:
    """One warning per level with steps still transient in their last quarter."""
    return [f"level {lv.level:.3g} N: the step(s) at "
            f"{', '.join(f'{f:g}' for f in lv.unsettled)} Hz have not settled by their last "
            "quarter (the free decay of the previous step still shows; that quarter is "
            "fitted, its FRF reads some of the decay): record longer steps"
            for lv in levels if lv.unsettled]


def _uncertainty(problem: HBMFit, z: np.ndarray, r: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray) -> tuple[dict, list[str]]:
    """95 % intervals from the linearised covariance (log parameters: asymmetric; a delay
    taken out counts as one parameter more)."""
    warnings = []
    sd = _standard_errors(problem, z, r)
    lo_z, hi_z = z - 1.96 * sd, z + 1.96 * sd
    a, b = problem.to_params(lo_z), problem.to_params(hi_z)
    ci = {u: (float(min(x, y)), float(max(x, y))) for u, x, y in zip(problem.unknowns, a, b)}
    for i, (e, name) in enumerate(problem.unknowns):
        if z[i] <= lo[i] + 1e-6 or z[i] >= hi[i] - 1e-6:
            side = "upper" if z[i] >= hi[i] - 1e-6 else "lower"
            note = (" (the data look like a sharp stick-slip: eq 34 tends to the Jenkins "
                    "element as n grows)" if name == "n" and side == "upper" else "")
            warnings.append(f"element {e} {name} reached its {side} bound "
                            f"{float(problem.to_params(z)[i]):.4g}{note}")
    return ci, warnings


def _linear_scales(model: Model) -> tuple[float, float]:
    """Stiffness and viscous-damping scales at the points: the largest diagonal entries of
    ``K`` and ``C`` (``[linear]`` form), or the stiffest point of the static flexibility and
    that stiffness times the modes' median ``2 ζ / ω`` (``[modal]`` form)."""
    if not model.is_modal:
        return (float(np.max(np.abs(np.diag(model.stiffness)))),
                max(float(np.max(np.abs(np.diag(model.damping)))), 1e-12))
    k_ref = float(1.0 / np.min(np.diag(model.point_flexibility())))
    ratio = np.diag(model.damping) / np.maximum(np.diag(model.stiffness), 1e-300)
    return k_ref, max(k_ref * float(np.median(ratio)), 1e-12)
