"""One selection principle (`analysis.diagnose._outofsample`): candidates judged out of sample
with their uncertainty, a linear correction kept jointly where the data support it.

The regression of issue 24's real Duffing circuit: a start model whose linear part is off at
every level (its stiffness 5 % low) and a missing cubic spring. The cubic must be named, with
the stiffness correction beside it, not a gap (the former "no correction may worsen a level"
veto rejected the cubic for worsening the lowest level and named a gap instead).
"""

from __future__ import annotations

import numpy as np
import pytest

import diagnose_zoo as Z
from analysis.diagnose import CandidateFit, KindAlternative
from analysis.diagnose._compare import LevelFRF
from analysis.diagnose._outofsample import (Z as OOS_Z, Predictor, Score, halves, reference,
                                            score, tied)
from analysis.diagnose._report import _kind_tie

STIFF = 0.05 * 2.0e4
"""The start model's stiffness error: 5 % of the SDOF's 2e4 N/m."""


def _linear_part_off(kind: str, exc: Z.Excitation, seed: int) -> Z.Built:
    truth_lin = Z.sdof()
    cubic = Z.strength("cubic_spring", truth_lin, ("0",), 0, exc)
    off = Z.Effect("stiffness_error", ("0",), {"delta_stiffness": STIFF})
    truth = truth_lin.with_elements(Z.elements_of(truth_lin, (cubic,)))
    return Z.Built(Z._start(truth_lin, (cubic, off)), Z.lumped_runs(truth, 0, exc, kind, seed))


def _case(kind: str, exc: Z.Excitation, seed: int) -> Z.ZooCase:
    cubic = Z.strength("cubic_spring", Z.sdof(), ("0",), 0, exc)
    off = Z.Effect("stiffness_error", ("0",), {"delta_stiffness": STIFF}, ("delta_stiffness",))
    truth = Z.Truth((cubic, off), Z.HELD_BACK, "the truth's linear part, stiffness 5 % low")
    return Z.ZooCase(f"sdof-cubic+stiffness-{Z.SHORT[kind]}-{exc.kind}", "SDOF",
                     f"{Z.SHORT[kind]}, all", exc.kind, truth,
                     lambda: _linear_part_off(kind, exc, seed), ("0",))


@pytest.mark.parametrize("kind, exc, seed", [("displacement", Z.RANDOM, 11),
                                             ("acceleration", Z.MULTISINE, 12)],
                         ids=["disp-random", "acc-multisine"])
def test_a_cubic_behind_a_linear_error_is_named_with_the_correction(kind, exc, seed):
    case = _case(kind, exc, seed)
    built = case.build()
    from analysis.diagnose import diagnose
    from analysis.recordings import model_at_sensors, one_kind
    recs = [one_kind(r) for r in built.recordings]
    d = diagnose(model_at_sensors(built.start, recs, "diagnose"), recs)
    low = min(d.fit.levels, key=lambda lv: lv.level)
    assert low.before > 3 * low.floor.limit          # the linear part misfits the lowest level
    out = Z.score(case, Z.result_json(d))
    assert out.family_right and out.location == "right", (d.verdict, out.found)
    assert "gap@0" not in out.found
    assert out.params_ok, out.param_errors
    held = [lv for lv in d.fit.levels if lv.held_back]
    assert held and all(lv.within_floor for lv in held), [(lv.after, lv.floor.limit)
                                                         for lv in held]
    if exc is Z.RANDOM:
        # Issue 24: cubic, quadratic and gap gain within 0.75 % of each other out of sample
        # (122193 / 121925 / 121275, deviations ~700), but the cubic encompasses both: added
        # to the model holding either it still wins out of sample, neither does added to the
        # model holding it (session 32): the data tell them apart, the cubic is named alone.
        cubic = next(c for c in d.chosen if c.kind == "cubic_spring")
        assert cubic.alternatives == ()
        assert cubic.evidence["encompasses"] == "quadratic_spring, gap"
        assert ("The cubic spring is named over the quadratic spring and the gap, whose "
                "out-of-sample gains tie with its") in d.explanation
        assert not any("the kind is ambiguous" in w for w in d.warnings)


# --- the score itself on synthetic level FRFs --------------------------------------------------

def _levels(effect: list[float], n: int = 400, noise: float = 0.01, seed: int = 3):
    """One-input, one-output 'levels' whose measured FRF is ``1 + e_l b(f)`` with a known
    basis ``b`` (the candidate's FRF change per unit coefficient) and complex noise of
    relative standard deviation ``noise``."""
    rng = np.random.default_rng(seed)
    f = np.linspace(1.0, 100.0, n)
    b = (np.exp(-((f - 40.0) / 15.0) ** 2) + 0.3j * np.sin(f / 9.0))[:, None, None]
    out = []
    for lv, e in enumerate(effect):
        var = np.full((n, 1, 1), noise ** 2)
        H = 1.0 + e * b + noise * (rng.standard_normal((n, 1, 1))
                                   + 1j * rng.standard_normal((n, 1, 1))) / np.sqrt(2)
        out.append(LevelFRF(f"level {lv}", float(lv + 1), f, H, np.ones((n, 1, 1)), var,
                            np.ones((1, 1))))
    return out, b


def _pred(levels, b, theta: float) -> Predictor:
    return Predictor(lambda t: [1.0 + t[0] * b for _ in levels], np.array([theta]), 1,
                     np.array([1.0]))


def _fit(levels, b) -> float:
    num = sum(np.sum(np.conj(b) * (lf.H - 1.0)).real for lf in levels)
    return float(num / (len(levels) * np.sum(np.abs(b) ** 2)))


def test_a_consistent_effect_wins_noise_does_not():
    levels, b = _levels([0.05, 0.05, 0.05])
    H0 = [np.ones_like(lf.H) for lf in levels]
    s = score(levels, H0, _pred(levels, b, _fit(levels, b)))
    assert s.wins and s.gain > OOS_Z * s.sd and s.distinct
    assert all(g > 0 for g in s.level_gain)
    quiet, b = _levels([0.0, 0.0, 0.0], seed=5)
    s0 = score(quiet, H0, _pred(quiet, b, _fit(quiet, b)))
    assert not s0.wins
    # Out of sample, fitting noise does not pay: the expected gain is about -1 per fold.
    assert s0.gain < OOS_Z * s0.sd


def test_an_effect_that_fits_some_levels_and_harms_another_loses():
    """A constant correction fitted to levels that disagree (the structure changed between
    runs): level 1, predicted from the others, gets worse beyond its uncertainty."""
    levels, b = _levels([0.1, -0.1, 0.1])
    H0 = [np.ones_like(lf.H) for lf in levels]
    s = score(levels, H0, _pred(levels, b, _fit(levels, b)))
    assert s.harmed == 1 and not s.wins
    assert "predicts level 1 worse" in s.reason([lf.label for lf in levels])


def test_an_effect_seen_at_one_level_only_is_confirmed_within_that_level():
    """A clearance closing only at the top level: no other level identifies it (no claim
    there), its two halves confirm it."""
    levels, b = _levels([0.0, 0.0, 0.1])
    H0 = [np.ones_like(lf.H) for lf in levels]
    theta = float(np.sum(np.conj(b) * (levels[2].H - 1.0)).real / np.sum(np.abs(b) ** 2))

    def predict(t):
        return [np.ones_like(levels[0].H), np.ones_like(levels[1].H), 1.0 + t[0] * b]
    s = score(levels, H0, Predictor(predict, np.array([theta]), 1, np.array([1.0])))
    assert s.wins
    assert s.level_gain[:2] == (0.0, 0.0) and s.level_gain[2] == 0.0   # no other level fits it


def test_halves_alternate_in_runs():
    side = halves(64)
    assert side.tolist()[:17] == [0] * 8 + [1] * 8 + [0]
    assert halves(6).tolist() == [0, 1, 0, 1, 0, 1]


# --- model-form error: what a further effect must beat ------------------------------------

def test_an_effect_explaining_a_minority_of_a_systematic_misfit_loses():
    """A systematic misfit of another shape (model-form error, not noise) beside a small real
    change along the candidate: the candidate's gain is far beyond its noise deviation, but
    smaller than the misfit it leaves beyond the noise, so it does not win; alone (no
    systematic misfit) the same candidate wins."""
    levels, b = _levels([0.02, 0.02, 0.02], seed=7)
    f = levels[0].freqs[:, None, None]
    other = 0.1 * np.exp(-((f - 70.0) / 10.0) ** 2)          # not in the candidate's span
    skewed = [LevelFRF(lf.label, lf.level, lf.freqs, lf.H + other, lf.weight, lf.var,
                       lf.bin_factor) for lf in levels]
    H0 = [np.ones_like(lf.H) for lf in levels]
    s = score(skewed, H0, _pred(skewed, b, _fit(skewed, b)))
    assert s.distinct and s.gain > OOS_Z * s.sd and s.harmed is None
    assert s.left > s.gain and not s.wins
    assert "model-form error" in s.reason([lf.label for lf in skewed])
    clean = score(levels, H0, _pred(levels, b, _fit(levels, b)))
    assert clean.wins and clean.left == 0.0


def test_a_start_models_own_misfit_at_every_level_is_the_scale_not_a_veto():
    """gvt-cubic-tip in small: the start model misfits every level by the same systematic
    error (its own model-form error, level-independent, at the noise's order) and the effect
    grows with level. Against the noise alone the candidate leaves more than it gains (the
    former veto); against the misfit the start model shows where it is declared within its
    floor (the lowest level), the effect wins and gains beyond its scaled deviation. A
    candidate along a share of the start model's own error gains less than the effect (the
    effect is the one accepted) and, judged against the noise alone as a further effect is,
    leaves more than it gains."""
    levels, b = _levels([0.0, 0.01, 0.03], seed=9)
    f = levels[0].freqs[:, None, None]
    own = 0.01 * np.exp(1j * f / 5.0)                        # about the noise's size
    start = [LevelFRF(lf.label, lf.level, lf.freqs, lf.H + own, lf.weight, lf.var,
                      lf.bin_factor) for lf in levels]
    H0 = [np.ones_like(lf.H) for lf in start]
    law = (0.0, 1.0, 3.0)                                   # the effect's amplitude law

    def cubic() -> Predictor:
        t = sum(np.sum(np.conj(a * b) * (lf.H - 1.0)).real for a, lf in zip(law, start))
        t /= sum(a * a for a in law) * np.sum(np.abs(b) ** 2)
        return Predictor(lambda t: [1.0 + t[0] * a * b for a in law], np.array([t]), 1,
                         np.array([1.0]))
    alone = score(start, H0, cubic())
    assert alone.gain > OOS_Z * alone.sd and alone.left > alone.gain and not alone.wins
    ref = reference(start, H0, [True, False, False])
    assert 1.7 < ref < 2.3               # the lowest level's reduced misfit: noise + own error
    s = score(start, H0, cubic(), ref)
    assert s.ref == ref and s.deviation > s.sd
    assert s.wins and s.gain > s.left
    # a candidate along a part of the start model's own error: a share of that error
    other = np.where(f < 35.0, own, 0.0) / 0.01
    along = Predictor(lambda t: [1.0 + t[0] * other for _ in start], np.array([1.0]), 1,
                      np.array([1.0]))
    assert score(start, H0, along, ref).gain < s.gain
    further = score(start, H0, along)
    assert further.gain > OOS_Z * further.sd and further.left > further.gain
    assert not further.wins
    assert reference(start, H0, [False, False, False]) == 1.0     # no level within: noise


def test_within_every_floor_a_misfit_that_changes_with_level_is_still_sought():
    """`policy.residual_dependent`: the homogeneity test on the residuals of the lowest and
    highest fitting level. A linear model of a structure whose FRF moves with level leaves
    residuals that move with it (a nonlinear candidate is sought, however small the misfit
    against the floors); a model that follows each level leaves noise that does not."""
    from types import SimpleNamespace

    from analysis.diagnose._policy import residual_dependent
    levels, b = _levels([0.0, 0.02], seed=4)
    linear = SimpleNamespace(levels=levels, H0s=[np.ones_like(lf.H) for lf in levels])
    assert residual_dependent(linear)
    follows = SimpleNamespace(levels=levels, H0s=[1.0 + e * b for e in (0.0, 0.02)])
    assert not residual_dependent(follows)
    flat, _ = _levels([0.01, 0.01], seed=4)
    assert not residual_dependent(SimpleNamespace(levels=flat,
                                                  H0s=[np.ones_like(lf.H) for lf in flat]))


def test_kinds_tie_within_their_uncertainty_or_the_misfit_left():
    a = Score(1000.0, 10.0, (), (), True)
    assert tied(a, Score(960.0, 10.0, (), (), True))             # 40 < 3.72 * 14.1
    assert not tied(a, Score(900.0, 10.0, (), (), True))         # 100 > 52.6
    # the better one leaves 80 beyond the noise: 100 apart is not a tie; leaving 120 it is
    assert not tied(Score(1000.0, 10.0, (), (), True, left=80.0),
                    Score(900.0, 10.0, (), (), True, left=180.0))
    assert tied(Score(1000.0, 10.0, (), (), True, left=120.0),
                Score(900.0, 10.0, (), (), True, left=220.0))


def test_a_kind_alternative_round_trips_and_is_explained_from_the_numbers():
    alts = (KindAlternative("quadratic_spring", (0,), ("0",), 121925.0, 702.0, 2563.0),
            KindAlternative("gap", (0,), ("0",), 121275.0, 703.0, 3215.0))
    c = CandidateFit("cubic_spring", (1.0,), (0,), ("0",), {"p": 2e8}, {},
                     evidence={"oos_gain": 122193.0}, alternatives=alts)
    back = CandidateFit.from_json(c.physics_json())
    assert back.alternatives == alts
    assert "alternatives" not in CandidateFit.from_json(c.physics_json()).to_json()
    text = _kind_tie(c)
    assert "Cubic spring, quadratic spring and gap explain the data equally" in text
    assert "1.222e+05, 1.219e+05, 1.213e+05: within 0.75 %" in text
    assert "The cubic spring is named" in text
    assert _kind_tie(CandidateFit("gap", (1.0,), (0,), None, {}, {})) == ""


def _scored(gain: float, correction: tuple[float, float] | None = None) -> Score:
    """A score of deviation 100 (chi2 units), with a joint correction's interval when given."""
    if correction is None:
        return Score(gain, 100.0, (), (), True)
    return Score(gain, 100.0, (), (), True, joint=sum(correction) / 2,
                 estimate=(1.0, sum(correction) / 2), interval=((0.5, 1.5), correction))


def test_a_joint_correction_is_kept_only_where_the_data_support_it():
    """`policy.supported`: the correction distinguishable from zero, and the pair better out
    of sample, beyond the two's uncertainty (Z x 141 = 526), than the candidate alone and
    than every candidate winning alone with fewer parameters."""
    from analysis.diagnose._policy import supported
    assert supported(_scored(1000.0), _scored(2000.0, (-700.0, -600.0)), [])
    assert not supported(_scored(1000.0), _scored(2000.0, (0.0, 0.0)), [])   # not distinct
    assert not supported(_scored(1000.0), _scored(1400.0, (-700.0, -600.0)), [])   # tied
    # a simpler candidate explaining as much: the correction is not needed
    assert not supported(_scored(1000.0), _scored(2000.0, (-700.0, -600.0)), [_scored(1900.0)])
    assert supported(_scored(1000.0), _scored(2000.0, (-700.0, -600.0)), [_scored(1400.0)])


def test_a_further_candidate_is_not_credited_with_the_earlier_effects_refit():
    """The misfit left is an earlier effect's estimation error (``0.05 b``, its scale free as
    nuisance); a candidate of another shape ``c`` scored with it gains only within noise from
    the earlier effect refitted alone (`outofsample.refitted`), though about 60 deviations
    from the current model."""
    from analysis.diagnose._outofsample import refitted
    levels, b = _levels([0.05, 0.05, 0.05])
    c = np.cos(levels[0].freqs / 7.0)[:, None, None] + 0j
    pred = Predictor(lambda t: [1.0 + t[0] * c + t[1] * b for _ in levels], np.array([0.0, 0.0]),
                     1, np.array([1.0, 1.0]))
    H0 = [np.ones_like(lf.H) for lf in levels]
    s0 = score(levels, H0, pred)
    assert s0.gain > 10 * OOS_Z * s0.sd and not s0.distinct   # its own shape: no claim
    base = refitted(levels, pred)
    np.testing.assert_allclose(base[0], 1.0 + _fit(levels, b) * b, rtol=1e-9)
    s = score(levels, base, pred)
    assert abs(s.gain) < OOS_Z * s.sd and not s.wins
