"""Stepped-sine friction scenario and the ``nlid-lab diagnose`` command (NPZ and HDF5 runs)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.diagnose import diagnose
from analysis.models import Model
from nlid_lab.cli import main
from nlid_lab.formats import write_npz
from nlid_lab.store import open_run, save_recording

from diagnose_scenarios import hidden_cubic, masked_friction, stepped_stiffness_error
from golden_cases import GOLDEN, same_as_golden, without_added_keys
from test_diagnose import check


def test_stick_slip_masked_by_ten_percent_noise_on_stepped_sine():
    sc = masked_friction(noise=0.10)
    d = diagnose(sc.start, sc.recordings)
    check(sc, d, rel_tol=0.05)
    assert d.evidence.odd_harmonic_ratio > 0.01     # harmonic signature of the friction
    assert d.ranking[0].evidence["estimator"] == "harmonic-balance fit"


def test_level_independent_stiffness_error_on_stepped_sine():
    sc = stepped_stiffness_error()
    d = diagnose(sc.start, sc.recordings)
    check(sc, d, rel_tol=0.05)
    assert d.model.stiffness[1, 2] == pytest.approx(-1.5e4, rel=0.01)


@pytest.fixture(scope="module")
def cubic_files(tmp_path_factory):
    sc = hidden_cubic(n=1 << 15)
    root = tmp_path_factory.mktemp("diag")
    sc.start.save(root / "start.toml")
    npz, h5 = [], []
    for i, rec in enumerate(sc.recordings):
        write_npz(root / f"level{i}.npz", rec)
        save_recording(root / f"level{i}.h5", rec)
        npz.append(str(root / f"level{i}.npz"))
        h5.append(str(root / f"level{i}.h5"))
    return sc, root, npz, h5


def test_npz_and_hdf5_runs_load_the_same_recordings(cubic_files):
    """Every field the diagnosis reads is equal whether a level was written as NPZ or into an
    HDF5 run; only ``meta`` (where it came from, outside the contract) differs. The diagnosis
    of the NPZ runs is therefore slow-only (`test_cli_diagnose_runs_on_npz_and_hdf5[npz]`):
    `make test` diagnoses the HDF5 runs."""
    import dataclasses

    from nlid_lab.formats import load_recordings
    _, _, npz, h5 = cubic_files
    for a_path, b_path in zip(npz, h5):
        (a,), (b,) = load_recordings(a_path), load_recordings(b_path)
        for field in dataclasses.fields(a):
            if field.name == "meta":
                continue
            x, y = getattr(a, field.name), getattr(b, field.name)
            if isinstance(x, np.ndarray):
                np.testing.assert_array_equal(x, y, err_msg=field.name)
                assert x.dtype == y.dtype, field.name
            else:
                assert x == y, field.name


@pytest.mark.parametrize("kind", [pytest.param("npz", marks=pytest.mark.slow), "h5"])
def test_cli_diagnose_runs_on_npz_and_hdf5(cubic_files, kind, diagnose_once):
    """The command on NPZ files (slow: they load as the HDF5 runs do,
    `test_npz_and_hdf5_runs_load_the_same_recordings`) and on HDF5 runs."""
    sc, root, npz, h5 = cubic_files
    runs = npz if kind == "npz" else h5
    out, fixed = root / f"out-{kind}.json", root / f"fixed-{kind}.toml"
    rc = main(["diagnose", str(root / "start.toml"), *runs, "--json", str(out),
               "--model-out", str(fixed), "--report", str(root / f"report-{kind}")])
    assert rc == 0
    res = json.loads(out.read_text())
    # the golden case's command on the same runs (test_diagnose_golden runs it as slow)
    assert same_as_golden(without_added_keys(out.read_text()),
                          (GOLDEN / "random-cubic.json").read_text())
    assert res["verdict"] == "discrepancy" and res["level_dependent"] is True
    assert res["missing_physics"][0]["kind"] == "cubic_spring"
    assert res["location"]["dofs"] == [2]
    assert res["fit"]["after"] <= 0.5 * res["fit"]["before"]
    assert res["explanation"]
    model = Model.load(fixed)
    assert model.elements[-1].kind == "cubic_spring"
    assert np.allclose(model.elements[-1].w, [0, 0, 1])
    assert (root / f"report-{kind}" / "report.md").exists()
    assert list((root / f"report-{kind}").glob("*.png"))


def test_cli_bad_input_exits_2(cubic_files, capsys):
    sc, root, npz, _ = cubic_files
    two = Model(np.eye(2), np.eye(2), np.eye(2) * 1e4)
    two.save(root / "two.toml")
    assert main(["diagnose", str(root / "two.toml"), *npz]) == 2
    err = capsys.readouterr().err.strip()
    assert "DOFs" in err and "\n" not in err
    assert main(["diagnose", str(root / "start.toml"), npz[0], "--holdout", "99"]) == 2


def test_stepped_sine_adequate_model_gives_no_false_alarm():
    sc = masked_friction(noise=0.10)
    d = diagnose(sc.truth, sc.recordings)
    assert d.verdict == "adequate", d.explanation
    assert d.level_dependent is True


def test_cli_store_puts_the_diagnosis_into_the_run_report(cubic_files, tmp_path,
                                                          diagnose_once):
    """The diagnosis of the HDF5 runs (computed once with the test above: `diagnose_once`)
    stored into a copy of the last one, then in its report."""
    sc, root, _, h5 = cubic_files
    import shutil
    run = tmp_path / "run.h5"
    shutil.copy(h5[-1], run)
    rc = main(["diagnose", str(root / "start.toml"), *h5, "--store", str(run),
               "--json", str(tmp_path / "out.json")])
    assert rc == 0
    stored = open_run(run).results["diagnose"]
    assert stored == json.loads((tmp_path / "out.json").read_text())
    assert main(["report", str(run), "--out", str(tmp_path / "report")]) == 0
    assert (tmp_path / "report" / "diagnosis_fit.png").exists()
    assert "Diagnosis" in (tmp_path / "report" / "index.html").read_text()
    assert main(["diagnose", str(root / "start.toml"), *h5, "--store", "x.npz"]) == 2
