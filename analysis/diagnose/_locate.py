"""Where the mismatch lives: level dependence, response DOFs and frequency band.

Level dependence (homogeneity): the FRFs of two levels are compared bin by bin against
their combined H1 random error; ``q = sum 2 |H_a - H_b|^2 / (var_a + var_b)`` / bin factor is
chi-square with ``N`` effective degrees of freedom when the structure is linear (variances
estimated from ``nu`` degrees of freedom, as a periodic record's period spread, are
corrected for the mean of their inverse). A p-value
below `ALPHA` for the lowest-versus-highest level pair means the structure is nonlinear.
``var`` holds the model-precision floor, so the test is conservative (0.03-0.72 per DOF on
the diagnosis zoo's linear rows) and sums every line of the band: a change confined to a
resonance's lines can pass it (`policy.linear_only` therefore also reads the floors).
The per-DOF share of ``q`` tells which FRFs move with level (paper chapter 2).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import chi2 as chi2_dist

from ._compare import LevelFRF

ALPHA = 1e-4


@dataclass(frozen=True)
class LevelDependence:
    """Outcome of the homogeneity test between the lowest and highest level: the chi-square
    statistic per degree of freedom (about 1 for a linear structure), its p-value, and the
    response DOFs that move most with their share of the statistic."""

    dependent: bool
    p_value: float
    statistic_per_dof: float
    moving_dofs: tuple[int, ...]
    share_by_dof: tuple[float, ...]

    def to_json(self) -> dict[str, Any]:
        return {"dependent": self.dependent, "p_value": self.p_value,
                "statistic_per_dof": self.statistic_per_dof,
                "moving_dofs": list(self.moving_dofs), "share_by_dof": list(self.share_by_dof)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> LevelDependence:
        return cls(data["dependent"], data["p_value"], data["statistic_per_dof"],
                   tuple(data["moving_dofs"]), tuple(data["share_by_dof"]))


def level_dependence(levels: list[LevelFRF]) -> LevelDependence | None:
    """Homogeneity test across levels (None with a single level)."""
    if len(levels) < 2:
        return None
    lo = min(levels, key=lambda lf: lf.level)
    hi = max(levels, key=lambda lf: lf.level)
    # the lines both levels hold (each level keeps the lines its own force excites)
    _, a, b = np.intersect1d(lo.freqs, hi.freqs, assume_unique=True, return_indices=True)
    if a.size == 0:
        return None
    z = 2 * np.abs(lo.H[a] - hi.H[b]) ** 2 / (lo.var[a] + hi.var[b])
    bf = 0.5 * (lo.bin_factor + hi.bin_factor)
    nu = min(lf.noise_dof or np.inf for lf in (lo, hi))
    if np.isfinite(nu) and nu > 2:
        z = z * (nu - 2) / nu   # variances estimated with nu dof: E[1/var] = nu/(nu-2)/var
    q = float(z.sum() / bf)
    dof = 2 * z.size / bf
    p = float(chi2_dist.sf(q, dof))
    by_dof = z.sum(axis=(0, 2))
    share = by_dof / max(by_dof.sum(), 1e-300)
    excess = by_dof / (2 * z.shape[0] * z.shape[2]) - 1.0   # mean normalised change - 1
    moving = [int(i) for i in np.flatnonzero(excess > 0.5 * excess.max())] if p < ALPHA else []
    return LevelDependence(p < ALPHA, p, q / max(dof, 1.0), tuple(moving),
                           tuple(float(s) for s in share))


def mismatch_band(lf: LevelFRF, H_model: np.ndarray, *, mass: float = 0.9
                  ) -> tuple[float, float]:
    """Frequency band holding the central ``mass`` of the excess weighted misfit."""
    z = np.sum(np.abs(lf.H - H_model) ** 2 / lf.var, axis=(1, 2))
    excess = np.clip(z - lf.H.shape[1] * lf.H.shape[2], 0.0, None)
    if excess.sum() <= 0:
        return float(lf.freqs[0]), float(lf.freqs[-1])
    cum = np.cumsum(excess) / excess.sum()
    tail = (1 - mass) / 2
    i0 = int(np.searchsorted(cum, tail))
    i1 = int(min(np.searchsorted(cum, 1 - tail), lf.freqs.size - 1))
    return float(lf.freqs[i0]), float(lf.freqs[i1])
