"""Diagnosis and predictions on stepped-sine tables (issue 25 items 3 and 6): a jointed-beam
twin, one mode near 80 Hz with a Jenkins joint (`jenkins_twin`, single-harmonic balance),
held at response amplitudes like the real Brake-Reuss beam's (5-80 m/s^2, 41 steps of
0.05 Hz about each level's resonance). The diagnosis starts from the linear model of the
lowest level (the joint stuck), finds the stick-slip element with its stuck stiffness taken
from the linear part, and its predictions at held *forces* (curves it was not fitted to)
match the twin's own force-controlled curves."""

import json

import numpy as np
import pytest

from analysis.diagnose import diagnose
from analysis.models import Model
from jenkins_twin import JenkinsSDOF
from nlid_lab.cli import main

#: underlying (slipped) mode at 79.6 Hz, stuck at 80.4 Hz, slips from 16 m/s^2 on
TWIN = JenkinsSDOF(m=1.0, k=(2 * np.pi * 79.6) ** 2, c=2 * 0.0015 * 2 * np.pi * 80.37,
                   kd=5000.0, fd=0.3)
LEVELS = (5.0, 20.0, 40.0, 60.0, 80.0)
#: the estimate's known bias: the backbone of a held-acceleration level reads the damping
#: of a rate-independent loss through a viscous single-mode fit (docs/backbone.md: up to
#: 3.3 % at one level just past slip onset); the issue asks 5 %
REL = 0.05


def level(held: float):
    fn = TWIN.backbone_at(np.array([TWIN.resonance_amplitude(held)]))[0][0]
    return TWIN.held_acceleration(held, fn + 0.05 * np.arange(-20, 21))


@pytest.fixture(scope="module")
def diagnosed():
    start = Model(np.eye(1), np.array([[TWIN.c]]), np.array([[TWIN.k + TWIN.kd]]),
                  name="stuck twin")
    return diagnose(start, [level(a) for a in LEVELS])


def test_diagnose_finds_the_jenkins_joint_of_the_twin(diagnosed):
    d = diagnosed
    assert d.verdict == "discrepancy"
    found = d.chosen[0]
    assert found.kind == "stick_slip" and found.stuck_stiffness_from_linear_part
    assert len(d.chosen) == 1          # a pure friction joint: no stiffening law beside it
    assert found.params["kd"] == pytest.approx(TWIN.kd, rel=REL)
    assert found.params["fd"] == pytest.approx(TWIN.fd, rel=REL)
    # the corrected model's underlying stiffness is the twin's (kd moved out of it)
    assert d.model.stiffness[0, 0] == pytest.approx(TWIN.k, rel=REL * TWIN.kd / TWIN.k)
    assert d.fit.held_back == ("level 20", "level 60")
    assert d.fit.after < 0.05 * d.fit.before                 # 1.42 -> 0.0023 measured


def test_predicted_force_controlled_curves_match_the_twins(diagnosed, tmp_path):
    """The corrected model at held forces (not fitted) against the twin's own force-controlled
    curves: the peak acceleration at every force within 2 % (the parameters' own error)."""
    model = tmp_path / "fixed.toml"
    diagnosed.model.save(model)
    forces = [0.1, 0.3, 1.0]
    out = tmp_path / "pred.json"
    assert main(["predict", str(model), "--amplitude", *map(str, forces), "--band", "79",
                 "81", "--step", "0.02", "--json", str(out), "--quiet"]) == 0
    curves = json.loads(out.read_text())["curves"]
    f = np.linspace(79, 81, 101)
    for F, c in zip(forces, curves):
        twin = np.abs(TWIN.held_force(F, f).response_phasor[:, 0])
        peak = c["peak"]["0"]
        assert peak["acceleration"] == pytest.approx(twin.max(), rel=0.02)
        assert peak["freq"] == pytest.approx(f[np.argmax(twin)], abs=0.03)


def test_the_backbone_chooses_the_kind_that_fits_frequency_and_damping():
    """On the twin's levels, each kind at the held point fitted to the backbone and scored
    on each level predicted from the others (`backbone_estimate`): the Jenkins joint
    (frequency falls, damping grows) predicts both (measured: frequency 2e-5, damping
    0.97 % rms held out, score 40.1); cubic damping cannot move the frequency (its held-out
    frequency error is the linear mode's, 0.68 %) and, the exact lowest level allowing no
    change of its own, gains nothing (score 0)."""
    from analysis.diagnose._stepped_memory import backbone_estimate
    from analysis.models import library
    start = Model(np.eye(1), np.array([[TWIN.c]]), np.array([[TWIN.k + TWIN.kd]]))
    tables = [level(a) for a in LEVELS]
    ev = {}
    for c in library(1, start.points, start.support):
        if c.kind in ("stick_slip", "cubic_damping") and c.compensated == (c.kind == "stick_slip"):
            ev[c.kind] = backbone_estimate(start, c, tables).score
    jenkins, cubic = ev["stick_slip"], ev["cubic_damping"]
    # a cubic spring beside the Jenkins joint gains less than a pair must (`PAIR_MIN`)
    from analysis.diagnose._stepped import PAIR_MIN
    slider = next(c for c in library(1, start.points, start.support)
                  if c.kind == "stick_slip" and c.compensated)
    spring = next(c for c in library(1, start.points, start.support) if c.kind == "cubic_spring")
    pair = backbone_estimate(start, slider, tables, beside=spring).score
    assert pair.gain <= jenkins.gain + PAIR_MIN
    assert jenkins.gain > cubic.gain
    assert jenkins.frequency_rms < 0.1 * cubic.frequency_rms
    assert jenkins.damping_rms < cubic.damping_rms


def test_a_backbone_estimate_writes_its_evidence_in_the_documented_order():
    """`BackboneEstimate.evidence`: the keys of `BackboneEvidence` in its order (the
    diagnosis JSON's ``evidence`` of a backbone fit), the correction and the pair partner
    only when there are some."""
    from analysis.diagnose._stepped_memory import (BackboneEstimate, BackboneEvidence,
                                                   BackboneScore)
    score = BackboneScore(40.1, 2e-5, 0.0097)
    alone = BackboneEstimate({"kd": 5e3, "fd": 0.3}, {"kd": [4e3, 6e3]}, 1e-4, 0.02, score)
    assert alone.evidence() == {"frequency_rms": 1e-4, "damping_rms": 0.02,
                                "backbone_oos_gain": 40.1, "frequency_rms_oos": 2e-5,
                                "damping_rms_oos": 0.0097}
    assert not alone.anchored
    pair = BackboneEstimate({"kd": 5e3}, {}, 1e-4, 0.02, score, (12.0, -0.5), "cubic_spring",
                            {"p": 1e9}, {"p": (0.9e9, 1.1e9)})
    ev = pair.evidence()
    assert list(ev) == list(BackboneEvidence.__annotations__)
    assert ev["linear_correction"] == {"delta_stiffness": 12.0, "delta_damping": -0.5}
    assert ev["beside_ci95"] == {"p": [0.9e9, 1.1e9]} and pair.anchored
