"""`find_bursts` on records that hold no bursts (the fuzzed import's NaN force)."""

import numpy as np

from analysis.recordings import find_bursts


def test_non_finite_constant_or_single_burst_records_hold_no_bursts():
    rng = np.random.default_rng(0)
    one = np.r_[np.zeros(100), rng.standard_normal(1000), np.zeros(100)]
    for force in (np.full(4096, np.nan), np.zeros(4096), one, np.r_[np.inf, one]):
        assert find_bursts(force) is None


def test_two_equal_bursts_between_quiet_gaps_are_found():
    rng = np.random.default_rng(1)
    gap = np.zeros(200)
    force = np.r_[gap, rng.standard_normal(1000), gap, rng.standard_normal(1000), gap]
    b = find_bursts(force)
    assert b is not None and b.length == 1000 and b.starts == (200, 1400)
