"""Concealed-effect scenarios on random data: verdict, kind, location, parameters, held-back fit.

The candidate library, search and thresholds are the same for every scenario; nothing here
tells the diagnosis what to look for.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.diagnose import diagnose
from analysis.diagnose.candidates import library

from diagnose_scenarios import (hidden_cubic, linear_mass_error, multisine_runs,
                                no_discrepancy, relative_damping)


def check(sc, d, rel_tol: float = 0.08) -> None:
    """Right verdict, kind, location, parameters and a held-back improvement by half."""
    assert d.verdict == sc.verdict, d.explanation
    if sc.level_dependent is not None:
        assert d.level_dependent == sc.level_dependent
    if sc.verdict == "adequate":
        assert d.missing_physics() == []
        assert d.fit["after"] == d.fit["before"]
        return
    (mp,) = d.missing_physics()
    assert mp["kind"] == sc.kind
    assert mp["dofs"] == sc.dofs
    assert d.location["dofs"] == sc.dofs
    for name, true in sc.params.items():
        assert mp["params"][name] == pytest.approx(true, rel=rel_tol), name
    assert d.fit["after"] <= 0.5 * d.fit["before"]
    assert d.fit["held_back"]


@pytest.fixture(scope="module")
def cubic():
    return hidden_cubic()


def test_hidden_grounded_cubic_at_unforced_dof(cubic):
    d = diagnose(cubic.start, cubic.recordings)
    check(cubic, d)
    lo, hi = d.location["band_hz"]
    assert lo < cubic.start.natural_frequencies()[0] < hi   # the stiffened first mode
    assert d.evidence["level_dependence"]["dependent"]


def test_relative_quadratic_damping_between_dofs():
    sc = relative_damping()
    check(sc, diagnose(sc.start, sc.recordings))


def test_level_independent_mass_error():
    sc = linear_mass_error()
    d = diagnose(sc.start, sc.recordings)
    check(sc, d)
    assert d.model.mass[1, 1] == pytest.approx(1.12, rel=0.02)


def test_adequate_model_gives_no_false_alarm():
    sc = no_discrepancy()
    d = diagnose(sc.start, sc.recordings)
    check(sc, d)
    assert "adequate" in d.explanation


def test_real_recording_issues_multisine_acceleration_dc():
    """Periodic multisine with start-up transient, DC offsets and acceleration sensors."""
    sc = linear_mass_error()
    recs = multisine_runs(sc.truth, 2, [3.0, 9.0, 27.0])
    assert all(abs(r.response.mean(axis=0)).min() > 0 for r in recs)
    d = diagnose(sc.start, recs)
    check(sc, d)


def test_held_back_segment_with_single_level(cubic):
    d = diagnose(cubic.start, cubic.recordings[-1:])
    assert d.level_dependent is None
    assert d.missing_physics()[0]["kind"] == "cubic_spring"
    assert d.missing_physics()[0]["dofs"] == [2]
    assert "segment" in d.fit["held_back"][0]


def test_library_is_the_same_cross_product_for_every_model():
    lib = library(3)
    assert len({(c.kind, c.dofs) for c in lib}) == len(lib)
    locs = {c.dofs for c in lib}
    assert locs == {(0,), (1,), (2,), (0, 1), (0, 2), (1, 2)}
    assert {c.kind for c in lib if c.dofs == (0, 1)} >= {"cubic_spring", "stick_slip",
                                                         "stiffness_error", "damping_error"}
    assert not any(c.kind == "mass_error" and len(c.dofs) == 2 for c in lib)
    assert np.allclose(next(c for c in lib if c.dofs == (0, 2)).w, [-1, 0, 1])
