"""Welch leakage of the model FRF and the floor within which a level counts as explained.

A Welch H1 estimate is the true FRF smoothed by the window's power kernel (weighted by the
input spectrum, `analysis.modal.welch_smoothing`). Where the line spacing is not well below
a resonance's half-power bandwidth that smoothing flattens and widens the peak: the
measured FRF of an exact model then differs from the model's FRF by far more than the noise
(examples/campaign-sim-random.toml, level 5 N, 1.6 lines per bandwidth: 17 %). The model
is therefore compared *as the estimator sees it*. With ``K[.]`` the input-weighted kernel
smoothing, the Welch estimate of ``x = H_L (B f - sum_m w_m p_m g_m)`` is

    H1 = K[H_L B] - sum_m p_m K[H_L w_m T_m],      T_m = S_{g_m f} / S_ff,

while the model FRF (`compare.model_frf`) uses the *measured*, already smoothed, transfer
``K[T_m]``. The leakage bias added to it is therefore

    b = (K[H_L B] - H_L B) - sum_m p_m (K[H_L w_m T_m] - H_L w_m K[T_m]),

with ``H_L`` exact between the lines and ``T_m`` between the lines taken from the
equivalent linear system at that level: ``T_m ~ (a_m + j omega b_m) w_m^T H_eq``,
``H_eq = (I + H_L D)^-1 H_L B``, ``D = sum_m p_m (a_m + j omega b_m) w_m w_m^T``, the
equivalent stiffness ``a_m`` and damping ``b_m`` fitted (least squares) to the measured
``T_m`` against the model's level response ``w_m^T H``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Hashable

import numpy as np

from ..models import Model
from ._compare import FLOOR, LevelFRF

Z_FLOOR = 3.72
"""One-sided normal quantile of p = 1e-4 (the test level of the level-dependence test): a
level whose error exceeds its expected floor by this many standard deviations misfits."""


def _equivalent(lf: LevelFRF, H_model: np.ndarray, w: np.ndarray, key: Hashable
                ) -> tuple[float, float]:
    """Equivalent stiffness ``a`` and damping ``b`` with ``T ~ (a + j omega b) w^T H``."""
    y = np.einsum("i,fij->fj", w, H_model)
    jw = 2j * np.pi * lf.freqs[:, None]
    cols = [y.ravel(), (jw * y).ravel()]
    t = lf.T[key].ravel()
    a = np.stack([np.concatenate([c.real, c.imag]) for c in cols], axis=1)
    sol, *_ = np.linalg.lstsq(a, np.concatenate([t.real, t.imag]), rcond=None)
    return float(sol[0]), float(sol[1])


def leakage_bias(model: Model, lf: LevelFRF,
                 terms: list[tuple[np.ndarray, float, Hashable]]) -> np.ndarray | None:
    """Welch leakage of ``model``'s FRF at level ``lf`` (None without a Welch kernel).

    Parameters
    ----------
    model : Model
        The model compared (its underlying linear system).
    lf : LevelFRF
        The level (``lf.smoothing`` gives the kernel; ``lf.leakage`` is ignored).
    terms : list of (w, p, key)
        The model's nonlinear terms (`model_frf`).

    Returns
    -------
    ndarray, complex, shape like ``lf.H``, or None
    """
    if lf.smoothing is None:
        return None
    saved, lf.leakage = lf.leakage, None
    try:
        h_lin = model.linear_frf(lf.freqs)
        rhs = np.broadcast_to(lf.B, (lf.freqs.size,) + lf.B.shape).astype(complex)
        for w, coef, key in terms:
            rhs = rhs - coef * w[None, :, None] * lf.T[key][:, None, :]
        H_model = h_lin @ rhs
    finally:
        lf.leakage = saved
    eq = [(w, coef * np.array(_equivalent(lf, H_model, w, key))) for w, coef, key in terms]
    offsets, weights = lf.smoothing
    fine = (lf.freqs[:, None] - offsets[None, :]).ravel()
    shape = (lf.freqs.size, offsets.size)

    def smooth(values: np.ndarray) -> np.ndarray:
        return np.einsum("fk,fk...->f...", weights, values.reshape(shape + values.shape[1:]))

    hl_fine, hl = model.linear_frf(fine), model.linear_frf(lf.freqs)
    n = hl.shape[1]
    d = np.zeros((fine.size, n, n), complex)
    for w, (a, b) in eq:
        d += (a + 2j * np.pi * fine * b)[:, None, None] * np.outer(w, w)[None]
    h_eq = np.linalg.solve(np.eye(n)[None] + hl_fine @ d, hl_fine @ lf.B)
    bias = smooth(hl_fine @ lf.B) - hl @ lf.B
    for w, (a, b) in eq:
        g = (a + 2j * np.pi * fine * b)[:, None] * np.einsum("i,fij->fj", w, h_eq)
        hw_fine = hl_fine @ w
        bias -= smooth(hw_fine[:, :, None] * g[:, None, :]) \
            - (hl @ w)[:, :, None] * smooth(g)[:, None, :]
    return bias


@dataclass(frozen=True)
class Floor:
    """Expected FRF error of an exact model at one level (the `weighted_error` metric).

    Attributes
    ----------
    noise : float
        Random error of the measured FRF, ``sqrt(sum g2 var / sum g2 |H|^2)``: for H1 the
        Bendat & Piersol variance ``(1 - g2) / (g2 n_eff) |H|^2`` from the measured
        coherence and number of averages (stepped sine: the block-to-block variance of the
        fitted fundamentals, weights 1).
    precision : float
        Model-precision floor (`compare.FLOOR`, relative).
    limit : float
        Error above which the level misfits: ``sqrt(precision^2 + noise^2 + Z_FLOOR s)``,
        ``s`` the standard deviation of the squared random error (bin correlation included).
    """

    noise: float
    precision: float
    limit: float

    def to_json(self) -> dict[str, float]:
        return {"noise": self.noise, "precision": self.precision, "limit": self.limit}

    @classmethod
    def from_json(cls, data: dict[str, float]) -> Floor:
        return cls(data["noise"], data["precision"], data["limit"])


def level_floor(lf: LevelFRF, precision: float = FLOOR) -> Floor:
    """The `Floor` of one level, from its measured variance (``lf.var`` less the precision
    part it holds)."""
    h2 = np.abs(lf.H) ** 2
    wt = lf.weight
    den = float(np.sum(wt * h2))
    rand = np.clip(lf.var - precision**2 * h2, 0.0, None)
    mean = float(np.sum(wt * rand)) / den
    sd = float(np.sqrt(lf.bin_factor * np.sum((wt * rand) ** 2))) / den
    return Floor(float(np.sqrt(mean)), precision,
                 float(np.sqrt(precision**2 + mean + Z_FLOOR * sd)))
