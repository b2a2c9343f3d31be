"""Basis library, kind mapping and the alias-free evaluation."""

import numpy as np
import pytest

from analysis.models import (LIBRARY, Element, alias_error, aliasing_factor, deformation,
                             element_basis, evaluate)
from analysis.errors import EstimationError, InputError


def test_kind_mapping():
    assert element_basis(Element("cubic_spring", np.ones(1)))[1].name == "x^3"
    assert element_basis(Element("quadratic_damping", np.ones(1)))[1].variable == "v"
    name, b = element_basis(Element("gap", np.ones(1), {"g": 0.1}))
    assert name == "k" and b(np.array([0.3]))[0] == pytest.approx(0.2)
    with pytest.raises(EstimationError, match="analyze hbm"):
        element_basis(Element("stick_slip", np.ones(1)))
    with pytest.raises(InputError, match="width g"):
        element_basis(Element("gap", np.ones(1)))


def test_aliasing_factor_and_correction():
    fs, n = 1000.0, 2**14
    t = np.arange(n) / fs
    s = np.sin(2 * np.pi * 300 * t)                  # x^3 -> 900 Hz folds to 100 Hz
    assert aliasing_factor(3, 300.0, fs, 200.0) > 1
    assert aliasing_factor(3, 50.0, fs, 200.0) == 1
    cube = LIBRARY["x^3"]
    assert alias_error(cube, s, fs, (50, 200), 2) > 0.1
    clean = evaluate(cube, s, 2)
    spec = np.abs(np.fft.rfft(clean[2000:-2000] * np.hanning(n - 4000)))
    f = np.fft.rfftfreq(n - 4000, 1 / fs)
    assert spec[(f > 80) & (f < 120)].max() < 1e-3 * spec.max()


def test_relative_deformation_is_the_exact_difference():
    x = np.random.default_rng(3).standard_normal((1000, 6))[:, ::2]   # strided (n, 3) view
    np.testing.assert_array_equal(deformation(np.array([0.0, -1.0, 1.0]), x), x[:, 2] - x[:, 1])
