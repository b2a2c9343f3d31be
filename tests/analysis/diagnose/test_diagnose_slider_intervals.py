"""Reported intervals of a slider's two parameters (`analysis.diagnose._joint.grid_refit`, the
misfit profile, then `misfit_intervals`, the cluster-robust joint covariance) on level FRFs
built by hand: the slider's basis is its describing function at a known amplitude per line,
so the truth and the noise are known exactly and the fitted model holds the truth.

A slider's ``kd`` and slip displacement trade off (a later slip with a softer spring explains
nearly the same FRFs); ``fd = kd * slip`` is pinned better than either, but not exactly: its
interval must hold ``kd``'s error at a fixed slip too (the profile's ends alone gave a
zero-width ``fd`` interval, zoo `gvt-jenkins-joint`).

Then the reported intervals over realizations where they matter: the level's stated noise
a third of the true one (a variance read from a few periods), and the zoo's
`twin-jenkins_joint-acc-multisine` over ten multisine realizations (its slip force moves by
about 3 % from one to the next, without sensor noise too)."""

import numpy as np
import pytest

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


def _realization(rng: np.random.Generator, understated: float = 1.0) -> tuple[Fit, Fit, Fit]:
    """One realization's fit after the profile (`grid_refit`), after `misfit_intervals`,
    and with the sandwich's intervals alone (`misfit_intervals` on the profiled estimates
    with zero-width intervals); the noise added is ``understated`` times the stated one."""
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
        lf.H = h + understated * e * np.sqrt(lf.var / 2)
    guess = 1.3 * SLIP                # a grid value off the truth, as the screening's
    search.ensure_basis(cand, guess)
    first = Fit(cand, scaled_params("stick_slip", KD, guess), {"kd": [KD, KD]}, 0.0, 0.0,
                extra=guess)
    profiled = grid_refit(start, search, [first], 0)[0]
    (reported,) = misfit_intervals(start, search, [profiled])
    assert reported.params == profiled.params             # the estimates are not touched
    point = Fit(cand, profiled.params, {k: [v] * 2 for k, v in profiled.params.items()}, 0.0,
                0.0, extra=profiled.extra)
    (alone,) = misfit_intervals(start, search, [point])
    return profiled, reported, alone


def _runs(n: int, understated: float = 1.0) -> tuple[list[Fit], ...]:
    rng = np.random.default_rng(3)
    return tuple(zip(*[_realization(rng, understated) for _ in range(n)]))


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


@pytest.mark.slow
def test_slider_sandwich_covers_a_misfit_its_noise_understates():
    """The noise 3x the stated one (a variance from three periods runs low): the profile
    widens by the reduced misfit; the sandwich alone must see the misfit itself. Over 60
    realizations its ``kd`` and ``fd`` intervals cover >= 85 % (measured 92 % and 88 %,
    half widths 1.2x the estimates' ``Z95`` spread). The leave-one-block-out covariance
    (`_joint._cluster_jackknife`, taken for second-parameter kinds) does this; the
    cluster-robust ``A^-1 B A^-1 G/(G-1)`` alone covered ``kd`` 82 % (half width 0.52 %
    against 0.65 % needed): the blocks that pin ``kd`` have the scores the fit zeroed."""
    _, reported, alone = _runs(60, understated=3.0)
    for name, truth in (("kd", KD), ("fd", KD * SLIP)):
        est = np.array([f.params[name] for f in reported])
        for fits in (reported, alone):
            assert _coverage(fits, name, truth) >= 0.85, name
        half = np.median([(f.ci95[name][1] - f.ci95[name][0]) / 2 for f in alone])
        assert half < 2 * Z95 * np.std(est), name


@pytest.mark.slow
def test_twin_slider_fd_interval_covers_over_multisine_realizations():
    """`twin-jenkins_joint-acc-multisine` with seeds 1-10 (multisine phases and sensor noise):
    the slip force's error spreads over -3.6 .. +5.7 % (standard deviation 3.1 %, mean +1.0 %;
    without sensor noise seeds 1-6 still -1.7 .. +4.3 %: the realization, not the noise).
    The reported ``fd`` and ``kd`` intervals each cover at least 7 of 10 (at a nominal 95 %
    fewer happens 1 % of the time; measured 8 and 9; with the cluster-robust sandwich alone,
    before the leave-one-block-out covariance, ``fd`` 4 of 10, half widths 1.0-4.3 %) and are not
    widened beyond twice the spread (``Z95`` standard deviations)."""
    import diagnose_zoo as Z
    cases = [Z._mapped_case("twin-jenkins_joint-acc-multisine", "twin", Z.TWIN_MS, Z.A,
                            Z.TWIN_CH, ("stick_slip", ("wing", "payload"), "joint"), seed=s)
             for s in range(1, 11)]
    rows = [Z.run_case(c).intervals for c in cases]
    for name in ("stick_slip.fd", "stick_slip.kd"):
        est, lo, hi, truth = np.array([r[name] for r in rows]).T
        assert np.sum((lo <= truth) & (truth <= hi)) >= 7, name
        assert np.median((hi - lo) / 2) < 2 * Z95 * np.std(est), name
