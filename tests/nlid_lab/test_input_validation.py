"""Malformed inputs of every format (model TOML, campaign TOML, NPZ and CSV recordings):
generated mutations either succeed or end in exit 2 with one line, within a time bound, and
a mutation that breaks a documented rule is never accepted (tests/fuzz_inputs.py)."""

from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from analysis.errors import ModelError
from analysis.models import MAX_ENTRY, MAX_PARAM, Model
from nlid_lab.campaign import CampaignError, parse_campaign

from fuzz_inputs import (CAMPAIGN, MODEL, bad_arrays, campaign_number_invalid, check_outcome,
                         model_number_invalid, mutations, run_cli, toml_text)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
FS = 1024.0
# NLID_FUZZ_EXAMPLES=400 for a long sweep; the fast suite keeps a modest count
FUZZ = settings(max_examples=int(os.environ.get("NLID_FUZZ_EXAMPLES", 25)), deadline=None,
                derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                         HealthCheck.too_slow])

# --- model files -----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    path = tmp_path_factory.mktemp("drive") / "drive.npz"
    rng = np.random.default_rng(0)
    np.savez(path, fs=FS, force=rng.normal(size=(512, 1)), force_dofs=[1], force_rms=1.0)
    return path


def test_base_model_is_valid():
    assert Model.from_dict(MODEL).complete


@FUZZ
@given(case=mutations(MODEL, model_number_invalid))
def test_mutated_models_load_or_name_the_problem(case):
    doc, what, invalid = case
    try:
        Model.loads(toml_text(doc))
    except ModelError as exc:
        assert "\n" not in str(exc)
        return
    assert not invalid, f"{what}: accepted"


@FUZZ
@given(case=mutations(MODEL, model_number_invalid))
def test_mutated_models_through_simulate(case, drive, tmp_path):
    doc, what, invalid = case
    model = tmp_path / "m.toml"
    model.write_text(toml_text(doc))
    out = tmp_path / "out.npz"
    out.unlink(missing_ok=True)
    code, err, _ = run_cli(["simulate", str(model), "--drive", str(drive), "--out", str(out)],
                        seconds=60)
    check_outcome(code, err, invalid, what)


# --- NPZ and CSV recordings -------------------------------------------------------------------
SDOF = """
[linear]
mass = [[2.0]]
damping = [[10.0]]
stiffness = [[2.0e5]]
[[element]]
kind = "cubic_spring"
w = [1.0]
"""
REQUIRED = {"fs", "force", "response", "force_dofs"}


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """A random and a stepped-sine NPZ of an SDOF cubic oscillator, and the candidate model."""
    from analysis.plant import simulate
    d = tmp_path_factory.mktemp("recs")
    truth = Model.loads(SDOF + "p = 6e10\n")
    force = np.random.default_rng(1).normal(scale=5.0, size=(4096, 1))
    x = simulate(truth, force, FS, [0])
    random = {"fs": FS, "force_dofs": np.array([0]), "force": force, "response": x,
              "force_rms": 5.0}
    t = np.arange(256) / FS
    freqs = np.array([40.0, 50.0, 60.0])
    steps = np.stack([20.0 * np.sin(2 * np.pi * f * t)[:, None] for f in freqs])
    xs = np.stack([simulate(truth, s, FS, [0]) for s in steps])
    stepped = {"fs": FS, "force_dofs": np.array([0]), "force": steps, "response": xs,
               "freqs": freqs, "force_amplitude": 20.0}
    (d / "cand.toml").write_text(SDOF)
    np.savez(d / "random.npz", **random)
    np.savez(d / "stepped.npz", **stepped)
    return d, {"random": random, "stepped": stepped}


@st.composite
def npz_mutations(draw, recs: dict) -> tuple[str, dict, str, bool]:
    kind = draw(st.sampled_from(sorted(recs)))
    data = dict(recs[kind])
    key = draw(st.sampled_from(sorted(data)))
    change = draw(st.sampled_from(["delete"] + sorted(bad_arrays(data[key]))))
    if change == "delete":
        del data[key]
        return kind, data, f"{kind}: {key} deleted", key in REQUIRED
    data[key], invalid = bad_arrays(data[key])[change]
    if key in ("force_rms", "force_amplitude") and change in ("negative", "zeros"):
        invalid = True
    return kind, data, f"{kind}: {key} {change}", invalid


@FUZZ
@given(data=st.data())
def test_mutated_npz_recordings_through_the_commands(data, recordings, tmp_path):
    from nlid_lab.methods import BatchOptions
    from nlid_lab.reanalyze import analyse_run
    folder, recs = recordings
    kind, arrays, what, invalid = data.draw(npz_mutations(recs))
    path = tmp_path / "rec.npz"
    np.savez(path, **arrays)
    run = tmp_path / "run.h5"
    run.unlink(missing_ok=True)
    method = "reverse-path" if kind == "random" else "hbm"
    for argv in (["import", str(path), "--out", str(run)], ["detect", str(path)],
                 ["analyze", method, str(path), "--model", str(folder / "cand.toml")]):
        code, err, _ = run_cli(argv, seconds=60)
        check_outcome(code, err, invalid, f"{argv[0]} {what}")
    if run.exists():
        uff = tmp_path / "frf.uff"
        uff.unlink(missing_ok=True)
        code, err, _ = run_cli(["export-uff", str(run), "--out", str(uff)], seconds=60)
        check_outcome(code, err, False, f"export-uff {what}")
    model = Model.loads(SDOF)
    for row in analyse_run(str(path), model, method, BatchOptions()):
        if not row.ok:  # a reanalysis row names an input problem, not a raw error
            assert "Error:" not in row.error, f"reanalyze {what}: {row.error}"
            assert not invalid or row.level_index == -1 or "level" in row.error
        else:
            assert not invalid, f"reanalyze {what}: accepted"


CANDIDATE = {"name": "candidate",
             "linear": {"mass": [[2.0]], "damping": [[10.0]], "stiffness": [[2.0e5]]},
             "element": [{"kind": "cubic_spring", "w": [1.0]},
                         {"kind": "quadratic_damping", "w": [1.0], "p": 1.0}]}


def candidate_number_invalid(path: tuple, value: float) -> bool:
    if path[0] == "linear":
        return abs(value) > MAX_ENTRY or value < 0 or (path[1] == "mass" and value < 1e-6)
    return abs(value) > MAX_PARAM or (path[2] == "w" and value == 0)


@FUZZ
@given(case=mutations(CANDIDATE, candidate_number_invalid))
def test_mutated_candidates_through_analyze(case, recordings, tmp_path):
    folder, _ = recordings
    doc, what, invalid = case
    model = tmp_path / "cand.toml"
    model.write_text(toml_text(doc))
    rec = folder / "random.npz"
    code, err, _ = run_cli(["analyze", "reverse-path", str(rec), "--model", str(model)],
                           seconds=60)
    check_outcome(code, err, invalid, f"analyze {what}")


@pytest.mark.slow
@settings(FUZZ, max_examples=40)
@given(case=mutations(CANDIDATE, candidate_number_invalid))
def test_mutated_models_through_hbm_and_diagnose(case, recordings, tmp_path):
    folder, _ = recordings
    doc, what, invalid = case
    model = tmp_path / "m.toml"
    model.write_text(toml_text(doc))
    stepped = folder / "stepped.npz"
    code, err, _ = run_cli(["analyze", "hbm", str(stepped), "--model", str(model)],
                           seconds=120)
    check_outcome(code, err, invalid, f"analyze hbm {what}")
    complete = copy.deepcopy(doc)
    for el in complete.get("element", []) if isinstance(complete.get("element"), list) else []:
        if isinstance(el, dict) and el.get("kind") == "cubic_spring" and "p" not in el:
            el["p"] = 6e10
    model.write_text(toml_text(complete))
    code, err, _ = run_cli(["diagnose", str(model), str(stepped)], seconds=120)
    check_outcome(code, err, invalid, f"diagnose {what}")


CSV_CELLS = ["abc", "1+2j", "nan", "inf", "1e300", "", "true", "0x10"]


@FUZZ
@given(row=st.integers(0, 40), col=st.integers(0, 2), cell=st.sampled_from(CSV_CELLS))
def test_mutated_csv_recordings_are_refused_in_one_line(row, col, cell, recordings, tmp_path):
    _, recs = recordings
    rec = recs["random"]
    t = np.arange(64) / FS
    lines = ["t,f0@0,x0@0"] + [f"{a!r},{b!r},{c!r}" for a, b, c in
                               zip(t, rec["force"][:64, 0], rec["response"][:64, 0])]
    cells = lines[1 + row].split(",")
    cells[col] = cell
    lines[1 + row] = ",".join(cells)
    path = tmp_path / "rec.csv"
    path.write_text("\n".join(lines) + "\n")
    run = tmp_path / "run.h5"
    run.unlink(missing_ok=True)
    code, err, _ = run_cli(["import", str(path), "--out", str(run)], seconds=60)
    check_outcome(code, err, True, f"csv row {row} col {col} = {cell!r}")


# --- campaign files ---------------------------------------------------------------------------
def _write_campaign(tmp_path, doc: dict) -> Path:
    path = tmp_path / "c.toml"
    path.write_text(toml_text(doc))
    return path


@FUZZ
@given(case=mutations(CAMPAIGN, campaign_number_invalid))
def test_mutated_campaigns_check_or_name_the_problem(case, tmp_path):
    doc, what, invalid = case
    path = _write_campaign(tmp_path, doc)
    code, err, _ = run_cli(["campaign", "check", str(path)], seconds=30)
    check_outcome(code, err, invalid, what)


def test_campaign_typo_names_the_nearest_key():
    doc = copy.deepcopy(CAMPAIGN)
    doc["random"]["avrages"] = doc["random"].pop("averages")
    with pytest.raises(CampaignError, match=r"\[random\]: unknown key 'avrages'; did you mean "
                                            "'averages'"):
        parse_campaign(doc)


def test_plant_model_that_is_a_device_is_refused(tmp_path):
    doc = copy.deepcopy(CAMPAIGN)
    doc["plant"]["model"] = "/dev/zero"
    code, err, _ = run_cli(["campaign", "check", str(_write_campaign(tmp_path, doc))], seconds=10)
    check_outcome(code, err, True, "plant.model = /dev/zero")
    assert "not a regular file" in err


@pytest.mark.parametrize("section,changes", [
    ("random", {"levels": [1.0] * 2000}), ("random", {"averages": 100000}),
    ("random", {"block_size": 2**22, "averages": 1000}),
])
def test_huge_campaign_plans_need_yes(tmp_path, section, changes):
    doc = copy.deepcopy(CAMPAIGN)
    doc[section].update(changes)
    path, out = _write_campaign(tmp_path, doc), tmp_path / "run.h5"
    code, _, out_text = run_cli(["campaign", "check", str(path)], seconds=10)
    assert code == 0 and "campaign run needs --yes" in out_text
    code, err, _ = run_cli(["campaign", "run", str(path), "--out", str(out)], seconds=10)
    check_outcome(code, err, True, str(changes))
    assert "pass --yes" in err and "measurement time" in err and not out.exists()


def test_stepped_plan_with_millihertz_steps_needs_yes(tmp_path):
    doc = copy.deepcopy(CAMPAIGN)
    del doc["random"]
    doc["kind"] = "stepped-sine"
    doc["stepped"] = {"levels": [1.0], "start": 10.0, "stop": 60.0, "step": 0.001,
                      "block_size": 512}
    code, err, _ = run_cli(["campaign", "run", str(_write_campaign(tmp_path, doc)), "--out",
                         str(tmp_path / "run.h5")], seconds=10)
    check_outcome(code, err, True, "1 mHz steps")
    assert "more than 60.0 min" in err


def test_plan_is_printed_and_yes_runs_a_plan_over_the_bound(tmp_path, monkeypatch):
    from nlid_lab.campaign import _campaign_config as campaign_config
    doc = copy.deepcopy(CAMPAIGN)
    doc["random"].update(levels=[5.0], averages=2, block_size=1024)
    path, out = _write_campaign(tmp_path, doc), tmp_path / "run.h5"
    monkeypatch.setattr(campaign_config, "MAX_PLAN_S", 1.0)
    code, err, _ = run_cli(["campaign", "run", str(path), "--out", str(out)], seconds=10)
    assert code == 2 and not out.exists()
    code, err, _ = run_cli(["campaign", "run", str(path), "--out", str(out), "--yes"],
                        seconds=120)
    assert code == 0 and out.exists(), err
    assert err.splitlines()[0].startswith("campaign 'sim random': measurement time")


STIFF = ("[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstiffness = [[1e15]]\n"
         "[[element]]\nkind = 'cubic_spring'\nw = [1.0]\np = 1e9\n")


def test_simulations_bound_their_work(tmp_path):
    """A valid but stiff nonlinear model (5 MHz mode) asks ~1e5 substeps per sample: a long
    drive is refused before the plant starts, by simulate and by a simulated campaign."""
    model = tmp_path / "stiff.toml"
    model.write_text(STIFF)
    drive = tmp_path / "drive.npz"
    np.savez(drive, fs=FS, force=np.ones((65536, 1)), force_dofs=[0])
    code, err, _ = run_cli(["simulate", str(model), "--drive", str(drive), "--out",
                            str(tmp_path / "o.npz")], seconds=10)
    check_outcome(code, err, True, "stiff simulate")
    assert "plant substeps" in err
    doc = copy.deepcopy(CAMPAIGN)
    doc["plant"]["model"] = str(model)
    path, out = _write_campaign(tmp_path, doc), tmp_path / "run.h5"
    code, err, _ = run_cli(["campaign", "run", str(path), "--out", str(out)], seconds=10)
    check_outcome(code, err, True, "stiff campaign")
    assert "plant substeps" in err and "pass --yes" in err and not out.exists()


def test_numeric_warnings_never_precede_a_one_line_error(monkeypatch):
    """RuntimeWarnings of a command that ends in bad input are dropped (the error names the
    cause); after a success each distinct one is shown on one line."""
    from analysis.errors import InputError
    from nlid_lab.commands import detect

    def noisy(args, fail: bool):
        for _ in range(3):
            np.log(np.zeros(1))
        if fail:
            raise InputError("the input is bad; fix it")
        return 0

    monkeypatch.setattr(detect, "run", lambda args: noisy(args, True))
    code, err, _ = run_cli(["detect", "x.npz"], seconds=10)
    assert code == 2 and err == "nlid-lab: error: the input is bad; fix it\n"
    monkeypatch.setattr(detect, "run", lambda args: noisy(args, False))
    code, err, _ = run_cli(["detect", "x.npz"], seconds=10)
    assert code == 0
    assert err == "warning: RuntimeWarning: divide by zero encountered in log\n"
