"""Reported intervals of a slider's two parameters (`analysis.diagnose._joint.grid_refit`, the
misfit profile, then `misfit_intervals`, the cluster-robust joint covariance) on level FRFs
built by hand: the slider's basis is its describing function at a known amplitude per line,
so the truth and the noise are known exactly and the fitted model holds the truth.

A slider's ``kd`` and slip displacement trade off (a later slip with a softer spring explains
nearly the same FRFs); ``fd = kd * slip`` is pinned better than either, but not exactly: its
interval must hold ``kd``'s error at a fixed slip too (the profile's ends alone gave a
zero-width ``fd`` interval, zoo `gvt-jenkins-joint`)."""

import numpy as np

from analysis.diagnose._compare import LevelFRF, model_frf
from analysis.diagnose._joint import grid_refit, misfit_intervals
from analysis.diagnose._linear_update import Z95
from analysis.diagnose._select import Fit, scaled_params
from analysis.models import Model, library

KD, SLIP = 2.0e3, 1.0e-3            # true slider stiffness (N/m) and slip displacement (m)
NOISE = 0.01                        # relative FRF noise (std of |H| per line)
FREQS = np.linspace(2.0, 40.0, 300)
AMPLITUDES = (2.0e-3, 6.0e-3)       # deformation amplitude scale of the two fitting levels, m


def _model() -> Model:
    return Model(np.eye(1), np.array([[2.0]]), np.array([[1.0e4]]))


def _describing(slip: float, amp: np.ndarray) -> np.ndarray:
    """Jenkins element's describing function at unit ``kd`` (elastic-perfectly-plastic)."""
    beta = np.minimum(slip / amp, 1.0)
    th = np.arccos(1 - 2 * beta)
    return (th - np.sin(2 * th) / 2) / np.pi + 4j / np.pi * beta * (1 - beta)


class _Search:
    """The part of `analysis.diagnose._select.Search` the refit and the intervals read: the
    basis of any slip displacement is added on demand (as the random search does)."""

    continuous_grid = True

    def __init__(self, start: Model, levels: list[LevelFRF], amps: list[np.ndarray],
                 cand) -> None:
        self.levels, self.amps, self.cand = levels, amps, cand
        self.terms, self.grid_refits = [], {}
        self.H_lins = [start.linear_frf(FREQS) for _ in levels]
        self.n_values = sum(lf.n_values for lf in levels)

    def ensure_basis(self, c, extra: float) -> None:
        for lf, amp in zip(self.levels, self.amps):
            lf.T[(c, extra)] = (_describing(extra, amp) * _unit_motion())[:, None]


def _unit_motion() -> np.ndarray:
    """Deformation per unit force over the band (a stiffness-controlled shape)."""
    w = 2 * np.pi * FREQS
    return 1.0 / (1.2e4 - w ** 2 + 2j * w)


def _realization(rng: np.random.Generator) -> tuple[Fit, Fit, Fit]:
    """One realization's fit after the profile (`grid_refit`), after `misfit_intervals`,
    and with the sandwich's intervals alone (`misfit_intervals` on the profiled estimates
    with zero-width intervals)."""
    start = _model()
    cand = next(c for c in library(1) if c.kind == "stick_slip")
    amps = [a * (0.5 + FREQS / FREQS.max()) for a in AMPLITUDES]
    levels = []
    for amp in amps:
        lf = LevelFRF("l", 1.0, FREQS, np.zeros((FREQS.size, 1, 1), complex),
                      np.ones((FREQS.size, 1, 1)), np.ones((FREQS.size, 1, 1)), np.ones((1, 1)))
        levels.append(lf)
    search = _Search(start, levels, amps, cand)
    search.ensure_basis(cand, SLIP)
    for lf, hl in zip(levels, search.H_lins):
        h = model_frf(hl, lf, [(cand.w, KD, (cand, SLIP))])
        lf.var = (NOISE * np.abs(h)) ** 2
        e = rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)
        lf.H = h + e * np.sqrt(lf.var / 2)
    guess = 1.3 * SLIP                # a grid value off the truth, as the screening's
    search.ensure_basis(cand, guess)
    first = Fit(cand, scaled_params("stick_slip", KD, guess), {"kd": [KD, KD]}, 0.0, 0.0,
                extra=guess)
    profiled = grid_refit(start, search, [first], 0)
    (reported,) = misfit_intervals(start, search, [profiled])
    assert reported.params == profiled.params             # the estimates are not touched
    point = Fit(cand, profiled.params, {k: [v] * 2 for k, v in profiled.params.items()}, 0.0,
                0.0, extra=profiled.extra)
    (alone,) = misfit_intervals(start, search, [point])
    return profiled, reported, alone


def _runs(n: int) -> tuple[list[Fit], ...]:
    rng = np.random.default_rng(3)
    return tuple(zip(*[_realization(rng) for _ in range(n)]))


def _coverage(fits: list[Fit], name: str, truth: float) -> float:
    return float(np.mean([f.ci95[name][0] <= truth <= f.ci95[name][1] for f in fits]))


def test_slider_intervals_cover_at_about_the_nominal_rate():
    """60 noise realizations of a model that holds the truth: the reported ``kd`` and ``fd``
    intervals hold the truth at about 95 % (>= 85 %: binomial spread of 60 draws and the
    sandwich's own sampling spread), and their half widths stay within 2x the spread of the
    estimates themselves (``Z95`` standard deviations): not widened beyond what they cover.
    So do the profile's own intervals (`grid_refit`, ``kd``'s error carried to each end of
    ``fd``: from the ends' ``kd * slip`` alone it covered 32 % of the time, half width
    0.024 % against a spread of 0.063 %) and the sandwich's alone (the joint covariance of
    ``kd`` and the log slip, ``fd`` by the delta method)."""
    profiled, reported, alone = _runs(60)
    for name, truth in (("kd", KD), ("fd", KD * SLIP)):
        est = np.array([f.params[name] for f in reported])
        for fits in (reported, profiled, alone):
            assert _coverage(fits, name, truth) >= 0.85, name
            half = np.median([(f.ci95[name][1] - f.ci95[name][0]) / 2 for f in fits])
            assert half < 2 * Z95 * np.std(est), name
