"""The real Brake-Reuss beam (../shared/real/brake-reuss-beam/, response-controlled stepped
sine, 8 levels 5-80 m/s^2, the source's MATLAB struct array): imported through a table map,
its backbone (frequency near 80 Hz, damping growing with amplitude, each fit error small),
its linear model from the lowest level, and the level dependence detect finds. Skipped when
the data are absent (a fresh clone has no ../shared)."""

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from nlid_lab.cli import main

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "real" / "brake-reuss-beam"
MAT = DATA / "ResponseControl.mat"
#: the source's phase is the displacement's (receptance) phase: 0 below the resonance,
#: -pi/2 at it, -pi above (docs/backbone.md)
MAP = ["table=FRdata.ResponseControl", "freqs=frequency", "force_amplitude=force:N",
       "response_amplitude=amplitude:m/s^2", "response_phase=phase:receptance",
       "control=response", "units=units"]

pytestmark = pytest.mark.skipif(not MAT.is_file(), reason="real data ../shared/real absent")


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("brb") / "brb.h5"
    assert main(["import", str(MAT), "--out", str(out), "--map", *MAP]) == 0
    return out


def test_import_holds_the_eight_levels(run):
    from nlid_lab.store import open_run
    tables = open_run(run).recordings()
    assert len(tables) == 8 and all(t.n_steps == 41 for t in tables)
    held = [t.level for t in tables]
    np.testing.assert_allclose(held, [5, 20, 30, 40, 50, 60, 70, 80], rtol=0.02)
    for t in tables:            # the controller held the acceleration within 11 % of its level
        assert np.ptp(np.abs(t.response_phasor[:, 0])) < 0.11 * t.level
        # an accelerance passes +90 deg at its peak (phase convention of contracts sec. 6)
        H = t.frf()[:, 0, 0]
        assert abs(np.angle(H[np.argmax(np.abs(H))], deg=True) - 90) < 20


def test_backbone_softens_first_and_damping_grows(run, tmp_path):
    out = tmp_path / "bb.json"
    assert main(["backbone", str(run), "--json", str(out)]) == 0
    levels = json.loads(out.read_text())["levels"]
    f = np.array([lv["frequency_hz"] for lv in levels])
    z = np.array([lv["damping_ratio"] for lv in levels])
    assert np.all((f > 79.5) & (f < 81.0))
    assert f[3] < f[0] - 0.15                 # 80.37 Hz at 5 m/s^2 -> 80.12 Hz at 40 m/s^2
    assert np.all(np.diff(z) > 0) and z[-1] > 3 * z[0]          # 0.15 % -> 0.64 %
    for lv in levels:
        assert lv["fit_error"] < 0.02                # one quasi-linear mode per level
        lo, hi = lv["damping_ci95"]
        assert lo < lv["damping_ratio"] < hi


def test_fit_linear_gives_the_lowest_levels_mode(run, tmp_path):
    model = tmp_path / "lin.toml"
    assert main(["fit-linear", str(run), "--out", str(model)]) == 0
    modal = tomllib.loads(model.read_text())["modal"]
    assert len(modal["frequencies_hz"]) == 1
    assert modal["frequencies_hz"][0] == pytest.approx(80.37, abs=0.01)
    assert modal["damping_ratios"][0] == pytest.approx(0.00153, rel=0.02)
    pred = tmp_path / "pred.json"
    assert main(["predict", str(model), "--amplitude", "0.0295", "--band", "79", "81",
                 "--json", str(pred)]) == 0
    curve = json.loads(pred.read_text())["curves"][0]
    peak = np.argmax(curve["amplitude"]["0"])
    acc = curve["amplitude"]["0"][peak] * (2 * np.pi * curve["freqs"][peak]) ** 2
    assert acc == pytest.approx(5.0, rel=0.05)   # the force that held 5 m/s^2 at resonance


def test_detect_finds_the_level_dependence(run, tmp_path):
    out = tmp_path / "det.json"
    assert main(["detect", str(run), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["verdict"] == "nonlinear"


FRICTION = ("stick_slip", "hysteresis", "iwan")
STIFFENING = ("cubic_spring", "quadratic_spring", "gap")
LINEAR_CORRECTION = ("stiffness_error", "damping_error")
FORCES = (0.2, 0.5, 1.0, 1.5)      # the held-back force-controlled curves' forces, N


def force_backbone(run: Path, forces) -> np.ndarray:
    """Peak acceleration at each held force that the measured backbone implies: a
    response-controlled level needs its least force at resonance (single nonlinear mode: a
    force-controlled curve peaks where that force equals its own), interpolated in log-log
    between the levels."""
    from nlid_lab.store import open_run
    pts = sorted((float(np.min(np.abs(t.force_phasor[:, 0]))), float(t.level))
                 for t in open_run(run).recordings())
    F, a = np.log(np.array(pts)).T
    return np.exp(np.interp(np.log(forces), F, a))


@pytest.mark.slow
def test_diagnose_finds_a_friction_joint_whose_predictions_follow_the_backbone(run, tmp_path):
    """fit-linear (lowest level) -> diagnose: a friction-family element with its stuck
    stiffness taken from the linear part, every level's FRF error lower or within its floor
    (the lowest one too: the linear part, fitted there, gives back the joint's share of it,
    docs/backbone.md), the held-back level improved; `predict --step` of the written model
    at the held-back force-controlled curves' forces peaks within 15 % of what the measured
    backbone implies (the linear model: +43 % to +275 %)."""
    lin, fixed, out = tmp_path / "lin.toml", tmp_path / "fixed.toml", tmp_path / "d.json"
    assert main(["fit-linear", str(run), "--out", str(lin)]) == 0
    assert main(["diagnose", str(lin), str(run), "--json", str(out), "--model-out",
                 str(fixed), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert d["verdict"] == "discrepancy"
    found = d["missing_physics"][0]
    assert found["kind"] in FRICTION and found["stuck_stiffness_from_linear_part"]
    # a friction element may come with a stiffening one beside it (the beam's frequency
    # falls and rises again; docs/backbone.md) and with the linear part's correction at its
    # point: nothing else, and no second friction
    assert all(m["kind"] in STIFFENING + LINEAR_CORRECTION and m["dofs"] == found["dofs"]
               for m in d["missing_physics"][1:])
    assert len(d["fit"]["held_back"]) == 3                       # 20, 40, 60 m/s^2
    assert d["fit"]["after"] < 0.8 * d["fit"]["before"]          # 1.125 -> 0.531 measured
    for lv in d["fit"]["levels"]:
        assert lv["after"] < lv["before"] or lv["after"] <= lv["floor"]
    # the backbone it reproduces: damping within 5 % rms over the levels (0.64 -> 1.3 %)
    assert d["ranking"][0]["kind"] == found["kind"]
    assert d["ranking"][0]["evidence"]["damping_rms"] < 0.05
    pred = tmp_path / "p.json"
    assert main(["predict", str(fixed), "--amplitude", *map(str, FORCES), "--band", "79",
                 "81.5", "--step", "0.01", "--json", str(pred), "--quiet"]) == 0
    peaks = [c["peak"]["0"]["acceleration"] for c in json.loads(pred.read_text())["curves"]]
    np.testing.assert_allclose(peaks, force_backbone(run, FORCES), rtol=0.15)
