"""Harmonic balance with a held response amplitude (analysis.hbm._held): on a hardening
Duffing oscillator it reaches the unstable middle branch that a force-controlled sweep jumps
over, at the force that continuation through the folds gives there."""

import numpy as np
import pytest

from analysis.hbm import HBMError, HBMSystem, continue_frf, sweep_held
from analysis.models import Element, Model

FORCE = 5.0


@pytest.fixture(scope="module")
def system():
    model = Model([[2.0]], [[10.0]], [[2e5]], [Element("cubic_spring", [1.0], {"p": 6e10})])
    return HBMSystem(model, [0], (1, 3, 5))


def test_held_amplitudes_of_the_middle_branch_need_the_continued_force(system):
    branch = continue_frf(system, 40.0, 80.0, FORCE)
    upper, lower = branch.folds
    middle = np.arange(upper + 1, lower)[::3]              # unstable: three answers at FORCE
    freqs, a = branch.freqs[middle], branch.amplitude(0)[middle]
    res, force = sweep_held(system, freqs, np.ones((freqs.size, 1)), 0, a)
    assert res.converged.all()
    np.testing.assert_allclose(np.abs(res.X[:, 0, 0]), a, rtol=1e-8)
    # both solve the same balance to the Newton tolerance (1e-9); continuation's corrector
    # stops at its own, looser one
    np.testing.assert_allclose(force[:, 0], FORCE, rtol=1e-6)
    np.testing.assert_allclose(res.X, branch.X[middle], rtol=0, atol=1e-6 * a.max())


def test_a_linear_model_is_held_in_closed_form():
    model = Model([[2.0]], [[10.0]], [[2e5]], [])
    freqs = np.linspace(40.0, 60.0, 5)
    res, force = sweep_held(HBMSystem(model, [0], (1,)), freqs, [1.0], 0, 1e-4)
    H = 1 / (2e5 - 2.0 * (2 * np.pi * freqs) ** 2 + 10.0j * 2 * np.pi * freqs)
    np.testing.assert_allclose(force[:, 0], 1e-4 / np.abs(H), rtol=1e-12)
    np.testing.assert_allclose(np.abs(res.X[:, 0, 0]), 1e-4, rtol=1e-12)


def test_bad_held_input(system):
    with pytest.raises(HBMError, match="held DOF"):
        sweep_held(system, [50.0], [1.0], 3, 1e-4)
    with pytest.raises(HBMError, match="positive"):
        sweep_held(system, [50.0], [1.0], 0, -1e-4)
