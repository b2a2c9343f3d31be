"""The period of an export that carries none (`analysis.recordings._periodicity`): found in periodic
multisine forces with or without a start-up transient, not in random or swept records."""

import numpy as np
import pytest
import scipy.signal

from analysis.plant import multisine, periodic
from analysis.recordings import SHARE_MIN, find_period, flat_ends, whole_periods

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


def test_record_cut_inside_its_last_realization():
    """Three realizations of 1 + 3 periods, the record cut 0.37 period before its end (an
    export that is not a whole number of periods): the layout is found with the last
    realization one period short, and `whole_periods` takes every realization to the 3
    whole periods the last one holds."""
    rng = np.random.default_rng(1)
    n = 1024
    blocks = [periodic(multisine(n, FS, (5.0, 100.0), 1.0, seed=s), 4) for s in (1, 2, 3)]
    x = np.concatenate(blocks)[: -int(0.37 * n)]
    x = x + 0.005 * x.std() * rng.standard_normal(x.size)
    p = find_period(x)
    assert (p.period, p.realizations, p.periods, p.short, p.whole) == (n, 3, 4, 1, 3)
    assert p.remainder == n - int(0.37 * n)
    cut = whole_periods(x, p)
    assert cut.shape == (3 * 3 * n,)
    for r in range(3):          # each realization's first 3 periods, in order
        assert np.array_equal(cut[3 * n * r:3 * n * (r + 1)], x[4 * n * r:4 * n * r + 3 * n])


def test_one_realization_with_a_partial_period():
    x = periodic(multisine(1024, FS, (5.0, 100.0), 1.0, seed=4), 6)[:-300]
    p = find_period(x)
    assert (p.period, p.realizations, p.short, p.whole, p.remainder) == (1024, 1, 0, 5, 724)
    assert whole_periods(x, p).shape == (5 * 1024,)


def test_flat_ends_are_the_export_padding():
    x = np.zeros((1000, 2))
    x[300:900] = np.random.default_rng(0).standard_normal((600, 2))
    assert flat_ends(x[:, :1], x[:, 1:]) == (300, 100)
    assert flat_ends(x[300:900]) == (0, 0)           # no padding
    assert flat_ends(np.zeros((10, 1))) == (0, 0)    # nothing moves: nothing to trim



def test_a_slow_drift_is_not_a_transient():
    """The artifact catalogue's drift (a quarter sine over the record plus a ramp, peak 0.1 of
    the rms, `analysis.recordings.DaqArtifacts`) moves each period's mean and tilt: with the
    periods' trends taken out the count is the clean twin's (1 of 4 per realization; the
    drift made it 2 before)."""
    import sys
    from pathlib import Path
    sys.path.append(str(Path(__file__).resolve().parents[2]))
    import daq_twin as T
    from analysis.recordings import DaqArtifacts, apply_daq_artifacts

    rec = T.clean_levels(False, T.LEVELS, 3)[0]
    for arts in ([], ["drift"]):
        a = apply_daq_artifacts(rec, DaqArtifacts.of(arts, T.FS), np.random.default_rng(11))
        p = find_period(a.force[:, 0], settle=a.response)
        assert (p.transient_periods, p.periods, p.realizations) == (1, 4, 3), arts
