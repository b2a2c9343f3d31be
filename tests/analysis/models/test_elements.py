"""Element force laws against hand formulas; hysteresis loops of the memory kinds."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.models import KINDS, restoring_force

U = np.linspace(-2e-3, 2e-3, 41)
V = np.linspace(-0.3, 0.3, 41)[::-1]


@pytest.mark.parametrize("kind, params, expected", [
    ("cubic_spring", {"p": 3e9}, lambda u, v: 3e9 * u ** 3),
    ("quadratic_spring", {"p": 6e7}, lambda u, v: 6e7 * u * np.abs(u)),
    ("quadratic_damping", {"p": 20.0}, lambda u, v: 20.0 * v * np.abs(v)),
    ("cubic_damping", {"p": 50.0}, lambda u, v: 50.0 * v ** 3),
    ("coulomb_friction", {"fc": 4.0}, lambda u, v: 4.0 * np.tanh(v / 1e-3)),
    ("coulomb_friction", {"fc": 4.0, "v_reg": 0.1}, lambda u, v: 4.0 * np.tanh(v / 0.1)),
    ("gap", {"k": 1e6, "g": 1e-3},
     lambda u, v: np.where(np.abs(u) > 1e-3, 1e6 * (np.abs(u) - 1e-3) * np.sign(u), 0.0)),
])
def test_memoryless_laws(kind, params, expected):
    g, _ = restoring_force(kind, params, U, V)
    np.testing.assert_allclose(g, expected(U, V), rtol=1e-14, atol=1e-300)


def test_every_kind_is_covered():
    assert set(KINDS) == {"cubic_spring", "quadratic_spring", "quadratic_damping",
                          "cubic_damping", "coulomb_friction", "stick_slip", "hysteresis",
                          "gap", "iwan"}


def _harmonic(amplitude, cycles=3, n_per_cycle=20000):
    t = np.linspace(0.0, 2 * np.pi * cycles, cycles * n_per_cycle + 1)
    return t, amplitude * np.sin(t), amplitude * np.cos(t)


def _loop_area(u, g, n_per_cycle):
    """Area of the last closed cycle, trapezoidal integral of g du."""
    u, g = u[-n_per_cycle - 1:], g[-n_per_cycle - 1:]
    return abs(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(u)))


def test_stick_slip_values_and_loop_area():
    kd, fd, amp, npc = 2.4e7, 246.048, 3e-5, 20000
    # virgin stick, then slip at +fd, then back into stick
    g, state = restoring_force("stick_slip", {"kd": kd, "fd": fd},
                               np.array([0.0, 5e-6, 2e-5, 1.5e-5]), np.zeros(4))
    np.testing.assert_allclose(g, [0.0, kd * 5e-6, fd, fd - kd * 5e-6], rtol=1e-12)
    assert state[0] == pytest.approx(2e-5 - fd / kd)
    _, u, v = _harmonic(amp, n_per_cycle=npc)
    g, _ = restoring_force("stick_slip", {"kd": kd, "fd": fd}, u, v)
    assert np.abs(g).max() == pytest.approx(fd)
    # loop area of the Jenkins element: 4 fd (A - fd / kd); sampling error ~ (2 pi / npc)^2
    assert _loop_area(u, g, npc) == pytest.approx(4 * fd * (amp - fd / kd), rel=1e-6)


def _virgin(kd, fd, n, u):
    return kd * u / (1 + np.abs(kd * u / fd) ** n) ** (1 / n)


def test_hysteresis_virgin_curve_and_masing_loop():
    kd, fd, n, amp, npc = 2.4e7, 246.048, 2.0, 3e-5, 20000
    up = np.linspace(0.0, amp, 101)
    g, _ = restoring_force("hysteresis", {"kd": kd, "fd": fd, "n": n}, up, np.ones_like(up))
    np.testing.assert_allclose(g, _virgin(kd, fd, n, up), rtol=1e-13)
    t, u, v = _harmonic(amp, n_per_cycle=npc)
    g, _ = restoring_force("hysteresis", {"kd": kd, "fd": fd, "n": n}, u, v)
    last = slice(-npc - 1, None)
    gl, ul = g[last], u[last]
    tip = _virgin(kd, fd, n, amp)
    # loop closes, tips on the virgin curve, symmetric
    assert gl[0] == pytest.approx(gl[-1], rel=1e-9)
    assert gl.max() == pytest.approx(tip, rel=1e-6)
    assert gl.min() == pytest.approx(-tip, rel=1e-6)
    i_top, i_bot = np.argmax(ul), np.argmin(ul)
    assert gl[i_top] == pytest.approx(tip, rel=1e-6)
    assert gl[i_bot] == pytest.approx(-tip, rel=1e-6)
    # descending branch is the Masing image of the virgin curve: F = F_tip - 2 F0((A - u)/2)
    k = i_top + npc // 8
    expected = tip - 2 * _virgin(kd, fd, n, (amp - ul[k]) / 2)
    assert gl[k] == pytest.approx(expected, rel=1e-6)
    # symmetric loop: g(-u) on the ascending branch = -g(u) on the descending one
    k2 = (k + npc // 2) % npc
    assert gl[k2] == pytest.approx(-gl[k], rel=1e-5)
    area = _loop_area(u, g, npc)
    assert 0 < area < 4 * fd * amp
