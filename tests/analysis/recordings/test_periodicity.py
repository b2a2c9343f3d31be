"""The period of an export that carries none (`analysis.recordings._periodicity`): found in periodic
multisine forces with or without a start-up transient, not in random or swept records."""

import numpy as np
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
