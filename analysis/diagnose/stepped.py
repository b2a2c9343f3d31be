"""Diagnosis on stepped-sine recordings: harmonic signatures, friction kinds, HBM refit.

Every step is sine-fitted (`analysis.spectral._sine_fit`, harmonics 1, 3, 5, 7). The element
deformation over one period is rebuilt from the fitted harmonics (noise-free by
construction), each candidate's restoring force is evaluated on it and its fundamental
``G_1`` gives the level FRF of the candidate model (measured-motion harmonic balance)::

    H_model = H_L (B F_1 - w G_1) / F_1

With ``T = G_1 / F_1`` this is the random-data identity, so the same `select.Search` ranks
the memoryless kinds and the linear errors; the memory kinds are fitted by nonlinear least
squares on the same residual (starts from their `analysis.models._kinds.Search`). The chosen element
is then refitted by the harmonic-balance FRF fit (`analysis.hbm.fit_hbm`, paper eq 33)
and the held-back level is compared with a harmonic-balance simulation of the corrected model.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares

from ..models import KINDS, Element, Model, restoring_force
from ..errors import EstimationError, InputError
from ..hbm import HBMSystem, fit_hbm
from ..recordings import Recording, StepTable
from ..spectral import SteppedSineFRF, stepped_sine_frf
from .candidates import Candidate, library
from .compare import LevelFRF, chi2, stuck_stiffness
from .prepare import level_name
from .engine import Flow
from .policy import BIC_MIN, MIN_REDUCTION, SearchPass, linear_only, pick_holdout
from .replay import periodic_replay
from .leakage import level_floor
from .report import LevelCurves
from .result import Evidence
from .select import Fit, Search, candidate_extras, unit_params

HARMONICS = (1, 3, 5, 7)
N_TIME = 256
PERIODS_MEMORY = 3
METRIC = ("relative first-harmonic FRF error (rms over steps and DOFs) of a harmonic-balance "
          "simulation on the held-back level")


def _noise_var(rec: Recording | StepTable, frf: SteppedSineFRF) -> np.ndarray:
    """Variance of each fundamental receptance, (n_steps, n_dof).

    Two parts: white noise from the sine-fit residual (``4 sigma^2 / n``), and a steady-state
    check: the fundamentals fitted to the two halves of the block differ when a transient
    has not died out; ``|X_a - X_b|^2 / 4`` is added for that. A table (no block) has the
    scatter of its steps about a single mode (`analysis.backbone.frf_noise`).
    """
    if isinstance(rec, StepTable):
        from ..backbone import frf_noise
        return np.broadcast_to(frf_noise(frf.freqs, frf.frf, 0), frf.frf.shape).copy()
    out = np.empty(frf.frf.shape)
    n = rec.response.shape[1]
    t = np.arange(n) / rec.fs
    half = n // 2
    for s, f in enumerate(frf.freqs):
        blk = rec.response[s]
        phase = 2 * np.pi * f * t[:, None] * np.asarray(frf.harmonics)[None, :]
        design = np.hstack([np.ones((n, 1)), np.cos(phase), np.sin(phase)])
        coef, *_ = np.linalg.lstsq(design, blk, rcond=None)
        sigma2 = np.var(blk - design @ coef, axis=0)
        x_a = np.linalg.lstsq(design[:half], blk[:half], rcond=None)[0][1]
        x_b = np.linalg.lstsq(design[half:], blk[half:], rcond=None)[0][1]
        out[s] = 4 * sigma2 / n / frf.force[s] ** 2 + (x_a - x_b) ** 2 / 4 / frf.force[s] ** 2
    return out


def _motion(frf: SteppedSineFRF, w: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Deformation and rate of ``w`` over one period of step ``s`` (from fitted harmonics)."""
    theta = 2 * np.pi * np.arange(N_TIME) / N_TIME
    h = np.asarray(frf.harmonics)
    U = frf.X[s] @ w
    e = np.exp(1j * np.outer(theta, h))
    om = 2 * np.pi * frf.freqs[s]
    return (e @ U).real, (e @ (1j * h * om * U)).real


def _transfer(frf: SteppedSineFRF, kind: str, params: dict[str, float], w: np.ndarray
              ) -> np.ndarray:
    """``G_1 / F_1`` of every step, shape (n_steps, 1): the fundamental of the element force
    along the steady periodic motion (memory kinds: the last of `PERIODS_MEMORY` periods)."""
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
    return (g1 / frf.force)[:, None]


def _level(model: Model, rec: Recording, frf: SteppedSineFRF, extra: dict, floor: float,
           label: str) -> LevelFRF:
    H = frf.frf[:, :, None]
    var = _noise_var(rec, frf)[:, :, None] + floor**2 * np.abs(H) ** 2
    B = np.zeros((model.n_dof, 1))
    B[frf.force_dof, 0] = 1.0
    # model elements in the stuck form (`.compare.stuck_linear`): less the stuck stiffness
    x1 = frf.X[:, list(frf.harmonics).index(1)]                 # fundamental, (n_s, n_dof)
    T = {("model", i): _transfer(frf, el.kind, el.params, el.w) - stuck_stiffness(el)
         * (x1 @ el.w / frf.force)[:, None] for i, el in enumerate(model.elements)}
    for c, extras in extra.items():
        for e in extras:
            T[(c, e)] = _transfer(frf, c.kind, unit_params(c.kind, e), c.w)
    return LevelFRF(label, frf.level, frf.freqs, H, np.ones(H.shape), var, B, T, 1.0)


class SteppedSearch(Search):
    """`Search` plus the memory kinds, on stepped-sine levels."""

    def __init__(self, model: Model, frfs: list[SteppedSineFRF], recs: list[Recording],
                 floor: float) -> None:
        self.frfs = frfs
        low = min(range(len(frfs)), key=lambda i: frfs[i].level)
        motion = [_motion(frfs[low], np.eye(model.n_dof)[:, d], s) for s in
                  range(frfs[low].freqs.size) for d in range(model.n_dof)]
        x = np.array([m[0] for m in motion]).reshape(-1, model.n_dof, N_TIME)
        v = np.array([m[1] for m in motion]).reshape(-1, model.n_dof, N_TIME)
        x = x.transpose(0, 2, 1).reshape(-1, model.n_dof)
        v = v.transpose(0, 2, 1).reshape(-1, model.n_dof)
        extra = candidate_extras(model, (x, v), (x, v))
        levels = [_level(model, r, f, extra, floor, level_name(r))
                  for r, f in zip(recs, frfs)]
        super().__init__(model, levels, extra)

    def memory_frfs(self, c: Candidate, params: dict[str, float]) -> list[np.ndarray]:
        return [h0 - (hl @ c.w)[:, :, None] * _transfer(frf, c.kind, params, c.w)[:, None, :]
                for hl, h0, frf in zip(self.H_lins, self.H0s, self.frfs)]

    def _chi2_memory(self, c: Candidate, params: dict[str, float]) -> float:
        total = 0.0
        for lf, hl, h0, frf in zip(self.levels, self.H_lins, self.H0s, self.frfs):
            d = (hl @ c.w)[:, :, None] * _transfer(frf, c.kind, params, c.w)[:, None, :]
            total += chi2(lf, h0 - d)
        return total

    def fit_memory(self, c: Candidate) -> Fit | None:
        """Nonlinear least squares of a memory element (log parameters, a few starts)."""
        names = KINDS[c.kind].params
        k_w = self.model.stiffness_along(c.w)
        amps = [float(np.abs(f.X[:, 0] @ c.w).max()) for f in self.frfs]
        u_amp, u_max = float(np.median(amps)), max(amps)
        best = None

        def resid(z: np.ndarray) -> np.ndarray:
            params = dict(zip(names, np.exp(z)))
            out = []
            for lf, hl, h0, frf in zip(self.levels, self.H_lins, self.H0s, self.frfs):
                d = (hl @ c.w)[:, :, None] * _transfer(frf, c.kind, params, c.w)[:, None, :]
                r = (lf.H - h0 + d) / np.sqrt(lf.var / 2)
                out += [r.real.ravel(), r.imag.ravel()]
            return np.concatenate(out)

        search = KINDS[c.kind].search
        starts = [np.log(p) for p in search.starts(k_w, u_amp)]
        # Local searches from the two most promising starts only (each costs ~40 sweeps).
        costs = [float(np.sum(resid(z) ** 2)) for z in starts]
        for i in np.argsort(costs)[:2]:
            z0 = starts[i]
            try:
                sol = least_squares(resid, z0, max_nfev=40, method="trf",
                                    bounds=(z0 - 9, z0 + 9))
            except (ValueError, FloatingPointError):
                continue
            if best is None or sol.cost < best.cost:
                best = sol
        if best is None:
            return None
        params = {n: float(v) for n, v in zip(names, np.exp(best.x))}
        if search.inactive(params, u_max):
            # The element never reaches its slip force in the data: it acts as a linear
            # spring, which the library holds as a stiffness error (one parameter fewer).
            return None
        x2 = self._chi2_memory(c, params)
        return Fit(c, params, {}, x2, self.bic_gain(x2, c.n_params),
                   {"estimator": "measured-motion harmonic balance"})

    def memory_fits(self) -> list[Fit]:
        fits = [self.fit_memory(c) for c in library(self.model.n_dof, self.model.points)
                if c.memory and not c.compensated]
        return [f for f in fits if f is not None]


def _hbm(model: Model, frf: SteppedSineFRF) -> np.ndarray:
    """Harmonics of a harmonic-balance sweep at each step's own force amplitude (as the fit,
    `analysis.hbm.fit_hbm`: a response-controlled level's force varies tenfold across the
    band, where scaling one solution at the mean force would be far off for a nonlinear
    model): shape (n_steps, n_h, n_dof)."""
    system = HBMSystem(model, [frf.force_dof], HARMONICS)
    return system.sweep(frf.freqs, frf.force[:, None]).X


def _error(frf: SteppedSineFRF, h: np.ndarray) -> float:
    return float(np.sqrt(np.sum(np.abs(frf.frf - h) ** 2) / np.sum(np.abs(frf.frf) ** 2)))


def _refit(model: Model, fit: Fit, frfs: list[SteppedSineFRF]) -> tuple[Fit, list[str]]:
    """Harmonic-balance FRF fit (paper eq 33) of the chosen nonlinear element."""
    c = fit.cand
    trial = model.with_elements(model.elements + [Element(c.kind, c.w, {})])
    names = KINDS[c.kind].params
    start = np.array([[fit.params[n] for n in names]])
    try:
        res = fit_hbm(trial, frfs, HARMONICS, starts=start,
                      dofs=list(range(model.n_dof)))
    except (InputError, EstimationError) as exc:
        return fit, [f"harmonic-balance refit failed ({exc}); kept the screening estimate"]
    e = len(model.elements)
    params = dict(fit.params)
    ci = {}
    for n in names:
        params[n] = float(res.params[(e, n)])
        ci[n] = list(res.ci95[(e, n)])
    ev = dict(fit.evidence, estimator="harmonic-balance fit", hbm_cost=res.cost)
    return Fit(c, params, ci, fit.chi2, fit.delta_bic, ev), list(res.warnings)


def _pool(model: Model, search: SteppedSearch, warnings: list[str]) -> list[Fit]:
    """Ranked fits of the whole library; a leading memory kind is refitted by HBM."""
    if linear_only(search):
        return [f for f in search.screen() if f.cand.linear]
    pool = sorted(search.screen() + search.memory_fits(), key=lambda f: -f.delta_bic)
    best = pool[0]
    reduction = (search.chi2_0 - best.chi2) / search.chi2_0
    if not (best.cand.memory and best.delta_bic > BIC_MIN and reduction > MIN_REDUCTION):
        return pool
    # Stick-slip is hysteresis with n -> infinity: the nested pair is decided by the
    # harmonic-balance fit itself (BIC with the residual variance unknown).
    rivals = [f for f in pool[:3] if f.cand.memory and f.cand.dofs == best.cand.dofs]
    refits = [_refit(model, f, search.frfs) for f in rivals]
    n_res = 2 * sum(f.frf.size for f in search.frfs)

    def hbm_bic(item: tuple[Fit, list[str]]) -> float:
        cost = item[0].evidence.get("hbm_cost")
        if cost is None:
            return np.inf
        return n_res * np.log(cost**2 / n_res) + item[0].cand.n_params * np.log(n_res)
    best, warn = min(refits, key=hbm_bic)
    warnings += warn
    for f, _ in refits:
        f.evidence["hbm_bic"] = hbm_bic((f, []))
    refitted = [f for f, _ in refits]
    return ([best] + [f for f in refitted if f is not best]
            + [f for f in pool if all(f.cand != r.cand for r in refitted)])


class SteppedFlow(Flow):
    """Stepped-sine levels in ascending order, one held back; the model's curves by
    harmonic balance, with periodic replays from the fitted harmonics."""

    metric = METRIC

    def __init__(self, model: Model, recs: Sequence[Recording], *,
                 holdout: float | str | None, floor: float) -> None:
        super().__init__()
        frfs = [stepped_sine_frf(r, HARMONICS) for r in recs]
        order = np.argsort([f.level for f in frfs])
        self.frfs, self.recs = [frfs[i] for i in order], [recs[i] for i in order]
        if len(frfs) < 2 or holdout == "segment":
            raise InputError("a stepped-sine diagnosis needs two or more levels (one is held "
                             "back); record another level")
        self.hold = pick_holdout([f.level for f in self.frfs], holdout)[0]   # one level
        self.model, self.floor = model, floor
        self.held = tuple(i == self.hold for i in range(len(self.frfs)))
        self._cache: dict[tuple[int, int], tuple[Model, np.ndarray]] = {}
        self.floors = [level_floor(_level(model, r, f, {}, floor, ""), floor)
                       for r, f in zip(self.recs, self.frfs)]

    def _hbm(self, m: Model, i: int) -> np.ndarray:
        """`_hbm` of level ``i``, cached per model (the entry keeps the model, so that its
        id is not reused by another one)."""
        hit = self._cache.get((id(m), i))
        if hit is None or hit[0] is not m:
            hit = self._cache[(id(m), i)] = (m, _hbm(m, self.frfs[i]))
        return hit[1]

    def curve(self, start: Model, fixed: Model, i: int) -> LevelCurves:
        f, i1 = self.frfs[i], list(HARMONICS).index(1)
        xb, xa = self._hbm(start, i), self._hbm(fixed, i)
        hb, ha = xb[:, i1] / f.force[:, None], xa[:, i1] / f.force[:, None]
        held = [list(HARMONICS).index(h) for h in f.harmonics]    # a table: its own orders
        return LevelCurves(level_name(self.recs[i]), f.level, self.held[i], f.freqs,
                           f.frf[:, :, None], hb[:, :, None], ha[:, :, None],
                           _error(f, hb), _error(f, ha), None,
                           periodic_replay(f.freqs, f.harmonics, f.X, xb[:, held]),
                           periodic_replay(f.freqs, f.harmonics, f.X, xa[:, held]))

    def pool(self, current: Model, memoryless: bool) -> tuple[SteppedSearch, list[Fit]]:
        search = SteppedSearch(current, [self.frfs[i] for i in self.fit_idx],
                               [self.recs[i] for i in self.fit_idx], self.floor)
        return search, _pool(current, search, self.warnings)

    def held_levels(self) -> list[LevelFRF]:
        return [_level(self.model, self.recs[self.hold], self.frfs[self.hold], {}, self.floor,
                       "held")]

    def evidence(self, first: SearchPass, common: Evidence) -> Evidence:
        return replace(common, odd_harmonic_ratio=_odd_ratio(first.search.frfs[-1]))


def _odd_ratio(frf: SteppedSineFRF) -> float:
    """Largest |X_3| / |X_1| over steps and DOFs at a level (harmonic signature)."""
    h = list(frf.harmonics)
    if 3 not in h:
        return 0.0
    x1, x3 = np.abs(frf.X[:, h.index(1)]), np.abs(frf.X[:, h.index(3)])
    return float((x3 / np.maximum(x1, 1e-300)).max())
