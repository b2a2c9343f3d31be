"""Kinds the data cannot tell apart (issue 24: "where the data cannot tell two answers apart,
say so"): what the verdict states about a kind tie and what would separate the tied kinds
(`analysis.diagnose._separate`), and its JSON."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.diagnose import CandidateFit, KindAlternative, KindSeparation
from analysis.diagnose._report import _encompassed, _kind_tie
from analysis.diagnose._separate import equivalent_stiffness, separable


def test_equivalent_stiffness_along_the_measured_deformation():
    """A cubic's grows with the square of the scale (``p s^2 <u^4> / <u^2>``, exact); a gap
    the deformation never closes has none; a stiffness error is its own constant."""
    u = np.random.default_rng(1).standard_normal(4096) * 1e-3
    s = np.array([1.0, 1.5, 2.0])
    k = equivalent_stiffness("cubic_spring", {"p": 3e9}, u, s)
    assert k == pytest.approx(3e9 * s ** 2 * np.mean(u ** 4) / np.mean(u ** 2), rel=1e-12)
    gap = equivalent_stiffness("gap", {"k": 5e4, "g": 10 * np.abs(u).max()}, u, s)
    assert np.all(gap == 0.0)
    assert np.all(equivalent_stiffness("stiffness_error", {"delta_stiffness": -40.0}, u, s)
                  == -40.0)
    assert separable("gap") and separable("stiffness_error")
    assert not separable("stick_slip") and not separable("quadratic_damping")
    assert not separable("mass_error")


SEP = KindSeparation(12.0, 24826.0, 2825.0, 1.5, 22783.0, (41042.0, 29401.0), 1.52)
GAP = KindAlternative("gap", (1,), ("1",), 362035.0, 1364.0, 29039.0, {"k": 5.95e4, "g": 1.67e-3},
                      {"k": (5.93e4, 5.97e4)}, 1.0, 24826.0, SEP)
CUBIC = CandidateFit("cubic_spring", (0.0, 1.0), (1,), ("1",), {"p": 2.74e9}, {},
                     evidence={"oos_gain": 358022.0, "oos_sd": 1371.0, "oos_left": 28840.0,
                               "estimator": "joint fit"}, alternatives=(GAP,))


def test_a_kind_tie_round_trips_with_both_sides_and_what_separates_them():
    """The alternative keeps its parameters, its side of the tie and the separation; the
    named entry carries its own side (and nothing else of its evidence); a result written
    before these keys reads back without them."""
    out = CUBIC.physics_json()
    assert out["evidence"] == {"oos_gain": 358022.0, "oos_sd": 1371.0, "oos_left": 28840.0}
    assert out["alternatives"][0]["separation"]["separating"] == 1.52
    back = CandidateFit.from_json(out)
    assert back.alternatives == (GAP,)
    old = {k: v for k, v in GAP.to_json().items()
           if k in ("kind", "dofs", "points", "oos_gain", "oos_sd", "bic")}
    assert KindAlternative.from_json(old) == KindAlternative("gap", (1,), ("1",), 362035.0,
                                                             1364.0, 29039.0)
    alone = CandidateFit("cubic_spring", (1.0,), (0,), None, {}, {}, evidence={"oos_gain": 1.0})
    assert "evidence" not in alone.physics_json()


def test_the_verdict_says_ambiguous_and_what_level_would_separate_them():
    text = _kind_tie(CUBIC)
    assert "Cubic spring and gap explain the data equally" in text
    assert "the kind is ambiguous" in text
    assert ("At 1.5 x the deformation of the highest fitting level (12) the cubic spring and "
            "the gap predict equivalent stiffnesses 4.104e+04 and 2.94e+04 N/m") in text
    assert "a misfit of 2.28e+04 (at the level itself 2.82e+03) against the 2.48e+04" in text
    assert "about 1.5 x as far (about 18.2" in text
    never = KindAlternative("gap", (1,), ("1",), 362035.0, 1364.0, 29039.0,
                            separation=KindSeparation(12.0, 2e4, 10.0, 1.5, 20.0, (1.0, 1.0),
                                                      None))
    text = _kind_tie(CandidateFit("cubic_spring", (1.0,), (1,), None, {}, {},
                                  alternatives=(never,)))
    assert "up to 4 x that deformation their FRFs stay within it" in text
    unknown = KindAlternative("hysteresis", (1,), ("1",), 1.0, 1.0, 1.0)
    text = _kind_tie(CandidateFit("stick_slip", (1.0,), (1,), None, {}, {},
                                  alternatives=(unknown,)))
    assert "A level beyond the fitted ones would separate them." in text


def test_a_tie_the_data_break_names_the_encompassing_kind_and_why():
    c = CandidateFit("cubic_spring", (1.0,), (0,), ("0",), {"p": 2e8}, {},
                     evidence={"encompasses": "quadratic_spring, gap"})
    text = _encompassed(c)
    assert text.startswith(" The cubic spring is named over the quadratic spring and the gap, "
                           "whose out-of-sample gains tie with its: added to the model holding "
                           "any of them the cubic spring still wins out of sample")
    assert _kind_tie(c) == "" and _encompassed(CUBIC) == ""
