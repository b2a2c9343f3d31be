"""Out-of-sample score of a candidate: the one selection principle of the diagnosis.

A candidate is judged on data it was not fitted to, and against the uncertainty of that
judgement:

* **gain** (positive evidence): the lines of every fitting level are split into two halves
  (alternating runs of `RUN` lines); each half-level is predicted by the candidate fitted on
  all the other data, and the gain is the drop of its variance-weighted misfit (``chi2``,
  i.e. relative to that level's noise and precision floor) against the current model, summed
  over the half-levels. An effect seen at one level only is still confirmed out of sample
  this way;
* **levels** (no harm): each fitting level is predicted by the candidate fitted on the other
  fitting levels alone (its nuisance parameters, below, at their estimate on all levels: one
  strongly nonlinear level cannot separate a linear correction from the candidate). A
  parameter that the other levels leave indistinguishable from zero makes no claim there
  (predicts no change);
* **uncertainty**: the standard deviation of a gain is that of ``2 Re <e, m>`` under the
  left-out data's noise (``e`` its misfit, ``m`` the predicted change): ``sqrt(8 |m|^2 /
  bin_factor)`` in ``chi2`` units; a candidate's parameter must be distinguishable from zero
  (its 95 % interval on all fitting levels excludes zero).

A candidate *wins* when its parameter is distinguishable from zero, its gain exceeds `Z` of
its deviations and the misfit it leaves out of sample beyond what an exact model shows
(`Score.left`: model-form error, systematic across lines, which the noise deviation does not
cover), and no left-out level is predicted worse by more than `Z` of that level's. What an
exact model shows is the noise times `reference` (`Score.ref`, at least 1): the reduced
misfit of the current model on the levels within their floor, which the caller
(`.policy.decide`) takes for the first effect only; the deviations are the noise's times its
square root. Two
candidates are tied (`tied`) when their gains differ by no more than that uncertainty. A
level's harm is judged against its own deviation times the square root of the current
model's reduced misfit there (at least ``ref``): a level the current model already misfits
(its linear part off) is not a noise-level yardstick. A nonlinear candidate is also scored
jointly with a stiffness correction at its own location (`Predictor.joint_at`,
`.select.JOINT_KINDS`), kept where the data support it (`.policy.supported`), so that a
start model's equivalent linear error does not count against it; a further candidate is
scored with the effects already accepted free (a scale of each element's force, a correction
of each linear error), its gain measured from them refitted alone (`refitted`), so that it
is not credited with their estimation error.

The fit on a fold is the weighted least-squares step from the candidate's estimate on all
fitting levels (Gauss-Newton, numerical Jacobian: exact for the kinds linear in their
coefficient); the left-out prediction is then evaluated exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ._compare import LevelFRF, chi2 as _chi2
from ._linear_update import Z95

Z = 3.72
"""One-sided normal quantile of p = 1e-4: the level of the floor and of the level-dependence
test."""
RUN = 8
"""Lines per run of the alternating half-level split (Welch bins are correlated over a few
lines: runs keep the two halves' noise nearly independent)."""

Predict = Callable[[np.ndarray], list[np.ndarray]]
"""``predict(theta) -> model FRF per fitting level``."""


@dataclass(frozen=True)
class Predictor:
    """A candidate's model FRFs as a function of its free parameters.

    Attributes
    ----------
    predict : callable
        ``theta -> model FRF per fitting level``.
    theta : ndarray
        The estimate on all fitting levels (a joint stiffness correction may start at 0:
        `score` refines it).
    own : int
        How many leading entries of ``theta`` are the candidate's own parameters (the rest,
        a joint stiffness correction, are nuisance).
    scale : ndarray
        Typical size of each parameter (the numerical derivative's step is 1e-4 of it).
    positive : bool
        The own parameters are positive by nature (memory laws): a fold estimating one
        at or below zero makes no claim.
    joint_at : int, optional
        Index in ``theta`` of a stiffness correction fitted jointly (reported).
    """

    predict: Predict
    theta: np.ndarray
    own: int
    scale: np.ndarray
    positive: bool = False
    joint_at: int | None = None

    @property
    def nuisance(self) -> bool:
        """Whether parameters beyond the candidate's own are fitted with it."""
        return self.theta.size > self.own


@dataclass(frozen=True)
class Score:
    """A candidate's out-of-sample evidence (`chi2` units).

    Attributes
    ----------
    gain, sd : float
        Gain over the left-out half-levels and its standard deviation.
    level_gain, level_sd : tuple of float
        Per fitting level, the gain predicted from the other levels and its deviation
        (times the square root of the current model's reduced misfit there over ``ref``,
        when above 1).
    distinct : bool
        Every own parameter's 95 % interval on all fitting levels excludes zero.
    joint : float or None
        The stiffness correction fitted jointly on all fitting levels, if any.
    estimate, interval : tuple
        Every parameter (own, then nuisance) fitted on all fitting levels and its 95 %
        interval (``(0, 0)`` for one fixed at zero: not distinguishable from it).
    chi2 : float
        The misfit of that fit on all fitting levels.
    """

    gain: float
    sd: float
    level_gain: tuple[float, ...]
    level_sd: tuple[float, ...]
    distinct: bool
    joint: float | None = None
    estimate: tuple[float, ...] = ()
    interval: tuple[tuple[float, float], ...] = ()
    chi2: float = 0.0
    left: float = 0.0
    """The misfit left out of sample beyond what an exact model shows: the current
    model's misfit less the gain less ``ref`` times the number of effective values (zero
    when within it)."""
    ref: float = 1.0
    """The reduced misfit an exact model shows on these data (`reference`: at least 1, the
    noise alone); the gain's and every level's deviation are the noise's times its square
    root."""

    @property
    def deviation(self) -> float:
        """The gain's deviation: the noise's, scaled by the square root of ``ref``."""
        return float(self.sd * np.sqrt(self.ref))

    def level_deviation(self, i: int) -> float:
        """Fitting level ``i``'s deviation: its ``level_sd`` scaled by the square root of
        ``ref``."""
        return float(self.level_sd[i] * np.sqrt(self.ref))

    @property
    def harmed(self) -> int | None:
        """Index of the first fitting level predicted worse beyond its uncertainty."""
        for i, g in enumerate(self.level_gain):
            if g < -Z * self.level_deviation(i):
                return i
        return None

    @property
    def wins(self) -> bool:
        """Distinguishable, a gain beyond its deviation and beyond the misfit it leaves
        (model-form error), and no significant harm."""
        return (self.distinct and self.gain > Z * self.deviation and self.gain > self.left
                and self.harmed is None)

    def reason(self, labels: Sequence[str]) -> str:
        """Why the candidate does not win, from the numbers (``labels``: fitting levels)."""
        if not self.distinct:
            return "its parameter is not distinguishable from zero (95 % interval)"
        k = self.harmed
        if k is not None:
            return (f"fitted on the other levels it predicts {labels[k]} worse (misfit "
                    f"{-self.level_gain[k]:.3g} higher, uncertainty "
                    f"{self.level_deviation(k):.3g})")
        if self.gain <= Z * self.deviation:
            return (f"its out-of-sample gain {self.gain:.3g} is within {Z:g} x its "
                    f"uncertainty {self.deviation:.3g}")
        beyond = ("the noise" if self.ref <= 1.0 else
                  f"what the levels within their floor show ({self.ref:.3g} x the noise)")
        return (f"its out-of-sample gain {self.gain:.3g} is less than the misfit it leaves "
                f"beyond {beyond} {self.left:.3g} (model-form error)")

    def evidence(self) -> dict[str, float]:
        """The numbers for a candidate's evidence mapping."""
        out = {"oos_gain": float(self.gain), "oos_sd": float(self.sd)}
        if self.level_gain:
            out["oos_worst_level_z"] = float(min((g / s if s > 0 else 0.0) for g, s in
                                                 zip(self.level_gain, self.level_sd)))
        if self.joint is not None:
            out["joint_delta_stiffness"] = float(self.joint)
        if self.ref > 1.0:
            out["oos_reference"] = float(self.ref)
        return out


def halves(n: int) -> np.ndarray:
    """Half (0 or 1) of each of ``n`` lines: alternating runs of ``min(RUN, n // 4)``."""
    run = max(1, min(RUN, n // 4))
    return (np.arange(n) // run) % 2


def reference(levels: Sequence[LevelFRF], H0s: Sequence[np.ndarray],
              within: Sequence[bool]) -> float:
    """The reduced misfit an exact model shows on these data: that of the current model
    ``H0s`` on the levels ``within`` their floor (declared fitted to what the data can tell),
    at least 1 (the noise alone; also when no level is within its floor)."""
    x2 = sum(_chi2(lf, h) for lf, h, w in zip(levels, H0s, within) if w)
    n = sum(lf.n_values for lf, w in zip(levels, within) if w)
    return max(1.0, float(x2 / n)) if n else 1.0


def score(levels: Sequence[LevelFRF], H0s: Sequence[np.ndarray], pred: Predictor,
          ref: float = 1.0) -> Score:
    """Out-of-sample score of ``pred`` against the current model FRFs ``H0s`` (``ref``:
    the `reference` scale of the misfit an exact model shows)."""
    theta = np.asarray(pred.theta, dtype=float).copy()
    for _ in range(3 if pred.nuisance else 0):   # Gauss-Newton: the nuisance starts at 0
        cells = _cells(levels, pred, theta)
        A, g = sum(c[2] for c in cells), sum(c[3] for c in cells)
        n = 1 / np.sqrt(np.maximum(np.diag(A), 1e-300))   # normalised: any scale
        theta = theta + n * np.linalg.lstsq(A * n[:, None] * n[None, :], n * g,
                                            rcond=1e-12)[0]
    cells = _cells(levels, pred, theta)
    A_all, g_all = sum(c[2] for c in cells), sum(c[3] for c in cells)
    bf = float(np.mean([lf.bin_factor for lf in levels]))
    own = slice(0, pred.own)
    d_ref = np.diag(A_all)

    def predicted(lv: int, out: list, hold: int = 0) -> np.ndarray:
        """Level ``lv`` predicted by the fit without the cells ``out`` (no claim, the
        current model, when the candidate's own parameters are not identified; ``hold``:
        the nuisance stays at its estimate on all levels)."""
        t, free = _fold(theta, A_all - sum(c[2] for c in out),
                        g_all - sum(c[3] for c in out), bf, d_ref, hold)
        if (not free[own].all() and not pred.nuisance) or (pred.positive
                                                           and np.any(t[own] <= 0)):
            return H0s[lv]
        return pred.predict(t)[lv]

    gain = var = 0.0
    for lv, s, *_ in cells:
        lines = halves(levels[lv].freqs.size) == s
        g_, v_ = _gain(levels[lv], H0s[lv],
                       predicted(lv, [c for c in cells if c[:2] == (lv, s)]), lines)
        gain, var = gain + g_, var + v_
    lg, ls = [], []
    for lv, lf in enumerate(levels if len(levels) > 1 else []):
        g_, v_ = _gain(lf, H0s[lv], predicted(lv, [c for c in cells if c[0] == lv],
                                              pred.own if pred.nuisance else 0),
                       np.ones(lf.freqs.size, dtype=bool))
        lg.append(g_)
        ls.append(float(np.sqrt(v_ * max(1.0, _chi2(lf, H0s[lv]) / lf.n_values / ref))))
    free = _fold(theta, A_all, g_all, bf, d_ref)[1]
    distinct = bool(free[own].all() and (not pred.positive or np.all(theta[own] > 0)))
    se = np.sqrt(np.clip(np.diag(np.linalg.pinv(A_all, rcond=1e-14)), 0, None) * bf / 2)
    interval = tuple((float(t - Z95 * e), float(t + Z95 * e)) if f else (0.0, 0.0)
                     for t, e, f in zip(theta, se, free))
    x2 = sum(_chi2(lf, h) for lf, h in zip(levels, pred.predict(theta)))
    left = sum(_chi2(lf, h) - ref * lf.n_values for lf, h in zip(levels, H0s)) - gain
    return Score(float(gain), float(np.sqrt(var)), tuple(lg), tuple(ls), distinct,
                 None if pred.joint_at is None else float(theta[pred.joint_at]),
                 tuple(float(t) for t in theta), interval, float(x2), max(float(left), 0.0),
                 float(ref))


def refitted(levels: Sequence[LevelFRF], pred: Predictor) -> list[np.ndarray]:
    """Model FRF per fitting level with ``pred``'s own parameters at zero and its nuisance
    (the effects already accepted, free) refitted on all levels: what re-estimating those
    effects alone explains, the baseline a further candidate's gain is measured from
    (`.policy.decide`: it is not credited with their estimation error)."""
    theta = np.asarray(pred.theta, dtype=float).copy()
    theta[:pred.own] = 0.0
    nuis = slice(pred.own, theta.size)
    for _ in range(3):   # Gauss-Newton, normalised as in `score`
        cells = _cells(levels, pred, theta)
        A = sum(c[2] for c in cells)[nuis, nuis]
        g = sum(c[3] for c in cells)[nuis]
        n = 1 / np.sqrt(np.maximum(np.diag(A), 1e-300))
        theta[nuis] += n * np.linalg.lstsq(A * n[:, None] * n[None, :], n * g, rcond=1e-12)[0]
    return pred.predict(theta)


def _fold(theta: np.ndarray, A: np.ndarray, g: np.ndarray, bf: float, d_ref: np.ndarray,
          hold: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The weighted least-squares step from ``theta`` on the normal equations ``A``, ``g``
    of a fold's data, with each parameter that those data leave undetermined or not
    distinguishable from zero (95 %) fixed at zero -- the current model's value, no claim --
    and the rest refitted (the weakest dropped first); the parameters from index ``hold``
    on (when positive) stay at ``theta``. Returns the parameters and the mask of the free
    ones."""
    held = np.zeros(theta.size, dtype=bool)
    if hold:
        held[hold:] = True
    free = (np.diag(A) > 1e-10 * d_ref) & ~held
    t = np.where(held, theta, 0.0)
    while free.any():
        n = 1 / np.sqrt(np.diag(A)[free])        # normalised: parameters of any scale
        C = A[np.ix_(free, free)] * n[:, None] * n[None, :]
        zero = ~free & ~held
        rhs = g[free] + A[np.ix_(free, zero)] @ theta[zero]
        Ci = np.linalg.pinv(C, rcond=1e-10)
        t = np.where(held, theta, 0.0)
        t[free] = theta[free] + n * (Ci @ (n * rhs))
        se = n * np.sqrt(np.clip(np.diag(Ci), 0, None) * bf / 2)
        z = np.abs(t[free]) / np.maximum(se, 1e-300)
        if z.min() > Z95:
            break
        free[np.flatnonzero(free)[np.argmin(z)]] = False
    return t, free


def _cells(levels: Sequence[LevelFRF], pred: Predictor, theta: np.ndarray
           ) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
    """Per level and half: ``(level, half, A, g)``, the normal matrix and gradient of the
    weighted least-squares step from ``theta``."""
    Hs = pred.predict(theta)
    J = _jacobian(pred.predict, theta, pred.scale)
    cells = []
    for lv, (lf, h, jac) in enumerate(zip(levels, Hs, J)):
        side = halves(lf.freqs.size)
        for s in (0, 1):
            m = side == s
            w = (1.0 / lf.var[m]).ravel()
            jm = jac[:, m].reshape(theta.size, -1)
            A = (np.conj(jm) @ (jm * w).T).real
            g = (np.conj(jm) @ ((lf.H - h)[m].ravel() * w)).real
            cells.append((lv, s, A, g))
    return cells


def _gain(lf: LevelFRF, h0: np.ndarray, h: np.ndarray, lines: np.ndarray
          ) -> tuple[float, float]:
    """Misfit drop on ``lines`` of one level from ``h0`` to ``h`` and its noise variance."""
    e = (lf.H - h0)[lines]
    m = (h - h0)[lines]
    v = lf.var[lines]
    k = 2.0 / lf.bin_factor
    gain = k * float(np.sum((np.abs(e) ** 2 - np.abs(e - m) ** 2) / v))
    return gain, 4.0 * k * float(np.sum(np.abs(m) ** 2 / v))


def _jacobian(predict: Predict, theta: np.ndarray, scale: np.ndarray) -> list[np.ndarray]:
    """Central-difference derivative of each level's FRF, shape (k, *H.shape) per level."""
    out: list[np.ndarray] = []
    for j in range(theta.size):
        step = 1e-4 * float(scale[j])
        up, dn = theta.copy(), theta.copy()
        up[j] += step
        dn[j] -= step
        cols = [(a - b) / (2 * step) for a, b in zip(predict(up), predict(dn))]
        if not out:
            out = [np.zeros((theta.size,) + c.shape, dtype=complex) for c in cols]
        for lv, c in enumerate(cols):
            out[lv][j] = c
    return out


def tied(a: Score, b: Score) -> bool:
    """Whether two candidates' gains differ by no more than their uncertainty
    (`tie_threshold`)."""
    return abs(a.gain - b.gain) <= tie_threshold(a, b)


def tie_threshold(a: Score, b: Score) -> float:
    """The uncertainty of two candidates' gain difference: `Z` of the two gains' deviations
    combined, or the misfit the better of the two leaves beyond the noise (model-form
    error), whichever is larger."""
    return max(Z * float(np.hypot(a.deviation, b.deviation)), min(a.left, b.left))
