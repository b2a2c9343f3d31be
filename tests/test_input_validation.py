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
