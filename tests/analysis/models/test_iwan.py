"""The four-parameter Iwan joint (Segalman 2005) against its closed forms and against the
parallel Jenkins sliders it stands for."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.models import Element, Model, restoring_force

P = {"kd": 2.4e7, "fd": 246.0, "chi": -0.5, "beta": 0.5}


def _constants(kd, fd, chi, beta):
    """``phi_max``, ``R`` and ``S`` of the slider-strength density (Segalman 2005, eq 8-10)."""
    c = (chi + 1) / (chi + 2)
    phi_max = fd * (1 + beta) / (kd * (beta + c))
    r = fd * (chi + 1) / (phi_max ** (chi + 2) * (beta + c))
    return phi_max, r, fd / phi_max * beta / (beta + c)


def _cycles(amplitude, cycles=3, n_per_cycle=20000):
    t = np.linspace(0.0, 2 * np.pi * cycles, cycles * n_per_cycle + 1)
    return amplitude * np.sin(t), amplitude * np.cos(t)


def _last_cycle_area(u, g, n_per_cycle=20000):
    """Energy dissipated over the last cycle, ``oint g du`` (trapezoids)."""
    u, g = u[-n_per_cycle - 1:], g[-n_per_cycle - 1:]
    return float(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(u)))


def test_small_amplitude_is_the_stuck_stiffness():
    """Below ``phi_max`` the secant stiffness is ``kd - R A^(chi+1) / ((chi+1)(chi+2))``:
    ``kd`` to within ``(A / phi_max)^(chi+1)`` as the amplitude shrinks."""
    phi_max, r, _ = _constants(**P)
    for a in (1e-6 * phi_max, 1e-3 * phi_max):
        g, _ = restoring_force("iwan", P, np.array([a]), np.array([1.0]))
        exact = P["kd"] - r * a ** 0.5 / (0.5 * 1.5)
        assert g[0] / a == pytest.approx(exact, rel=1e-12)
        assert abs(g[0] / a / P["kd"] - 1) < 2 * (a / phi_max) ** 0.5


def test_large_amplitude_is_coulomb_with_the_total_slip_force():
    """Beyond ``phi_max`` every slider slips: the force is ``+-fd`` (a Coulomb element), and the
    dissipation per cycle tends to ``4 fd A`` (less the elastic part, ``O(fd phi_max)``)."""
    phi_max, _, _ = _constants(**P)
    a = 50 * phi_max
    u, v = _cycles(a)
    g, _ = restoring_force("iwan", P, u, v)
    slipping = u * v > 0        # moving out from zero: over a (> 2 phi_max) past a reversal
    slipping[:20000] = False    # (the first cycle starts on the virgin curve)
    np.testing.assert_allclose(g[slipping], P["fd"] * np.sign(v[slipping]), rtol=1e-12)
    d = _last_cycle_area(u, g)
    assert 1 - 4 * phi_max / a < d / (4 * P["fd"] * a) < 1


@pytest.mark.parametrize("chi,beta", [(-0.5, 0.5), (-0.2, 0.0), (-0.8, 2.0)])
def test_dissipation_per_cycle_is_segalmans_power_law(chi, beta):
    """Below ``phi_max``: ``D = 4 R A^(chi+3) / ((chi+2)(chi+3))`` (Segalman 2005, eq 14), a
    power law of exponent ``chi + 3``; the trapezoid rule over 20000 samples per cycle is
    within 1e-6 of it."""
    p = dict(P, chi=chi, beta=beta)
    phi_max, r, _ = _constants(**p)
    amps = phi_max * np.array([0.01, 0.1, 0.5])
    d = []
    for a in amps:
        u, v = _cycles(a)
        g, _ = restoring_force("iwan", p, u, v)
        d.append(_last_cycle_area(u, g))
    exact = 4 * r * amps ** (chi + 3) / ((chi + 2) * (chi + 3))
    np.testing.assert_allclose(d, exact, rtol=1e-6)
    slope = np.polyfit(np.log(amps), np.log(d), 1)[0]
    assert slope == pytest.approx(chi + 3, abs=1e-6)


def _jenkins_sliders(p, n):
    """The density as ``n`` parallel Jenkins elements (each bin's stiffness and mean slip
    displacement integrated exactly) plus the Dirac slider at ``phi_max``."""
    phi_max, r, s = _constants(**p)
    chi = p["chi"]
    edges = phi_max * np.linspace(0.0, 1.0, n + 1) ** 2     # finer where the density peaks
    k = r * np.diff(edges ** (chi + 1)) / (chi + 1)
    phi = r * np.diff(edges ** (chi + 2)) / (chi + 2) / k
    return np.append(k, s), np.append(phi, phi_max)


def test_periodic_cycles_are_the_parallel_jenkins_sliders():
    """Over a sine in micro- and macroslip the law is the sum of 4000 stick_slip sliders
    drawn from its density (Masing branches are exact for the sliders' periodic state); the
    remaining difference is the sliders' binning, below 1e-4 of ``fd``."""
    k, phi = _jenkins_sliders(P, 4000)
    phi_max, _, _ = _constants(**P)
    for a in (0.3 * phi_max, 3 * phi_max):
        u, v = _cycles(a, cycles=2, n_per_cycle=2000)
        g, _ = restoring_force("iwan", P, u, v)
        total = np.zeros_like(u)
        for kk, ph in zip(k, phi):
            total += restoring_force("stick_slip", {"kd": kk, "fd": kk * ph}, u, v)[0]
        assert np.max(np.abs(g - total)) < 1e-4 * P["fd"]


def test_model_file_round_trip(tmp_path):
    text = ("[linear]\nmass = [[10.0]]\ndamping = [[126.0]]\nstiffness = [[4.0e6]]\n\n"
            "[[element]]\nkind = \"iwan\"\nw = [1.0]\nkd = 2.4e7\nfd = 246.0\nchi = -0.5\n"
            "beta = 0.5\n")
    (tmp_path / "iwan.toml").write_text(text)
    model = Model.load(tmp_path / "iwan.toml")
    assert model.elements[0].kind == "iwan" and model.elements[0].params == P
    model.save(tmp_path / "back.toml")
    assert Model.load(tmp_path / "back.toml").to_dict() == model.to_dict()
    candidate = model.with_elements([Element("iwan", [1.0], {"kd": 2.4e7})])
    assert candidate.elements[0].missing == ["fd", "chi", "beta"]


@pytest.mark.parametrize("entry,match", [("chi = -1.0", "chi"), ("chi = 1e3", "chi"),
                                         ("beta = -0.1", "beta")])
def test_out_of_range_parameters_are_named(tmp_path, entry, match):
    from analysis.errors import ModelError
    text = ("[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstiffness = [[1e4]]\n\n"
            "[[element]]\nkind = \"iwan\"\n"
            f"w = [1.0]\nkd = 1e5\nfd = 1.0\n{entry}\n")
    (tmp_path / "m.toml").write_text(text)
    with pytest.raises(ModelError, match=f"{match} = .* is outside"):
        Model.load(tmp_path / "m.toml")
