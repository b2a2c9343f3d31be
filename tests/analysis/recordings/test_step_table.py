"""`StepTable`: a table's mixed sensor kinds become one kind on its phasors (harmonics at
their own order), and its FRF feeds the spectral room as time blocks do."""

import numpy as np
import pytest

from analysis.recordings import SensorMap, StepTable, one_kind
from analysis.spectral import level_frf, stepped_sine_frf


def test_mixed_kinds_become_the_highest_kind():
    f = np.array([10.0, 20.0, 30.0])
    w = 2 * np.pi * f
    x = np.array([1e-3, 2e-3, 1e-3]) * np.exp(0.3j)          # displacement of one point
    smap = SensorMap(("a", "b"), ("displacement", "acceleration"), ("a",))
    harm = np.stack([x * 0.1, x * 0.01], axis=1)             # orders 2 and 3, (3, 2)
    t = StepTable(f, np.ones((3, 1)), np.stack([x, -(w**2) * x], axis=1), [0], "force", 1.0,
                  sensors=smap, harmonics=(2, 3), force_harmonics=np.zeros((3, 2, 1)),
                  response_harmonics=np.stack([harm, harm], axis=2))
    one = one_kind(t)
    assert one.response_kind == "acceleration"
    np.testing.assert_allclose(one.response_phasor[:, 0], one.response_phasor[:, 1])
    # harmonic h of the displacement channel: times (i h w)^2
    np.testing.assert_allclose(one.response_harmonics[:, 1, 0],
                               -(3 * w) ** 2 * t.response_harmonics[:, 1, 0])
    np.testing.assert_allclose(one.response_harmonics[:, 1, 1], t.response_harmonics[:, 1, 1])


def test_table_feeds_level_frfs_and_harmonic_balance_data():
    f = np.array([10.0, 20.0])
    w = 2 * np.pi * f
    x = np.array([1e-3, 2e-3j])
    t = StepTable(f, np.array([[2.0], [1j]]), (-(w**2) * x)[:, None], [0], "response",
                  0.5, response_kind="acceleration", control_dof=0)
    frf = level_frf(t)
    np.testing.assert_allclose(frf.H[:, 0, 0], -(w**2) * x / np.array([2.0, 1j]))
    assert frf.level_kind == "acceleration" and frf.label == "0.5 m/s²"
    ss = stepped_sine_frf(t)                 # displacement, force phase referenced to 0
    assert list(ss.harmonics) == [1]         # no zero-filled harmonics
    np.testing.assert_allclose(ss.force, [2.0, 1.0])
    np.testing.assert_allclose(ss.X[:, 0, 0], x * np.exp(-1j * np.angle([2.0, 1j])))
    with pytest.raises(ValueError, match="control"):
        StepTable(f, np.ones((2, 1)), np.ones((2, 1)), [0], "voltage", 1.0)
