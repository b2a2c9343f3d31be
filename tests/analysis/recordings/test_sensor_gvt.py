"""End to end on a mapped GVT recording (issue 14 item 3): a 21-DOF FE beam measured at 3 of
its 5 named points (drive, joint, payload) by two accelerometers and a displacement probe;
the force cell behind the DAQ's anti-alias filter (``force_hold = "none"``), 1 % sensor noise,
a multisine with 4 transient periods of 4 s (the first mode, 6.6 Hz at 1 % damping, keeps
exp(-0.415 * 16) = 1.3e-3 of its transient) and 8 steady periods.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.models import Element, Model
from nlid_lab import formats as rio
from nlid_lab.cli import main
from sensor_scenarios import mapped_recording, multisine_drive, named_points
from structures import beam_with_payload

FS, UP, N = 1024.0, 2, 4096
MEASURED = ["drive", "joint", "payload"]
KINDS = ["acceleration", "acceleration", "displacement"]
POINTS = ["root", "drive", "joint", "tip", "payload"]


@pytest.fixture(scope="module")
def named():
    beam = beam_with_payload()
    return named_points(beam.model, beam.points)


def _run(model, level, seed=7):
    f, layout = multisine_drive(N, FS, (3.0, 200.0), level, realizations=1, periods=8,
                                transient=4, up=UP, seed=seed)
    return mapped_recording(model, MEASURED, KINDS, "drive", f, FS, UP, noise=0.01,
                            layout=layout, level=level)


def test_fit_linear_names_the_map_points_and_matches_the_frfs(named, tmp_path):
    rio.write_npz(tmp_path / "low.npz", _run(named, 2.0))
    out = tmp_path / "fit.toml"
    assert main(["fit-linear", str(tmp_path / "low.npz"), "--out", str(out), "--band", "3",
                 "200", "--json", str(tmp_path / "fit.json")]) == 0
    fit = Model.load(out)
    assert fit.points == MEASURED
    freqs = np.arange(3.0, 200.0, 0.25)
    exact = named.linear_frf(freqs, [named.point_index("drive")])[
        :, [named.point_index(p) for p in MEASURED], 0]
    got = fit.linear_frf(freqs, [fit.point_index("drive")])[:, :, 0]
    err = np.linalg.norm(got - exact, axis=0) / np.linalg.norm(exact, axis=0)
    # measured 1.3 / 0.9 / 2.1 %: the 5 %
    assert np.all(err < 0.05), err


@pytest.mark.slow
def test_diagnose_on_the_fe_modal_model_names_the_joint_pair(named, tmp_path, capsys):
    """The full 5-point FE-derived modal model, two levels recorded with the map, a cubic joint
    (p = 2e9) between the measured joint and payload points: the diagnosis names that pair
    and writes the corrected model over the model's 5 points (measured: p = 1.98e9)."""
    w = np.zeros(named.n_dof)
    w[named.point_index("joint")], w[named.point_index("payload")] = -1.0, 1.0
    truth = named.with_elements([Element("cubic_spring", w, {"p": 2e9})])
    runs = []
    for i, level in enumerate((2.0, 20.0)):
        runs.append(str(tmp_path / f"level{i}.npz"))
        rio.write_npz(runs[-1], _run(truth, level, seed=7 + i))
    named.modal_form(POINTS).save(tmp_path / "modal.toml")
    fixed = tmp_path / "fixed.toml"
    assert main(["diagnose", str(tmp_path / "modal.toml"), *runs, "--json",
                 str(tmp_path / "d.json"), "--model-out", str(fixed)]) == 0
    d = json.loads((tmp_path / "d.json").read_text())
    assert d["verdict"] == "discrepancy"
    first = d["missing_physics"][0]
    assert first["kind"] == "cubic_spring" and first["points"] == ["joint", "payload"], first
    model = Model.load(fixed)
    assert model.points == POINTS
    (el,) = model.elements
    assert el.kind == "cubic_spring"
    assert np.flatnonzero(el.w).tolist() == [POINTS.index("joint"), POINTS.index("payload")]
