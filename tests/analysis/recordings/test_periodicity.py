"""The period of an export that carries none (`analysis.recordings._periodicity`): found in periodic
multisine forces with or without a start-up transient, not in random or swept records."""

import numpy as np
import pytest
import scipy.signal

from analysis.plant import multisine, periodic
from analysis.recordings import SHARE_MIN, find_period

FS = 400.0


def _through_a_resonance(x: np.ndarray) -> np.ndarray:
    """A force measured behind a lightly damped 3 Hz resonance, started from rest: the first
    period carries the transient."""
    b, a = scipy.signal.iirpeak(3.0, 30.0, fs=FS)
    return x + 5 * scipy.signal.lfilter(b, a, x)


def test_f16_layout_8192_by_9_periods_first_transient():
    rng = np.random.default_rng(0)
    one = multisine(8192, FS, (2.0, 15.0), 1.0, seed=3)
    x = _through_a_resonance(periodic(one, 9))
    x += 0.01 * x.std() * rng.standard_normal(x.size)
    p = find_period(x)
    assert (p.period, p.periods, p.transient_periods, p.remainder) == (8192, 9, 1, 0)
    assert p.share > SHARE_MIN


def test_no_transient_when_the_first_period_repeats_like_the_others():
    rng = np.random.default_rng(1)
    x = periodic(multisine(1024, FS, (2.0, 50.0), 1.0, seed=4), 6)[:, None]
    x = x + 0.02 * x.std() * rng.standard_normal(x.shape)
    p = find_period(x)
    assert (p.period, p.periods, p.transient_periods) == (1024, 6, 0)


def test_a_record_that_is_not_whole_periods_says_so():
    x = periodic(multisine(1000, FS, (2.0, 50.0), 1.0, seed=5), 5)[:4700]
    p = find_period(x)
    assert (p.period, p.periods, p.remainder) == (1000, 4, 700)


def test_random_and_swept_records_have_no_period():
    rng = np.random.default_rng(2)
    noise = scipy.signal.lfilter(*scipy.signal.butter(4, [2, 15], "bandpass", fs=FS),
                                 rng.standard_normal(73728))
    assert find_period(noise) is None
    assert find_period(rng.standard_normal((8192 * 3, 2))) is None
    t = np.arange(108000) / FS                       # F-16 sine sweep: 15 -> 2 Hz
    assert find_period(scipy.signal.chirp(t, 15.0, t[-1], 2.0)) is None


def _back_to_back(period: int, periods: int, realizations: int, same: bool = False):
    """``realizations`` random-phase multisines of ``periods`` periods each, concatenated, as
    measured behind a resonance that runs on across the boundaries, 1 % noise."""
    rng = np.random.default_rng(period + periods)
    x = np.concatenate([periodic(multisine(period, FS, (2.0, 15.0), 1.0,
                                           seed=7 if same else 7 + r), periods)
                        for r in range(realizations)])
    x = _through_a_resonance(x)
    return x + 0.01 * x.std() * rng.standard_normal(x.size)


@pytest.mark.parametrize("period, periods, realizations", [(8192, 9, 3), (4096, 5, 2),
                                                           (1024, 4, 3)])
def test_realizations_back_to_back_are_found(period, periods, realizations):
    x = _back_to_back(period, periods, realizations)
    p = find_period(x)
    assert (p.period, p.periods, p.realizations, p.remainder) == (period, periods,
                                                                   realizations, 0)
    # the transient is each realization's own (the same test on each one alone), the most of
    # them; every realization's steady periods are periodic
    alone = [find_period(part).transient_periods for part in np.split(x, realizations)]
    assert p.transient_periods == max(alone) >= 1 and p.share > SHARE_MIN
    with_period = find_period(x, period=period)
    assert (with_period.realizations, with_period.periods) == (realizations, periods)


def test_the_f16_layout_has_one_transient_period_per_realization():
    """8192 samples x 9 periods x 3 realizations: behind a 3 Hz resonance with Q = 30 the
    transient decays by exp(-pi f T / Q) = 2e-3 over a 20 s period, below the 1 % noise after
    one period."""
    p = find_period(_back_to_back(8192, 9, 3))
    assert (p.realizations, p.transient_periods) == (3, 1)


def test_identical_realizations_are_one_realization():
    p = find_period(_back_to_back(2048, 3, 3, same=True))
    assert (p.period, p.periods, p.realizations) == (2048, 9, 1)


def test_settle_channels_extend_the_transient():
    """A force periodic from its first sample drives a slowly settling response: the
    response's leading periods are transient, the force's are not."""
    force = periodic(multisine(1024, FS, (2.0, 50.0), 1.0, seed=8), 8)
    rng = np.random.default_rng(3)
    force = force + 1e-3 * rng.standard_normal(force.size)
    b, a = scipy.signal.iirpeak(3.0, 60.0, fs=FS)        # decays over ~ 6 s = 2.5 periods
    response = scipy.signal.lfilter(b, a, force)
    response += 1e-3 * response.std() * rng.standard_normal(response.size)
    assert find_period(force).transient_periods == 0
    assert find_period(force, settle=response[:, None]).transient_periods >= 2


@pytest.mark.parametrize("n", [8192 * 12, 1024 * 60])
def test_noise_with_many_divisors_stays_without_period(n):
    rng = np.random.default_rng(n)
    noise = scipy.signal.lfilter(*scipy.signal.butter(4, [2, 15], "bandpass", fs=FS),
                                 rng.standard_normal(n))
    assert find_period(noise) is None
    t = np.arange(n // 2) / FS                             # an up- then a down-sweep
    sweep = scipy.signal.chirp(t, 2.0, t[-1], 15.0)
    assert find_period(np.r_[sweep, sweep[::-1]]) is None
