"""The responses' delay behind the force, read off a modal fit's poles
(`analysis.modal._delay`): a 2-DOF receptance column delayed by a known number of samples,
noise-free and with 1 % noise on the lines."""

import numpy as np
import pytest

from analysis.models import Model
from analysis.modal._delay import STEP, response_delay

FS = 512.0


def _column(delay: float, noise: float, seed: int = 0):
    k = np.array([[3.0e4, -1.5e4], [-1.5e4, 1.5e4]])
    m = np.diag([1.0, 0.5])
    model = Model(m, 4e-4 * k + m, k, [], "2-DOF")
    f = np.arange(5.0, 100.0, 0.5)
    H = model.linear_frf(f, [0])[:, :, 0] * np.exp(-2j * np.pi * f * delay / FS)[:, None]
    std = noise * np.abs(H)
    rng = np.random.default_rng(seed)
    H = H + std * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    w, v = np.linalg.eig(np.linalg.solve(m, k))
    # the model's poles (proportional damping c = 4e-4 k + m)
    wn = np.sqrt(w)
    zeta = 0.5 * (4e-4 * wn + 1.0 / wn)
    poles = -zeta * wn + 1j * wn * np.sqrt(1 - zeta ** 2)
    return f, H, std, poles


@pytest.mark.parametrize("delay", [1.0, -0.5, 2.3])
def test_delay_found(delay):
    f, H, std, poles = _column(delay, 0.0)
    assert response_delay(f, H, None, poles, FS) == pytest.approx(delay, abs=STEP)


def test_delay_found_through_noise():
    f, H, std, poles = _column(1.0, 0.01)
    assert response_delay(f, H, std, poles, FS) == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_delay_reads_none(seed):
    """With no delay, noise alone does not pass the F test (alpha 1e-3)."""
    f, H, std, poles = _column(0.0, 0.01, seed)
    assert response_delay(f, H, std, poles, FS) == 0.0
