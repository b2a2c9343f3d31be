"""Fold and jump of a hardening Duffing oscillator (analysis.hbm._continuation, HBM sweeps)."""

import numpy as np
import pytest

from analysis.hbm import HBMSystem, continue_frf
from analysis.errors import InputError
from analysis.models import Element, Model
from analysis.plant import Plant
from analysis.spectral import sine_fit

FORCE = 5.0


@pytest.fixture(scope="module")
def system():
    model = Model([[2.0]], [[10.0]], [[2e5]], [Element("cubic_spring", [1.0], {"p": 6e10})])
    return HBMSystem(model, [0], (1, 3, 5))


@pytest.fixture(scope="module")
def branch(system):
    return continue_frf(system, 40.0, 80.0, FORCE)


def test_continuation_turns_both_folds(branch):
    assert branch.folds.size == 2
    upper, lower = branch.folds
    f_up, f_lo = branch.freqs[upper], branch.freqs[lower]
    assert f_lo < f_up
    # between the folds the curve runs backwards in frequency and is unstable
    middle = slice(upper, lower)
    assert np.all(np.diff(branch.freqs[middle]) < 0)
    assert not branch.stable[middle].any()
    assert branch.stable[:upper].all() and branch.stable[lower:].all()
    # the backbone of the cubic spring: f = f0 sqrt(1 + 3/4 p A^2 / k) at the peak
    a = branch.amplitude(0)[upper]
    f0 = np.sqrt(2e5 / 2.0) / (2 * np.pi)
    assert f_up == pytest.approx(f0 * np.sqrt(1 + 0.75 * 6e10 * a ** 2 / 2e5), rel=0.01)


def test_up_and_down_sweeps_jump_at_the_folds(system, branch):
    f_up, f_lo = branch.freqs[branch.folds[0]], branch.freqs[branch.folds[1]]
    freqs = np.arange(40.0, 80.0, 0.25)
    up = system.sweep(freqs, FORCE)
    down = system.sweep(freqs[::-1], FORCE)
    assert up.converged.all() and down.converged.all()
    a_up = np.abs(up.X[:, 0, 0])
    a_dn = np.abs(down.X[::-1, 0, 0])
    jump_up = freqs[np.argmin(np.diff(a_up))]           # last point before the drop
    jump_dn = freqs[np.argmin(np.diff(a_dn)) + 1]       # lowest point left on the low branch
    assert f_up - 0.25 <= jump_up <= f_up
    assert f_lo <= jump_dn <= f_lo + 0.25
    assert a_up.max() == pytest.approx(branch.amplitude(0)[branch.folds[0]], rel=0.01)
    # hysteresis region: the two sweeps differ, outside it they agree
    both = (freqs > f_lo + 0.5) & (freqs < f_up - 0.5)
    assert np.all(a_up[both] > 2 * a_dn[both])
    np.testing.assert_allclose(a_up[freqs < f_lo - 1], a_dn[freqs < f_lo - 1], rtol=1e-6)


def test_time_domain_sweep_lands_on_the_same_branches(system):
    """A simulated phase-continuous stepped up-sweep stays on the upper branch up to the
    fold, like the HBM sweep."""
    fs, step = 4096.0, 0.5
    freqs = np.arange(45.0, 59.01, step)
    hbm = system.sweep(freqs, FORCE)
    plant = Plant(system.model, fs, [0])
    n, phase = int(1.5 * fs), 0.0
    for i, f in enumerate(freqs):
        t = np.arange(n) / fs
        out = plant.run((FORCE * np.cos(2 * np.pi * f * t + phase))[:, None])
        phase += 2 * np.pi * f * n / fs
        if f in (50.0, 55.0, 59.0):
            amp = abs(sine_fit(out.displacement[-int(0.5 * fs):, 0], fs, f)[0])
            assert amp == pytest.approx(abs(hbm.X[i, 0, 0]), rel=5e-3)
    assert abs(hbm.X[-1, 0, 0]) > 1e-3        # 59 Hz: still on the upper branch


def test_bad_range(system):
    with pytest.raises(InputError, match="two different positive"):
        continue_frf(system, 50.0, 50.0, FORCE)


def test_fold_frequencies_between_the_points(system, branch):
    """The folds' frequencies by Hermite interpolation along the arc (error ~ step^4) turn
    beyond both points around each fold, and a run with 10x the step finds them 100x closer
    to those of the default step than its own fold points are (the points: ~ step^2)."""
    upper, lower = branch.folds
    assert branch.fold_freqs[0] >= branch.freqs[upper - 1:upper + 1].max()
    assert branch.fold_freqs[1] <= branch.freqs[lower - 1:lower + 1].min()
    coarse = continue_frf(system, 40.0, 80.0, FORCE, max_step=1.0)
    assert coarse.folds.size == 2
    by_point = np.abs(coarse.freqs[coarse.folds] - branch.fold_freqs)
    by_turn = np.abs(coarse.fold_freqs - branch.fold_freqs)
    assert np.all(by_turn <= by_point / 100), (by_turn, by_point)
