"""Response-controlled stepped-sine campaigns: every step holds the response amplitude at
``control_dof``; the run reads as response-controlled tables, whose backbone is the one
harmonic balance gives for the simulated model; the serial emulator (a real pseudo-terminal)
holds the amplitude too; drive and force limits end a level with a message."""

from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from analysis.backbone import backbone
from analysis.hbm import aft_tables, periodic_forces
from analysis.models import KINDS, Element, Model, pack_params
from analysis.recordings import StepTable
from nlid_lab.campaign import CampaignError, parse_campaign, run_campaign
from nlid_lab.cli import main
from nlid_lab.commands.backbone import levels as run_levels

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
BASE = tomllib.loads((EXAMPLES / "campaign-sim-response.toml").read_text())
MODEL = Model.load(EXAMPLES / "models" / "sdof-iwan-beam.toml")


def campaign(backend: str = "sim", **stepped) -> dict:
    """The example, held in displacement (the joint's amplitude constant over a level)."""
    data = copy.deepcopy(BASE)
    if backend == "serial":    # room for a busy machine, as in test_campaign.py
        data["shaker"].update(url="serial-emu://", watchdog=0.5)
        data["daq"].update(url="serial-emu://?pace=16", comms_timeout=0.25)
    data["daq"].update(response_kind="displacement")
    data["channel"][1].update(name="x0", quantity="displacement", sensitivity=1e4)
    data["plant"]["noise_std"] = 1e-9                 # m rms per sample
    data["safety"]["limits"] = {"F0": 2.0}
    for key in ("start", "stop", "step"):
        del data["stepped"][key]
    data["stepped"].update(block_size=1024, **stepped)
    return data


def describing(a: float) -> complex:
    """First-harmonic stiffness of the model's Iwan joint at amplitude ``a``: harmonic
    balance of one harmonic, by the AFT the HBM solver uses."""
    el = MODEL.elements[0]
    harm = np.array([1])
    G = np.zeros(2)
    periodic_forces(KINDS["iwan"].code, pack_params("iwan", el.params), True,
                    np.array([a, 0.0]), 1.0, *aft_tables(harm, 512), harm, 50, 1e-13, G,
                    np.zeros((0, 0)))
    return complex(G[0], G[1]) / a


def hbm_table(freqs: np.ndarray, held: np.ndarray, level: float) -> StepTable:
    """The response-controlled table harmonic balance predicts at the run's steps and held
    amplitudes: force ``(k + N(a) - m w^2 + i c w) a`` per step."""
    m, c, k = MODEL.mass[0, 0], MODEL.damping[0, 0], MODEL.stiffness[0, 0]
    w = 2 * np.pi * freqs
    force = np.array([(k + describing(a) - m * wi**2 + 1j * c * wi) * a
                      for wi, a in zip(w, held)])
    return StepTable(freqs, force[:, None], held[:, None].astype(complex), [0], "response",
                     level, control_dof=0)


@pytest.mark.slow
def test_sim_run_gives_the_harmonic_balance_backbone_and_joint(tmp_path):
    """Three held displacements (micro-, partial and near macroslip) over the resonances:
    every step within the 1 % tolerance; `nlid-lab backbone`'s reading of the run and the
    backbone of harmonic balance's table at the same steps and amplitudes agree within the
    run's 95 % intervals widened by what one harmonic leaves out (the run's higher harmonics
    and the plant's 1e-5 accuracy: measured 9e-6 relative in frequency and 0.05 % in damping,
    checked at 3e-5 and 0.5 %). `analyze hbm` with an `iwan` candidate gets the joint's four
    parameters back within 1 %: with 1 nm noise what is left is harmonic balance's truncation
    to orders 1, 3, 5, 7 (5e-4 to 7e-4 of the response against the plant, test_hbm.py), which
    the fit turns into 0.02 to 0.4 % on the parameters."""
    levels = [4e-6, 2e-5, 8e-5]
    freqs = [float(f) for f in np.arange(77.25, 80.01, 0.25)]
    data = campaign(control="response", levels=levels, freqs=freqs)
    data["safety"]["limits"] = {"F0": 5.0}
    out = tmp_path / "run.h5"
    result = run_campaign(parse_campaign(data, EXAMPLES), out)
    assert result.status == "complete" and not result.warnings
    tables = run_levels([str(out)])
    assert [str(t.control) for t in tables] == ["response"] * 3
    for t, level in zip(tables, levels):
        np.testing.assert_allclose(t.held(), level, rtol=0.01)
    run = backbone(tables)
    ref = backbone([hbm_table(t.freqs, t.held(), t.level) for t in tables])
    for p, q in zip(run.points, ref.points):
        df = p.frequency_ci95[1] - p.frequency_hz + 3e-5 * q.frequency_hz
        assert abs(p.frequency_hz - q.frequency_hz) <= df, (p.frequency_hz, q.frequency_hz)
        dz = p.damping_ci95[1] - p.damping_ratio
        assert abs(p.damping_ratio - q.damping_ratio) <= dz + 0.005 * q.damping_ratio, \
            (p.damping_ratio, q.damping_ratio)
    assert run.points[2].frequency_hz < run.points[0].frequency_hz - 1.0      # softening
    assert run.points[2].damping_ratio > 3 * run.points[0].damping_ratio     # friction loss
    candidate = MODEL.with_elements([Element("iwan", [1.0], {})])
    candidate.save(tmp_path / "candidate.toml")
    assert main(["analyze", "hbm", str(out), "--model", str(tmp_path / "candidate.toml"),
                 "--json", str(tmp_path / "fit.json"), "-q"]) == 0
    fitted = json.loads((tmp_path / "fit.json").read_text())["elements"][0]["params"]
    for name, true in MODEL.elements[0].params.items():
        assert fitted[name] == pytest.approx(true, rel=0.01), name


def test_serial_run_holds_the_amplitude(tmp_path):
    """Through the serial shaker and DAQ emulators (pseudo-terminals): each step's response
    fundamental within the 1 % tolerance of the held displacement."""
    c = parse_campaign(campaign("serial", control="response", levels=[1e-5],
                                freqs=[78.0, 80.0]), EXAMPLES)
    run_campaign(c, tmp_path / "run.h5")
    (table,) = run_levels([str(tmp_path / "run.h5")])
    assert str(table.control) == "response" and table.level == 1e-5
    np.testing.assert_allclose(table.held(), 1e-5, rtol=0.01)


def test_force_limit_ends_the_level_with_a_message(tmp_path):
    """A level needing more force than the force channel's safety limit ends at that step
    (the steps before kept); the next level runs."""
    c = parse_campaign(campaign(control="response", levels=[2e-4, 4e-6], freqs=[76.0, 80.0]),
                       EXAMPLES)
    result = run_campaign(c, tmp_path / "run.h5")
    assert result.status == "complete"
    assert any("over its safety limit 2 N; level ended here" in w for w in result.warnings)
    assert result.levels[0].done < 2 and result.levels[1].done == 2


@pytest.mark.parametrize("change,match", [
    ({"control": "amplitude"}, "control must be one of force, response"),
    ({"control": "response", "control_dof": 3}, "control_dof = 3 has no response channel"),
    ({"control": "force", "control_dof": 0}, "with control = \"response\""),
])
def test_bad_control_keys_are_named(change, match):
    with pytest.raises(CampaignError, match=match):
        parse_campaign(campaign(levels=[1e-5], freqs=[78.0, 80.0], **change), EXAMPLES)


JENKINS = Model(MODEL.mass, MODEL.damping, MODEL.stiffness,
                [Element("stick_slip", [1.0], {"kd": 2.5e4, "fd": 0.75})], name="jenkins beam")


@pytest.mark.slow
@pytest.mark.parametrize("truth", [MODEL, JENKINS], ids=["iwan", "jenkins"])
def test_response_campaign_backbone_diagnose_recovers_the_joint(tmp_path, truth):
    """Issue 25: a simulated beam mode with a known joint (Iwan: kd, fd and the signed
    exponent chi; Jenkins: kd, fd), a response-controlled campaign (held displacement, five
    levels from microslip to near macroslip), `backbone`, then `diagnose` from the linear
    model of the stuck joint (what `fit-linear` of the lowest level gives): the joint's kind
    with its stuck stiffness taken from the linear part, every parameter within 5 %."""
    from analysis.diagnose import diagnose
    from nlid_lab.store import open_run
    model = tmp_path / "truth.toml"
    truth.save(model)
    levels = [4e-6, 1e-5, 2e-5, 4e-5, 8e-5]
    data = campaign(control="response", levels=levels,
                    freqs=[float(f) for f in np.arange(77.25, 80.01, 0.25)])
    data["plant"]["model"] = str(model)
    data["safety"]["limits"] = {"F0": 5.0}
    out = tmp_path / "run.h5"
    assert run_campaign(parse_campaign(data, EXAMPLES), out).status == "complete"
    assert main(["backbone", str(out), "--json", str(tmp_path / "bb.json"), "--quiet"]) == 0
    points = json.loads((tmp_path / "bb.json").read_text())["levels"]
    assert points[-1]["damping_ratio"] > 2 * points[0]["damping_ratio"]      # it slips
    joint = truth.elements[0]
    stuck = Model(truth.mass, truth.damping, truth.stiffness + joint.params["kd"],
                  name="stuck joint")
    d = diagnose(stuck, open_run(out).recordings())
    assert d.verdict == "discrepancy"
    found = d.chosen[0]
    assert found.kind == joint.kind and found.stuck_stiffness_from_linear_part
    for name, true in joint.params.items():
        assert found.params[name] == pytest.approx(true, rel=0.05), name
