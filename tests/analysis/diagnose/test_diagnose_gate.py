"""The gate before the search (`policy.linear_only`): only linear candidates while the levels'
FRFs are the same within their random error, unless the floors already show a misfit that
grows with level (`policy.misfit_grows`: the highest fitting level beyond its floor, the
lowest within).

Synthetic one-input SDOF receptances as `sdof-cubic_above-disp-random-z7` has them: random
error 0.3 % of |H| (high coherence), the 1 % precision floor in ``var``, and the top level's
resonance 0.1 % higher (a cubic's stiffening: 5 % of |H| at the peak, as in the row) -- a
change confined to the resonance's lines.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from analysis.diagnose._compare import FLOOR, LevelFRF, weighted_error
from analysis.diagnose._leakage import level_floor
from analysis.diagnose._locate import ALPHA, level_dependence
from analysis.diagnose._policy import linear_only, misfit_grows

F0, ZETA, NOISE = 22.5, 0.02, 0.003


def _receptance(f: np.ndarray, f0: float) -> np.ndarray:
    r = f / f0
    return (1.0 / (1.0 - r**2 + 2j * ZETA * r))[:, None, None]


def _search(shift: float, seed: int, *, start_shift: float = 0.0, n: int = 467):
    """Two levels (1 and 12) measured with relative noise ``NOISE``; the top level's resonance
    moved by ``shift`` (relative); the start model's resonance by ``start_shift``."""
    rng = np.random.default_rng(seed)
    f = np.linspace(2.0, 60.0, n)
    levels = []
    for level, s in ((1.0, 0.0), (12.0, shift)):
        H = _receptance(f, F0 * (1 + s))
        noise = NOISE * np.abs(H) * (rng.standard_normal(H.shape)
                                     + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
        var = (NOISE**2 + FLOOR**2) * np.abs(H) ** 2
        levels.append(LevelFRF(f"{level:g} N", level, f, H + noise, np.ones(H.shape), var,
                               np.ones((1, 1))))
    H0 = _receptance(f, F0 * (1 + start_shift))
    search = SimpleNamespace(levels=levels, H0s=[H0, H0])
    return search, [level_floor(lf) for lf in levels]


def test_a_change_at_the_resonance_opens_the_gate_the_band_wide_test_misses():
    """The band-wide homogeneity test dilutes the resonance's lines among hundreds of
    unchanged ones (and its variances hold the precision floor: statistic well below 1 per
    DOF), so it calls the levels equal; the top level's misfit beyond its floor, the lowest
    within, keeps the nonlinear candidates in the search."""
    search, floors = _search(0.001, seed=1)
    dep = level_dependence(search.levels)
    assert not dep.dependent and dep.statistic_per_dof < 1.0
    assert misfit_grows(search, floors)
    assert not linear_only(search, floors)


def test_equal_levels_keep_the_gate_closed():
    """Size: with equal levels and the exact start model the gate opens only when a level
    misfits its floor by chance (p = 1e-4 each) or the levels differ (p = `ALPHA`): over 40
    seeds the expected count is 40 x 2e-4 = 0.008, so none may open it."""
    opened = [not linear_only(*_search(0.0, seed=s)) for s in range(40)]
    assert not any(opened)
    assert ALPHA == 1e-4


def test_a_linear_error_at_every_level_keeps_linear_candidates_only():
    """A start model 3 % too stiff misfits both levels beyond their floors: the misfit does not
    grow with level and the levels are equal, so only linear candidates are sought."""
    search, floors = _search(0.0, seed=2, start_shift=0.03)
    assert all(weighted_error(lf, h) > fl.limit
               for lf, h, fl in zip(search.levels, search.H0s, floors))
    assert not misfit_grows(search, floors)
    assert linear_only(search, floors)
