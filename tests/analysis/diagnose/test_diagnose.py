"""Concealed-effect scenarios on random data: verdict, kind, location, parameters, held-back fit.

The candidate library, search and thresholds are the same for every scenario; nothing here
tells the diagnosis what to look for.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.diagnose import diagnose
from analysis.models import library

from analysis.diagnose._prepare import prepare_random
from analysis.diagnose._replay import horizon_samples, replay
from analysis.models import Element

from diagnose_scenarios import (TWO_EFFECTS_STIFFNESS, chain, hidden_cubic, linear_mass_error,
                                multisine_runs, no_discrepancy, random_runs, relative_damping,
                                three_effects, two_effects)


def check_residuals(d) -> None:
    """Time and frequency residuals per DOF and level in the JSON; time residual halves."""
    res = d.to_json()["residuals"]
    assert [r["label"] for r in res] == [c.label for c in d.curves]
    for r in res:
        for part in ("time", "frequency"):
            assert len(r[part]["before"]) == len(r[part]["after"]) == d.model.n_dof
    tr = d.fit.time_residual
    if d.verdict == "adequate":
        assert tr.after == tr.before
    else:
        assert tr.after <= 0.5 * tr.before


def check(sc, d, rel_tol: float = 0.08) -> None:
    """Right verdict, kind, location, parameters and a held-back improvement by half."""
    assert d.verdict == sc.verdict, d.explanation
    if sc.level_dependent is not None:
        assert d.level_dependent == sc.level_dependent
    check_residuals(d)
    if sc.verdict == "adequate":
        assert d.chosen == ()
        assert d.fit.after == d.fit.before
        return
    (mp,) = d.chosen
    assert mp.kind == sc.kind
    assert list(mp.dofs) == sc.dofs
    assert list(d.location.dofs) == sc.dofs
    for name, true in sc.params.items():
        assert mp.params[name] == pytest.approx(true, rel=rel_tol), name
    assert d.fit.after <= 0.5 * d.fit.before
    assert d.fit.held_back


@pytest.fixture(scope="module")
def cubic():
    """2^15 samples per level (measured with seeds 11-14: p -4.2 to -4.9 %, a bias of the
    shorter record, 2^16 gives -1.4 %; held-back 1.51 -> 0.075; half the time of 2^16)."""
    return hidden_cubic(n=1 << 15)


def test_hidden_grounded_cubic_at_unforced_dof(cubic):
    d = diagnose(cubic.start, cubic.recordings)
    check(cubic, d)
    lo, hi = d.location.band_hz
    assert lo < cubic.start.natural_frequencies()[0] < hi   # the stiffened first mode
    assert d.evidence.level_dependence.dependent


def test_relative_quadratic_damping_between_dofs():
    # 2^15 samples per level (measured: p -0.71 %, held-back 0.148 -> 0.035; 2^16: -0.11 %,
    # 0.140 -> 0.014, twice the time)
    sc = relative_damping(n=1 << 15)
    check(sc, diagnose(sc.start, sc.recordings))


def test_level_independent_mass_error():
    # 2^15 samples per level (measured: delta_mass -0.09 %, held-back 0.947 -> 0.031; half
    # the time of 2^16)
    sc = linear_mass_error(n=1 << 15)
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
    assert d.chosen[0].kind == "cubic_spring"
    assert d.chosen[0].dofs == (2,)
    assert "segment" in d.fit.held_back[0]


def test_library_is_the_same_cross_product_for_every_model():
    lib = library(3)
    assert len({(c.kind, c.dofs, c.compensated) for c in lib}) == len(lib)
    # sliders also with their stuck stiffness taken from the linear part, nothing else
    assert {c.kind for c in lib if c.compensated} == {"stick_slip", "hysteresis", "iwan"}
    locs = {c.dofs for c in lib}
    assert locs == {(0,), (1,), (2,), (0, 1), (0, 2), (1, 2)}
    assert {c.kind for c in lib if c.dofs == (0, 1)} >= {"cubic_spring", "stick_slip",
                                                         "stiffness_error", "damping_error"}
    assert not any(c.kind == "mass_error" and len(c.dofs) == 2 for c in lib)
    assert np.allclose(next(c for c in lib if c.dofs == (0, 2)).w, [-1, 0, 1])


def test_two_missing_effects_found_by_a_second_pass():
    """A cubic spring between DOFs and a linear stiffness error: both found, then refitted
    jointly (the first, sequential estimate of the linear error absorbs part of the cubic)."""
    sc = two_effects()
    d = diagnose(sc.start, sc.recordings)
    assert d.verdict == "discrepancy", d.explanation
    found = {(m.kind, m.dofs): m.params for m in d.chosen}
    assert set(found) == {("cubic_spring", (0, 1)), ("stiffness_error", (2,))}
    assert found[("cubic_spring", (0, 1))]["p"] == pytest.approx(sc.params["p"], rel=0.05)
    assert found[("stiffness_error", (2,))]["delta_stiffness"] == pytest.approx(
        TWO_EFFECTS_STIFFNESS, rel=0.05)
    # a third pass may stand in for the first estimate's sequential error; the joint refit
    # makes it irrelevant and it is pruned (measured: a -3 N/m stiffness at DOF 1)
    ev = d.evidence
    assert sum(p.accepted for p in ev.passes) - len(ev.pruned_after_joint_refit) == 2
    assert d.location.dofs == (0, 1, 2)
    assert d.fit.after <= 0.5 * d.fit.before
    check_residuals(d)


@pytest.mark.slow      # the multi-pass search and joint refit: test_two_missing_effects_...
def test_three_missing_effects():
    """The two effects above plus quadratic damping between DOFs 1 and 2: all three found
    by three passes and refitted jointly (measured: stiffness -0.4 %, cubic -0.2 %, damping
    +2.0 %; held-back error 1.48 -> 0.16)."""
    sc = three_effects()
    d = diagnose(sc.start, sc.recordings)
    found = {(m.kind, m.dofs): m.params for m in d.chosen}
    assert set(found) == {("cubic_spring", (0, 1)), ("stiffness_error", (2,)),
                          ("quadratic_damping", (1, 2))}
    assert found[("cubic_spring", (0, 1))]["p"] == pytest.approx(3.0e9, rel=0.05)
    assert found[("stiffness_error", (2,))]["delta_stiffness"] == pytest.approx(
        TWO_EFFECTS_STIFFNESS, rel=0.05)
    assert found[("quadratic_damping", (1, 2))]["p"] == pytest.approx(30.0, rel=0.1)
    assert d.fit.after <= 0.2 * d.fit.before


def test_replay_restarts_reproduce_the_exact_model():
    """Noise-free records: short-horizon replays of the true model match the measured motion
    (restart state and hold history rebuilt from the measured motion); the model without
    the effect does not."""
    sc = hidden_cubic(n=1 << 13)
    base = chain([1.5, 0.6], [1.0e4], [2.5e4, 0.0])
    friction = base.with_elements([Element("stick_slip", [-1.0, 1.0], {"kd": 8e3, "fd": 4.0})])
    for truth, start, level, tol in ((sc.truth, sc.start, 12.0, 5e-3),
                                     (friction, base, 10.0, 2e-2)):
        rec = random_runs(truth, 0, [level], n=1 << 13, noise=0.0)[0]
        p = prepare_random(rec, (2.0, 60.0), "noise-free")
        horizon = horizon_samples(truth, p.fs)
        exact, wrong = replay(truth, p, horizon), replay(start, p, horizon)
        assert exact.residual.max() < tol
        assert wrong.residual.min() > 10 * exact.residual.max()
        assert exact.t.size == exact.measured.shape[0] == exact.predicted.shape[0]


def test_unconfirmed_finding_is_flagged(tmp_path):
    """Two levels of a structure missing two effects: the held-back (lower) level barely
    exercises them. The tool may still name physics, but never silently: whenever the held-back
    error is not at least halved, a warning and a tentative explanation say so."""
    from pathlib import Path

    from analysis.models import Model
    from nlid_lab.campaign import run_campaign
    from nlid_lab.campaign import load_campaign
    from nlid_lab.formats import load_recordings

    examples = Path(__file__).resolve().parents[3] / "examples"
    run = tmp_path / "run.h5"
    run_campaign(load_campaign(examples / "campaign-sim-random.toml"), run)
    full = Model.load(examples / "models" / "sdof-cubic-quaddamp.toml")
    d = diagnose(full.with_elements([]), load_recordings(run))
    assert d.verdict == "discrepancy" and d.level_dependent
    confirmed = d.fit.after <= 0.5 * d.fit.before
    flagged = any("does not confirm" in w for w in d.warnings)
    assert confirmed != flagged
    assert flagged == ("tentative" in d.explanation)
