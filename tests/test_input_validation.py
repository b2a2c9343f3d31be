"""Malformed inputs of every format (model TOML, campaign TOML, NPZ and CSV recordings):
generated mutations either succeed or end in exit 2 with one line, within a time bound, and
a mutation that breaks a documented rule is never accepted (tests/fuzz_inputs.py)."""

from __future__ import annotations

import copy
import os
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from analysis.errors import ModelError
from analysis.model import MAX_ENTRY, MAX_PARAM, Model
from nlid_lab.campaign_config import CampaignError, parse_campaign

from fuzz_inputs import check_outcome, mutations, run_cli, toml_text

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FS = 1024.0
# NLID_FUZZ_EXAMPLES=400 for a long sweep; the fast suite keeps a modest count
FUZZ = settings(max_examples=int(os.environ.get("NLID_FUZZ_EXAMPLES", 25)), deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])

# --- model files -----------------------------------------------------------------------------
MODEL = {
    "name": "two dof",
    "linear": {"mass": [[1.0, 0.0], [0.0, 2.0]], "damping": [[20.0, -10.0], [-10.0, 20.0]],
               "stiffness": [[2e4, -1e4], [-1e4, 2e4]]},
    "element": [{"kind": "cubic_spring", "w": [1.0, 0.0], "p": 1e9},
                {"kind": "gap", "w": [-1.0, 1.0], "k": 1e4, "g": 1e-3},
                {"kind": "hysteresis", "w": [0.0, 1.0], "kd": 1e4, "fd": 2.0, "n": 2.0},
                {"kind": "coulomb_friction", "w": [0.0, 1.0], "fc": 0.5, "v_reg": 1e-2}],
}
POSITIVE = {"g", "k", "kd", "fd", "n", "v_reg"}


def model_number_invalid(path: tuple, value: float) -> bool:
    """Numbers that break a rule of docs/model-format.md for certain in `MODEL`."""
    if path[0] == "linear":
        matrix, r, c = path[1], path[2], path[3]
        old = MODEL["linear"][matrix][r][c]
        return (abs(value) > MAX_ENTRY or (r != c and abs(value - old) > 1e-6)
                or (r == c and value < 0) or (matrix == "mass" and r == c and value < 1e-6))
    if path[2] == "w":
        return abs(value) > MAX_ENTRY
    return abs(value) > MAX_PARAM or (path[2] in POSITIVE and value <= 0)


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
    code, err = run_cli(["simulate", str(model), "--drive", str(drive), "--out", str(out)],
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
    return d, {"random": random, "stepped": stepped}


def _bad_arrays(value: np.ndarray) -> dict[str, tuple[np.ndarray, bool]]:
    """Replacements of one NPZ entry, and whether each breaks a documented rule for sure."""
    arr = np.asarray(value)
    return {"complex": (arr + 1j, True), "text": (np.full(arr.shape, "abc"), True),
            "bool": (arr != 0, True), "nan": (np.full(arr.shape, np.nan), True),
            "huge": (np.full(arr.shape, 1e300), True), "tiny": (arr * 1e-300, False),
            "negative": (-np.abs(arr) - 1, False), "empty": (arr.reshape(-1)[:0], True),
            "first sample": (arr[..., :1, :] if arr.ndim >= 2 else arr, arr.ndim >= 2),
            "transposed": (arr.T, False), "zeros": (np.zeros_like(arr), False)}


@st.composite
def npz_mutations(draw, recs: dict) -> tuple[str, dict, str, bool]:
    kind = draw(st.sampled_from(sorted(recs)))
    data = dict(recs[kind])
    key = draw(st.sampled_from(sorted(data)))
    change = draw(st.sampled_from(["delete"] + sorted(_bad_arrays(data[key]))))
    if change == "delete":
        del data[key]
        return kind, data, f"{kind}: {key} deleted", key in REQUIRED
    data[key], invalid = _bad_arrays(data[key])[change]
    if key in ("force_rms", "force_amplitude") and change in ("negative", "zeros"):
        invalid = True
    return kind, data, f"{kind}: {key} {change}", invalid


@FUZZ
@given(data=st.data())
def test_mutated_npz_recordings_through_the_commands(data, recordings, tmp_path):
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
        code, err = run_cli(argv, seconds=60)
        check_outcome(code, err, invalid, f"{argv[0]} {what}")
    if run.exists():
        uff = tmp_path / "frf.uff"
        uff.unlink(missing_ok=True)
        code, err = run_cli(["export-uff", str(run), "--out", str(uff)], seconds=60)
        check_outcome(code, err, False, f"export-uff {what}")
    model = Model.loads(SDOF)
    for row in analyse_run(str(path), model, method, {}):
        if row["status"] != "ok":  # a reanalysis row names an input problem, not a raw error
            assert "Error:" not in row["error"], f"reanalyze {what}: {row['error']}"
            assert not invalid or row["level_index"] == -1 or "level" in row["error"]
        else:
            assert not invalid, f"reanalyze {what}: accepted"


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
    code, err = run_cli(["import", str(path), "--out", str(run)], seconds=60)
    check_outcome(code, err, True, f"csv row {row} col {col} = {cell!r}")
