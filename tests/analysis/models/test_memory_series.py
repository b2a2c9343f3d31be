"""`memory_force_series`: the built-in memory laws along a series, bitwise `restoring_force`."""

import numpy as np
import pytest

from analysis.models import memory_force_series, restoring_force

PARAMS = {"stick_slip": {"kd": 2.0e4, "fd": 3.0},
          "hysteresis": {"kd": 2.0e4, "fd": 3.0, "n": 2.0},
          "iwan": {"kd": 2.0e4, "fd": 3.0, "chi": -0.5, "beta": 0.5}}


def _motion(n: int = 20000, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Random motion reaching several slip displacements (inner loops and full slips), with
    samples where the rate is exactly zero (no reversal there)."""
    rng = np.random.default_rng(seed)
    v = np.convolve(rng.standard_normal(n), np.hanning(40), mode="same")
    v[::97] = 0.0
    u = np.cumsum(v)
    return 4 * 3.0 / 2.0e4 * u / u.std(), v


@pytest.mark.parametrize("kind", sorted(PARAMS))
def test_bitwise_restoring_force(kind):
    u, v = _motion()
    ref = restoring_force(kind, PARAMS[kind], u, v)[0]
    got = memory_force_series(kind, PARAMS[kind], u, v)
    assert np.abs(ref).max() == pytest.approx(PARAMS[kind]["fd"], rel=0.05)   # it slips
    np.testing.assert_array_equal(got, ref)


def test_memoryless_kind_refused():
    u, v = _motion(100)
    with pytest.raises(ValueError, match="cubic_spring"):
        memory_force_series("cubic_spring", {"p": 1.0}, u, v)
