"""The diagnosis zoo (`diagnose_zoo`, issue 24): its cases are what they claim to be, its
scoring judges right from wrong, and each row's outcome today.

A row passes when the family is right, the location right (or listed as an alternative: an
honest "ambiguous"), the identifiable parameters within 5 % and, on a "none" row, no false
alarm. Rows the diagnosis gets wrong today are ``xfail(strict=True)`` with the measured
reason (`WRONG_TODAY`, from ``python benchmarks/bench_diagnose.py --zoo --workers 1``), so a
fix that makes one right flips it. The reduced zoo (`ZooCase.fast`) runs in ``make test``,
the whole zoo in ``make test-slow``.
"""

import dataclasses

import numpy as np
import pytest

import diagnose_zoo as Z
from analysis.recordings import ARTIFACTS

WRONG_TODAY: dict[str, str] = {
    "beam-cubic_tip-disp-random-few": "'adequate' up to level 12: every level lies within "
                                      "its floor (12 N: 0.287 against 0.301, the exact model "
                                      "0.177; held back 4 N: 0.0904 against 0.339, the exact "
                                      "model 0.0745) and the residuals' level dependence is "
                                      "p = 3.3e-4, not 1e-4: these recordings cannot show "
                                      "the cubic (the row's judging, docs/diagnose.md)",
    # session 33's rows (docs/diagnose.md, "Zoo, session 33: new scenarios"), measured per row
    "chain4-cubic3-disp-random-few-z7": "a cubic at unmeasured DOF 3 named as gap@1 (tied with "
                                        "cubic@1, gains 5.07e4 / 4.71e4) that makes the "
                                        "held-back level worse (0.499 -> 0.537); the "
                                        "candidates at DOF 2, through which it acts, are "
                                        "rejected by the worst-level gate (they predict "
                                        "level 12 worse fitted on the others)",
}
"""Row name -> what the diagnosis does wrong today, measured by ``python
benchmarks/bench_diagnose.py --zoo --workers 2`` on main after the model-form scale of further
effects, the kind ties and the gap's and slider's refit (docs/diagnose.md, Zoo, "Merged, session
29"); the slider rows since measured per row with memory laws run between the samples and the
periodic records' harmonics kept (docs/diagnose.md, "Sliders between the samples and above the
band"); the whole zoo again on main in session 30 (docs/diagnose.md, "Merged, session 30");
the accelerometer and slider rows again per row with the sensor-noise debiasing and the
second parameters' joint intervals (docs/diagnose.md, "Sensor noise debiased, second
parameters from the joint covariance");

``gvt-cubic-tip`` and ``beam-cubic_tip-disp-random-few`` per row in session 31 (``--only``,
docs/diagnose.md, "The start model's own misfit as the scale"); the whole zoo in session 32
with the second parameters' cluster jackknife: ``twin-gvt-hysteresis_joint-acc-multisine-mains``
left (fd +5.3 %, 95 % -0.3 .. +10.8 %: not identifiable to 5 %, as its realizations say,
-3.1 .. +9.6 %; docs/diagnose.md, "Session 32: intervals that cover"); the circuit rows right since
session 32 (the whole zoo, docs/diagnose.md, "Session 32: the circuit"), the clipping row right
since session 32 (clipped samples left out, "Session 32: clipped samples and fractional delays");
session 33's new rows (``-z7``) per row (``--only -z7``) and in the whole zoo with ``--workers 1``
(docs/diagnose.md, "Zoo, session 33: new scenarios")."""


def _param(case: Z.ZooCase):
    marks = [pytest.mark.xfail(strict=True, reason=WRONG_TODAY[case.name])
             ] if case.name in WRONG_TODAY else []
    if not case.fast:
        marks.append(pytest.mark.slow)
    return pytest.param(case, id=case.name, marks=marks)


def check_row(out: Z.Outcome) -> None:
    assert out.error is None, out.error
    if out.family == "none":
        assert not out.false_alarm, f"false alarm: {out.verdict}, named {out.found}"
        return
    assert out.family_right, f"{out.verdict}, named {out.found}"
    if out.verdict == "adequate":                # right only below the floors (`below_floor`)
        return
    assert out.location in ("right", "ambiguous"), f"named {out.found}"
    assert out.params_ok in (None, True), out.param_errors


@pytest.mark.parametrize("case", [_param(c) for c in Z.zoo()])
def test_zoo_row(case):
    check_row(Z.run_case(case))


# --- the zoo itself -----------------------------------------------------------------------


def test_zoo_covers_the_issue():
    """At least 40 cases over every structure, effect family, sensor set, excitation and
    artifact issue 24 names, each with a truth."""
    cases = Z.zoo()
    assert len(cases) >= 40 and len({c.name for c in cases}) == len(cases)
    kinds = {e.kind for c in cases for e in c.truth.effects}
    assert kinds >= {"cubic_spring", "quadratic_spring", "gap", "coulomb_friction",
                     "stick_slip", "hysteresis", "iwan", "quadratic_damping", "mass_error",
                     "stiffness_error", "damping_error"}
    assert any(len(c.truth.effects) == 2 for c in cases)
    assert sum(c.truth.family == "none" for c in cases) >= 6
    assert any(not c.truth.visible for c in cases)                      # gap not reached
    assert {c.excitation for c in cases} == {"random", "multisine", "stepped"}
    assert {c.sensors.split(",")[0] for c in cases} == {"disp", "vel", "acc"}
    assert any(c.sensors.endswith("all") for c in cases)
    assert any(" of " in c.sensors for c in cases)
    named = {a for c in cases for a in c.artifacts}
    assert named <= set(ARTIFACTS)                            # the catalogue's names
    assert set(ARTIFACTS) - named == {"dead-channel"}         # every artifact but a dead one
    assert set(Z.CATALOGUE) < set(ARTIFACTS) and any(set(c.artifacts) == set(Z.CATALOGUE)
                                                     for c in cases)
    fitted = [c for c in cases if c.truth.start.startswith("fit_linear on the lowest")]
    assert any(c.structure.startswith("SDOF") for c in fitted)            # the circuit
    assert {c.sensors.split(",")[0] for c in fitted if c.structure.startswith("SDOF")} == \
        {"disp", "acc"}
    structures = " ".join(c.structure for c in cases)
    for s in ("SDOF", "3-DOF chain", "FE beam", "aircraft-like twin"):
        assert s in structures
    for c in cases:
        assert c.truth.held_back and c.truth.start
        for e in c.truth.effects:
            assert set(e.points) <= set(c.channels) or (
                e.seen_at and set(e.seen_at) <= set(c.channels)), (c.name, e.points)
            assert set(e.identifiable) <= set(e.params)
    assert len(Z.zoo(fast=True)) >= 3 and Z.zoo("sdof-cubic-disp-r")[0].name == \
        "sdof-cubic-disp-random"


def test_twin_joint_sensors_move_within_5_percent():
    assert Z.twin_joint_spread(Z.twin()) < 0.05
    soft = Z.twin_joint_spread(_twin_with_interface(1.0))
    assert soft > 0.5             # the F-16-like interface alone: the sensors differ a lot


def _twin_with_interface(scale: float):
    old = Z.TWIN_INTERFACE
    try:
        Z.TWIN_INTERFACE = scale
        return Z.twin()
    finally:
        Z.TWIN_INTERFACE = old


def test_gap_rows_close_or_not_as_stated():
    """The unreached gap never closes in its recordings; the reached one does at the top
    level (deformation read from the simulated, noisy records: 1 % noise is far below the
    margins of 8 and 1.5 rms)."""
    for name, closes in (("sdof-gap_unreached", False), ("sdof-gap-disp", True)):
        case = Z.zoo(name)[0]
        g = case.truth.effects[0].params["g"]
        top = case.build().recordings[-1]
        assert (np.abs(top.response[:, 0]).max() > g) == closes, name


@pytest.mark.slow
def test_gap_intervals_from_the_profile_hold_the_truth():
    """A gap's contact stiffness and width come with their 95 % intervals from the misfit
    profile over both (`analysis.diagnose._joint.grid_refit`): they hold the truth; the
    stiffness's, wider than 5 %, says it is not identified to 5 % by these levels (the
    screening's interval at the fixed width held +-1.3 %)."""
    out = Z.run_case(Z.zoo("sdof-gap-disp-random")[0])
    assert out.covered == {"gap.k": True, "gap.g": True}
    assert out.unidentifiable["gap.k"] > Z.PARAM_TOL
    assert abs(out.param_errors["gap.g"]) <= Z.PARAM_TOL


def test_daq_artifacts_add_a_mains_line_an_offset_and_quantization():
    rec = Z.lumped_runs(Z.sdof(), 0, Z.RANDOM, "displacement", 5)[0]
    out = Z.daq_artifacts(rec, mains_hz=50.0, mains=0.05, offset=0.2, bits=12)
    x, x0 = out.response[:, 0], rec.response[:, 0]
    rms = x0.std()
    assert np.mean(x - x0) == pytest.approx(0.2 * rms, rel=0.02)
    steps = np.diff(np.unique(x))
    lsb = steps.min()
    assert lsb == pytest.approx(2.5 * np.abs(x).max() / 2 ** 12, rel=1e-3)
    assert np.allclose(steps / lsb, np.round(steps / lsb), atol=1e-6)
    spec = 2 * np.abs(np.fft.rfft(x - x0 - np.mean(x - x0))) / x.size    # sine amplitudes
    f = np.fft.rfftfreq(x.size, 1 / rec.fs)
    assert f[np.argmax(spec)] == pytest.approx(50.0, abs=rec.fs / x.size)
    assert spec.max() == pytest.approx(0.05 * np.sqrt(2) * rms, rel=0.05)
    hum = 2 * np.abs(np.fft.rfft(out.force[:, 0] - rec.force[:, 0])) / x.size
    assert hum[np.argmin(np.abs(f - 50.0))] < 1e-3 * rec.force.std()     # no mains on the force


def test_catalogue_rows_carry_the_catalogue_at_its_levels():
    """The new rows' records are the catalogue's (`apply_daq_artifacts` at `DaqArtifacts.of`):
    an imported-like record with 0.5 s of zeros at both ends, cut inside its last period and
    without a layout; a drift that moves the record's slow mean by about its catalogue level
    (10 % of the rms at its peak)."""
    rec = Z.zoo("sdof-cubic-acc-multisine-zeros")[0].build().recordings[0]
    pad = int(rec.fs / 2)
    assert rec.layout is None
    for x in (rec.force, rec.response):
        assert not x[:pad].any() and not x[-pad:].any() and x[pad].any() and x[-pad - 1].any()
    assert (rec.force.shape[0] - 2 * pad) % 4096 == round(0.63 * 4096)
    x = Z.zoo("sdof-cubic-disp-random-drift")[0].build().recordings[-1].response[:, 0]
    slow = np.convolve(x, np.ones(1024) / 1024, mode="valid")       # below the 2 Hz band edge
    assert 0.07 < np.ptp(slow) / x.std() < 0.13


def test_force_dips_rows_dip_where_the_structure_resonates():
    """`dip_gain`, with which the dipped rows set their effects' strength, is the law
    `shaker_force` applies to the drive; the SDOF row's measured force dips at 22.5 Hz (the
    3 kg armature's back-EMF damping takes the coil's force where the structure moves most)."""
    from scipy.signal import welch
    from analysis.recordings import Shaker, shaker_force
    m, fs, n = Z.sdof(), 256.0, 1 << 14
    coil = np.random.default_rng(0).standard_normal(n)
    f = np.fft.rfftfreq(n, 1 / fs)
    h = m.linear_frf(f, [0])[:, 0, 0]
    ratio = np.fft.rfft(shaker_force(coil, fs, h)) / np.fft.rfft(coil)
    assert np.allclose(ratio[1:-1], Z.dip_gain(Shaker(), f, h)[1:-1], rtol=1e-9)  # Nyquist: real
    rec = Z.zoo("sdof-cubic-disp-random-force-dips")[0].build().recordings[0]
    fw, p = welch(rec.force[:, 0], rec.fs, nperseg=1024)
    at = p[np.argmin(np.abs(fw - 22.5))]
    assert at < 0.1 * np.median(p[(fw > 2) & (fw < 60)])


@pytest.mark.slow
def test_circuit_start_misfits_its_own_level_at_several_times_its_floor():
    """The Duffing circuit's cubic acts at the level its start model is fitted on: the
    `fit_linear` start misfits that lowest level at more than 3x the level's floor (the
    real circuit of issue 24: 8x)."""
    from analysis.diagnose import diagnose
    built = Z.zoo("circuit-cubic-disp-multisine")[0].build()
    res = Z.result_json(diagnose(built.start, built.recordings))
    low = min(res["fit"]["levels"], key=lambda lv: lv["level"])
    assert low["before"] > 3 * low["floor"]


# --- the scoring ---------------------------------------------------------------------------

CASE = Z.ZooCase("toy", "3-DOF chain", "disp, all", "random",
                 Z.Truth((Z.Effect("cubic_spring", ("0", "1"), {"p": 1e9}, ("p",)),), (4.0,),
                         "exact"), lambda: None, ("0", "1", "2"))
NONE = Z.ZooCase("toy-none", "SDOF", "disp, all", "random", Z.Truth((), (4.0,), "exact"),
                 lambda: None, ("0",))


def _res(verdict, found=(), alternatives=(), ci95=None):
    return {"verdict": verdict, "missing_physics": [
        {"kind": k, "dofs": list(d), "params": p, "ci95": ci95 or {}} for k, d, p in found],
        "location": {"alternatives": [{"dofs": list(a)} for a in alternatives]},
        "fit": {"before": 1.0, "after": 0.1},
        "levels": [{"level": 4.0, "held_back": True}]}


def test_score_judges_family_location_and_parameters():
    right = Z.score(CASE, _res("discrepancy", [("cubic_spring", [0, 1], {"p": 1.03e9})]))
    assert right.family_right and right.location == "right" and right.params_ok
    assert right.param_errors["cubic_spring.p"] == pytest.approx(0.03)
    off = Z.score(CASE, _res("discrepancy", [("cubic_spring", [0, 1], {"p": 1.06e9})]))
    assert off.family_right and off.params_ok is False
    support = Z.score(CASE, _res("discrepancy", [("cubic_spring", [1], {"p": 1e9})]))
    assert support.family_right and support.location == "wrong" and not support.params_ok
    ambiguous = Z.score(CASE, _res("discrepancy", [("cubic_spring", [1], {"p": 1e9})],
                                   alternatives=[[0, 1]]))
    assert ambiguous.location == "ambiguous"
    kind = Z.score(CASE, _res("discrepancy", [("gap", [0, 1], {"k": 1.0, "g": 1.0})]))
    assert not kind.family_right and kind.location == "right"
    assert not Z.score(CASE, _res("unexplained")).family_right
    assert Z.score(CASE, _res("discrepancy", [("cubic_spring", [0, 1], {"p": 1e9})])
                   ).held_back == (1.0, 0.1)


def _tie(named_gain=3.62e5, alt_gain=3.58e5, left=2.5e4, kinds=("cubic_spring",),
         evidence=True):
    """A gap named at the truth's location with ``kinds`` listed as tied (numbers as the
    diagnosis states them)."""
    res = _res("discrepancy", [("gap", [0, 1], {"k": 6e4, "g": 1.7e-3})])
    named = res["missing_physics"][0]
    if evidence:
        named["evidence"] = {"oos_gain": named_gain, "oos_sd": 1364.0, "oos_left": left}
    named["alternatives"] = [{"kind": k, "dofs": [0, 1], "points": ["0", "1"],
                              "oos_gain": alt_gain, "oos_sd": 1371.0, "oos_left": left + 4e3,
                              "params": {"p": 1.02e9}, "ci95": {"p": [1.0e9, 1.04e9]}}
                             for k in kinds]
    return res


def test_score_credits_an_honest_kind_tie_and_cannot_be_gamed():
    """The true kind stated as tied with the named one counts as the family found
    (``ambiguous``), judged on the alternative's location and parameters, only when the
    stated numbers tie by the stated rule (recomputed) and at most two kinds are listed."""
    tie = Z.score(CASE, _tie())
    assert tie.family_right and tie.kind == "ambiguous" and tie.location == "right"
    assert tie.param_errors == pytest.approx({"cubic_spring.p": 0.02}) and tie.params_ok
    assert Z.totals([tie])["family_ambiguous"] == 1
    # 4e4 apart, threshold max(3.72 x 1934, 2.5e3): no tie however the tie is worded
    apart = Z.score(CASE, _tie(alt_gain=3.22e5, left=2.5e3))
    assert not apart.family_right and apart.kind == "wrong"
    assert Z.real_tie({"oos_gain": 3.62e5, "oos_sd": 1364.0, "oos_left": 2.5e3},
                      {"oos_gain": 3.58e5, "oos_sd": 1371.0, "oos_left": 3e3})  # 4e3 < 7.2e3
    # a gain within its own noise does not win, so it ties with nothing
    assert not Z.real_tie({"oos_gain": 3e3, "oos_sd": 1364.0, "oos_left": 0.0},
                          {"oos_gain": 4e3, "oos_sd": 1371.0, "oos_left": 0.0})
    # listing every kind says nothing; nor does a tie without its numbers
    many = Z.score(CASE, _tie(kinds=("cubic_spring", "quadratic_spring")))
    assert not many.family_right
    assert not Z.score(CASE, _tie(evidence=False)).family_right
    # the true kind named outright is right, not ambiguous
    right = Z.score(CASE, _res("discrepancy", [("cubic_spring", [0, 1], {"p": 1.03e9})]))
    assert right.kind == "right"


SLIDER = Z.ZooCase("toy-slider", "3-DOF chain", "disp, all", "random",
                   Z.Truth((Z.Effect("stick_slip", ("0", "1"), {"kd": 1e4, "fd": 2.0},
                                     ("kd", "fd"), ("hysteresis", "iwan")),), (4.0,), "exact"),
                   lambda: None, ("0", "1", "2"))


def test_score_leaves_out_what_the_data_do_not_identify():
    """A parameter whose 95 % interval is wider than 5 % either side is not judged (and
    counted as unidentifiable); one within is judged, whether or not its interval holds the
    truth (recorded in ``covered``)."""
    wide = Z.score(CASE, _res("discrepancy", [("cubic_spring", [0, 1], {"p": 1.07e9})],
                              ci95={"p": [0.99e9, 1.15e9]}))
    assert wide.params_ok is None and wide.param_errors == {}
    assert wide.unidentifiable["cubic_spring.p"] == pytest.approx(0.08 / 1.07)
    assert wide.covered == {"cubic_spring.p": True}
    tight = Z.score(CASE, _res("discrepancy", [("cubic_spring", [0, 1], {"p": 1.07e9})],
                               ci95={"p": [1.06e9, 1.08e9]}))
    assert tight.params_ok is False and tight.covered == {"cubic_spring.p": False}
    tot = Z.totals([wide, tight])
    assert tot["params_unidentifiable"] == 1 and tot["intervals_covering"] == (1, 2)


def test_score_judges_a_slider_named_as_another_of_its_family_on_kd_and_fd():
    iwan = {"kd": 1.02e4, "fd": 1.9, "chi": -0.5, "beta": 0.5}
    out = Z.score(SLIDER, _res("discrepancy", [("iwan", [0, 1], iwan)]))
    assert out.param_errors == pytest.approx({"stick_slip.kd": 0.02, "stick_slip.fd": -0.05})
    both = Z.score(SLIDER, _res("discrepancy", [("hysteresis", [0, 1], {"kd": 2e4, "fd": 9.0}),
                                                ("stick_slip", [0, 1], {"kd": 1e4, "fd": 2.0})]))
    assert both.params_ok                           # the true kind is judged when named
    other = Z.score(SLIDER, _res("discrepancy", [("coulomb_friction", [0, 1], {"fc": 2.0})]))
    assert not other.family_right and other.params_ok is False


def test_score_counts_any_claim_on_a_none_row_as_a_false_alarm():
    assert Z.score(NONE, _res("adequate")).false_alarm is False
    assert Z.score(NONE, _res("unexplained")).false_alarm is True
    alarm = Z.score(NONE, _res("discrepancy", [("cubic_spring", [0], {"p": 1.0})]))
    assert alarm.false_alarm and not alarm.family_right
    tot = Z.totals([alarm, Z.score(NONE, _res("adequate"))])
    assert tot["false_alarms"] == 1 and tot["family_right"] == 0.5


# --- session 33's rows (``-z7``) --------------------------------------------------------------


def test_new_rows_add_the_dimensions_they_claim():
    """Softening (p < 0), a start model too stiff, cubic damping, 0.5 % and 5 % modal damping,
    an effect at an unmeasured point, velocity sensors, 60 Hz and unlocked mains, two families
    at once, none of them in the fast zoo."""
    new = Z.zoo("-z7")
    assert len(new) >= 12 and not any(c.fast for c in new)
    effects = [e for c in new for e in c.truth.effects]
    assert any(e.kind == "cubic_spring" and e.params["p"] < 0 for e in effects)
    assert any(e.kind == "stiffness_error" and e.params["delta_stiffness"] < 0 for e in effects)
    assert "cubic_damping" in {e.kind for e in effects}
    assert any(e.seen_at and not set(e.points) & set(c.channels) for c in new
               for e in c.truth.effects)
    assert any(c.sensors.startswith("vel") for c in new)
    assert any(len({e.kind for e in c.truth.effects}) == 2 for c in new)
    from scipy.linalg import eigh
    for zeta in (0.005, 0.05):
        m = Z.modal_damped(Z.chain3, zeta)
        lam, phi = eigh(m.stiffness, m.mass)
        assert np.allclose(np.diag(phi.T @ m.damping @ phi), 2 * zeta * np.sqrt(lam))
    assert [c.truth.below_floor for c in new if "cubic_below" in c.name] == [True]


@pytest.mark.parametrize("hz", [60.0, 50.02])
def test_mains_rows_carry_their_line(hz):
    """The mains rows' records carry the line at ``hz`` with harmonics: the second, above the
    2-60 Hz band where a linear structure under the multisine adds nothing, at -36 dB of the
    response's rms (6 dB below the -30 dB line), locked to the period or not."""
    name = "chain-none-acc-multisine-mains" + ("60" if hz == 60.0 else "5002")
    rec = Z.zoo(name)[0].build().recordings[0]
    x = rec.response[:, 0] - rec.response[:, 0].mean()
    t = np.arange(x.size) / rec.fs
    amp = 2 * abs(np.sum(x * np.exp(-2j * np.pi * 2 * hz * t))) / x.size
    assert amp / np.sqrt(2) == pytest.approx(x.std() * 10 ** (-36 / 20), rel=0.1)


def test_softening_rows_stay_in_their_well():
    """No record of a softening row passes its well's edge (`SOFT_EDGE` top rms deformations
    of the stiffness the structure opposes to the element)."""
    case = Z.zoo("sdof-softcubic-disp-random-z7")[0]
    p = case.truth.effects[0].params["p"]
    edge = np.sqrt(Z.sdof().stiffness_along(np.ones(1)) / (3 * abs(p)))
    top = case.build().recordings[-1].response[:, 0]
    assert np.abs(top).max() < edge and np.abs(top).max() > 0.4 * edge


def test_faint_cubics_change_the_frf_as_stated():
    m, w = Z.sdof(), np.ones(1)
    u1 = Z.RANDOM.rms(m, w, 0, Z.LEVELS[-1])
    for times in Z.LOW_SIGNAL.values():
        p = Z.faint_cubic(m, ("0",), 0, Z.RANDOM, times).params["p"]
        assert Z.frf_change(m, w, 0, Z.RANDOM.band, 3 * p * u1 ** 2) == pytest.approx(
            0.01 * times, rel=1e-6)


def test_stepped_gap_closes_at_the_top_level_only():
    case = Z.zoo("sdof-gap-disp-stepped-z7")[0]
    g = case.truth.effects[0].params["g"]
    recs = case.build().recordings
    assert [bool(np.abs(r.response).max() > g) for r in recs] == [False, False, True]


def test_stepped_screen_fits_the_gap_the_top_level_closes():
    """The gap's widths scale with the highest fitting level's rms (the kind's ``level``) and
    are refined continuously: the screen lands on the truth, k's interval covering it."""
    from analysis.diagnose._stepped import HARMONICS, SteppedSearch, stepped_sine_frf
    from analysis.recordings import model_at_sensors, one_kind
    case = Z.zoo("sdof-gap-disp-stepped-z7")[0]
    truth = case.truth.effects[0].params
    built = case.build()
    recs = [one_kind(r) for r in built.recordings]
    fitting = [recs[0], recs[2]]                       # level 4 is held back
    model = model_at_sensors(built.start, recs, "diagnose")
    search = SteppedSearch(model, [stepped_sine_frf(r, HARMONICS) for r in fitting], fitting,
                           0.01)
    gap = next(f for f in search.screen() if f.cand.kind == "gap")
    lo, hi = gap.ci95["k"]
    assert lo <= truth["k"] <= hi
    assert abs(np.log(gap.params["g"] / truth["g"])) < 0.01      # `refine_grid`'s xatol


def test_score_accepts_unexplained_only_where_the_numbers_show_a_one_level_effect():
    case = Z.ZooCase("toy-one-level", "SDOF", "disp, all", "stepped",
                     Z.Truth((Z.Effect("gap", ("0",), {"k": 2e4, "g": 7e-3}, ("k", "g")),),
                             (4.0,), "exact", one_level=True), lambda: None, ("0",))

    def res(errors, best="gap DOF 0 to ground", points=("0",)):
        trend = [{"level": lv, "error": e, "floor": 0.01}
                 for lv, e in zip((1.0, 4.0, 12.0), errors)]
        return dict(_res("unexplained"), evidence={"misfit": {
            "level_trend": trend, "points": list(points), "tried": {"best": best}}})
    ok = Z.score(case, res((0.002, 0.002, 1.1)))
    assert ok.family_right and ok.kind == "right" and ok.location == "right"
    assert not Z.score(case, res((0.002, 0.05, 1.1))).family_right    # another level sees it
    assert not Z.score(case, res((0.002, 0.002, 1.1), best="cubic_spring DOF 0 to ground")
                       ).family_right
    assert not Z.score(case, res((0.002, 0.002, 1.1), points=("1",))).family_right
    plain = Z.ZooCase("toy-plain", "SDOF", "disp, all", "stepped",
                      dataclasses.replace(case.truth, one_level=False), lambda: None, ("0",))
    assert not Z.score(plain, res((0.002, 0.002, 1.1))).family_right


def test_score_accepts_adequate_below_the_floor_and_a_neighbour_of_an_unmeasured_point():
    below = Z.ZooCase("toy-below", "SDOF", "disp, all", "random",
                      Z.Truth((Z.Effect("cubic_spring", ("0",), {"p": 1e5}, ("p",)),), (4.0,),
                              "exact", below_floor=True), lambda: None, ("0",))
    ok = Z.score(below, _res("adequate"))
    assert ok.family_right and ok.location == "-" and ok.false_alarm is None
    assert Z.totals([ok])["location_right"] == 0.0 and Z.totals([ok])["family_right"] == 1.0
    assert not Z.score(below, _res("unexplained")).family_right
    found = Z.score(below, _res("discrepancy", [("cubic_spring", [0], {"p": 1.02e5})]))
    assert found.family_right and found.location == "right" and found.params_ok
    hidden = Z.ZooCase("toy-hidden", "4-DOF chain", "disp, 3 of 4", "random",
                       Z.Truth((Z.Effect("cubic_spring", ("3",), {"p": 1e9}, (),
                                         seen_at=("2",)),), (4.0,), "exact"),
                       lambda: None, ("0", "1", "2"))
    near = Z.score(hidden, _res("discrepancy", [("cubic_spring", [2], {"p": 3e9})]))
    assert near.family_right and near.location == "ambiguous" and near.params_ok is None
    far = Z.score(hidden, _res("discrepancy", [("cubic_spring", [0], {"p": 3e9})]))
    assert far.location == "wrong"
