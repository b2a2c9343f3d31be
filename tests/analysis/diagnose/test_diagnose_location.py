"""Joints vs supports: the location table scores every pair beside the grounded points, the
alternatives the data cannot separate, and the explanation's wording (issue 24 item 2).

The table and the alternatives are checked on a hand-made search (its FRFs and fits set
exactly, so every number is known); `test_support_*` run the diagnosis itself.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from analysis.diagnose import Alternative, Location, LocationRow, diagnose
from analysis.diagnose._select import Fit
from analysis.diagnose._where import (RIGID, SEPARATE, alternatives, location_table,
                                     relative_motion)
from analysis.models import Candidate, Element, Support

from diagnose_scenarios import chain, random_runs

NAMES = ("drive", "wing", "payload")
SPREAD = 0.04
"""Relative motion of the payload over the wing in the hand-made search."""


def _lf(kind_order: int = 0):
    f = np.linspace(2.0, 15.0, 50)
    wing = 1.0 / (1.0 + 1j * f)
    H = np.stack([2.0 * wing, wing, (1.0 + SPREAD) * wing], axis=1)[:, :, None]
    B = np.array([[1.0], [0.0], [0.0]])
    return SimpleNamespace(freqs=f, H=H, kind_order=kind_order, B=B, level=12.0,
                           label="12 N")


def _fit(kind: str, dofs: tuple[int, ...], bic: float) -> Fit:
    c = Candidate(kind, dofs, 3, names=NAMES)
    return Fit(c, {"p": 1.0}, {}, 1000.0 - bic, bic)


class FakeSearch:
    """What the table and the alternatives read of a search: levels, chi2_0, screen()."""

    def __init__(self, fits: list[Fit]) -> None:
        self.levels, self.chi2_0, self._fits = [_lf()], 1000.0, fits

    def screen(self) -> list[Fit]:
        return sorted(self._fits, key=lambda f: -f.delta_bic)


def test_relative_motion_is_the_rms_difference_over_the_larger_rms():
    lf = _lf()
    assert relative_motion(lf, 1, 2) == pytest.approx(SPREAD / (1 + SPREAD), rel=1e-12)
    assert relative_motion(lf, 0, 1) == pytest.approx(0.5, rel=1e-12)
    # the recorded kind weighs every line alike here (a common factor per line cancels)
    assert relative_motion(_lf(2), 1, 2) == pytest.approx(SPREAD / (1 + SPREAD), rel=1e-12)


def test_every_pair_is_scored_beside_the_grounded_points():
    screen = [_fit("stick_slip", (1,), 500.0), _fit("stick_slip", (1, 2), 60.0),
              _fit("cubic_spring", (0,), 20.0), _fit("cubic_spring", (0, 1), -4.0),
              _fit("cubic_spring", (0, 2), -8.0), _fit("cubic_spring", (2,), 3.0)]
    search = FakeSearch(screen)
    pool = [_fit("stick_slip", (1,), 510.0)]     # the refined shortlist holds no pair
    rows = location_table(search, pool)
    assert [r.dofs for r in rows] == [(1,), (1, 2), (0,), (2,), (0, 1), (0, 2)]
    assert rows[0].delta_bic == 510.0            # the pool's refined fit where it has one
    joint = rows[1]
    assert joint.relative_motion == pytest.approx(SPREAD / (1 + SPREAD))
    assert joint.best_grounded_end.points == ("wing",)
    wing = rows[0].best_joint
    assert wing.points == ("wing", "payload") and wing.delta_bic == 60.0
    assert wing.chi2_reduction == pytest.approx(0.06)
    back = [LocationRow.from_json(r.to_json()) for r in rows]
    assert back == list(rows)


def test_support_named_where_the_joint_sensors_move_together_is_ambiguous():
    screen = [_fit("stick_slip", (1,), 500.0), _fit("stick_slip", (1, 2), 60.0),
              _fit("cubic_spring", (0,), 30.0), _fit("cubic_spring", (0, 1), -4.0)]
    search = FakeSearch(screen)
    (alt,) = alternatives(search, screen, screen[0])
    assert alt.points == ("wing", "payload") and alt.kind == "stick_slip"
    assert alt.relative_motion == pytest.approx(SPREAD / (1 + SPREAD))
    assert "within 3.8 %" in alt.why_not_separable
    assert f"exceeds {100 * RIGID:.0f} %" in alt.separate_by
    assert "drive at wing or payload" in alt.separate_by   # neither side is driven
    assert Location.from_json(Location((1,), ("wing",), None, (alt,)).to_json()).alternatives \
        == (alt,)


def test_close_scores_are_ambiguous_far_ones_are_not():
    near = [_fit("cubic_spring", (0,), 500.0),
            _fit("cubic_spring", (0, 1), 500.0 - 0.5 * SEPARATE),
            _fit("cubic_spring", (2,), 500.0 - 3 * SEPARATE)]
    (alt,) = alternatives(FakeSearch(near), near, near[0])
    assert alt.points == ("drive", "wing")
    assert "within the 10 needed" in alt.why_not_separable
    assert "at wing" in alt.separate_by
    # a clear winner, no sensors moving together: nothing to list
    far = [_fit("cubic_spring", (0,), 500.0), _fit("cubic_spring", (0, 1), 400.0)]
    assert alternatives(FakeSearch(far), far, far[0]) == ()


def test_alternatives_keep_to_the_chosen_class():
    """A linear error is compared with linear errors only."""
    fits = [_fit("stiffness_error", (1,), 500.0), _fit("stick_slip", (1, 2), 495.0),
            _fit("stiffness_error", (1, 2), -20.0)]
    assert alternatives(FakeSearch(fits), fits, fits[0]) == ()


# ---------------------------------------------------------------------------------------------
# the diagnosis with [support]


@pytest.fixture(scope="module")
def grounded_cubic():
    """2-DOF chain grounded at DOF 0, a hardening cubic spring from DOF 1 to ground."""
    base = chain([1.0, 0.8], [2.0e4], [1.5e4, 0.0])
    truth = base.with_elements([Element("cubic_spring", [0, 1.0], {"p": 3e9})])
    return base, random_runs(truth, 0, [1.0, 6.0, 12.0], n=1 << 14, seed=5)


def test_support_declared_elsewhere_leaves_no_grounded_element_at_the_point(grounded_cubic):
    base, recs = grounded_cubic
    free = base.with_elements([])
    free.support = Support(free=True)
    d = diagnose(free, recs)
    assert all(len(c.dofs) == 2 or c.kind.endswith("_error") for c in d.ranking)
    assert "free or suspended ([support] free = true)" in d.explanation
    rows = d.evidence.locations
    assert {r.dofs for r in rows} >= {(0, 1)}
    assert all(r.kind.endswith("_error") for r in rows if len(r.dofs) == 1)


@pytest.mark.slow
def test_support_at_the_point_finds_it(grounded_cubic):
    """The cubic at the declared support, named or stated as honestly tied (the issue's "or
    listed as an alternative with 'ambiguous'"): cubic and gap tie out of sample (gains
    3.580e5 and 3.620e5, within the misfit either leaves, 2.48e4), the cubic is named (its
    BIC on the fitting levels 28400 against the gap's 29039), and the verdict says the kind is
    ambiguous and which level would separate them: the two laws' FRFs differ by a misfit of
    2.8e3 at the highest level, within the tie, and by 2.3e4 at 1.5x its deformation (1.52x,
    about 18 N, separates them). No further effect: on an earlier state three followed whose
    reported 95 % intervals held zero (docs/diagnose.md, "Session 32: pruning on the
    reported intervals")."""
    import diagnose_zoo as Z
    base, recs = grounded_cubic
    held = base.with_elements([])
    held.support = Support((1,))
    d = diagnose(held, recs)
    assert d.verdict == "discrepancy"
    assert "supported at 1 ([support])" in d.explanation
    assert "the support at DOF 1" in d.explanation
    found = d.to_json()["missing_physics"]
    assert len(found) == 1
    first = found[0]
    assert first["dofs"] == [1]
    tied = [a for a in first.get("alternatives", []) if Z.real_tie(first["evidence"], a)]
    assert first["kind"] == "cubic_spring" or [a["kind"] for a in tied] == ["cubic_spring"]
    assert {a["kind"] for a in tied} == {a["kind"] for a in first.get("alternatives", [])}
    if tied:
        assert "the kind is ambiguous" in d.explanation
        for a in tied:
            sep = a["separation"]
            # tied at the highest level, apart beyond it: a higher level separates them
            assert sep["difference"] <= sep["threshold"] and sep["separating"] > 1.0
            assert sep["difference_at"] > 4 * sep["difference"]


def test_explanation_says_ambiguous_and_names_the_joint_as_a_joint():
    from analysis.diagnose._report import _advice, _ambiguity
    screen = [_fit("stick_slip", (1,), 500.0), _fit("stick_slip", (1, 2), 60.0)]
    alts = alternatives(FakeSearch(screen), screen, screen[0])
    d = SimpleNamespace(location=Location((1,), ("wing",), None, alts))
    text = _ambiguity(screen[0].cand, d)
    assert text.startswith(" The location is ambiguous between the support at wing (the "
                           "element acts from wing to ground) and the joint between wing and "
                           "payload (stick slip):")
    assert "To separate them: a sensor pair across the joint between wing and payload" in text
    advice = _advice([screen[0].cand], alts)
    assert advice == ("the support at wing (the element acts from wing to ground), or "
                      "(ambiguous) the joint between wing and payload (stick slip)")
    assert _ambiguity(screen[0].cand, SimpleNamespace(location=Location((1,), None, None))) == ""


@pytest.mark.slow
def test_support_beside_a_stiff_joint_is_reported_ambiguous():
    """3-DOF chain whose DOFs 1 and 2 are joined by a stiff spring (they move within a few per
    cent of each other in the band), a hardening cubic from DOF 1 to ground: a hardening
    support is found at DOF 1 or 2, and the locations acting on nearly the same motion (the
    support at the other end, the joint 1-2) are listed as not separable, the truth among them
    (the zoo's "honestly ambiguous"), with the measurement that would separate them."""
    base = chain([1.0, 1.0, 0.5], [2.0e4, 1.0e6], [1.5e4, 0.0, 0.0])
    truth = base.with_elements([Element("cubic_spring", [0, 1.0, 0], {"p": 3e9})])
    recs = random_runs(truth, 0, [1.0, 6.0, 12.0], n=1 << 14, seed=5)
    d = diagnose(base, recs)
    (found,) = d.chosen[0].dofs
    assert d.verdict == "discrepancy" and not d.chosen[0].kind.endswith("_error")
    assert found in (1, 2), d.location
    alts = {a.points: a for a in d.location.alternatives}
    taken = {c.dofs for c in d.chosen}
    # a further effect found is no alternative
    assert not {tuple(int(p) for p in a) for a in alts} & taken
    assert found == 1 or ("1",) in alts or (1,) in taken, d.location
    assert ("1", "2") in alts or ("2",) in alts or ("1",) in alts, d.location
    for a in alts.values():
        assert a.relative_motion is not None and a.relative_motion < RIGID
        assert "a sensor pair across the joint between DOF 1 and DOF 2" in a.separate_by
    assert f"The location is ambiguous between the support at DOF {found}" in d.explanation
    assert any(w.startswith(f"the location is ambiguous between {found} and ")
               for w in d.warnings), d.warnings
    row = next(r for r in d.evidence.locations if r.dofs == (1, 2))
    assert row.relative_motion < RIGID and row.best_grounded_end is not None
