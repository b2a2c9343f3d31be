"""fit-linear on a ground-vibration-test-like structure: a 21-DOF FE beam with a payload on a
joint, four accelerometers with 1 % noise, force measured through the DAQ's anti-alias filter,
periodic multisine (analysis.modal._linear_fit, nlid-lab fit-linear)."""

import json

import numpy as np
import pytest

from analysis.plant import Plant, multisine, periodic
from analysis.spectral import convert_frf
from analysis.modal import fit_linear
from analysis.models import Model
from analysis.recordings import PeriodicLayout
from nlid_lab.cli import main
from nlid_lab.formats import write_npz
from structures import beam_with_payload, gvt_recording

NAMES = ["drive", "joint", "tip", "payload"]
BAND = (3.0, 200.0)
FS, N, UP = 1024.0, 2048, 8


@pytest.fixture(scope="module")
def beam():
    return beam_with_payload()


def lowest_level(beam, level=2.0, periods=8):
    fine = multisine(N * UP, FS * UP, (1.0, 220.0), level, seed=7)
    return gvt_recording(beam, NAMES, "drive", periodic(fine, periods + 1), FS, UP,
                         layout=PeriodicLayout(N, 1, periods, 1), level=level)


def accelerance_error(model, beam, freqs):
    sensors = [beam.points[k] for k in NAMES]
    truth = beam.model.linear_frf(freqs, [beam.points["drive"]])[:, sensors, 0]
    mine = model.linear_frf(freqs, [model.point_index("drive")])[:, :, 0]
    a, b = (convert_frf(x, freqs, "displacement", "acceleration") for x in (mine, truth))
    return np.linalg.norm(a - b, axis=0) / np.linalg.norm(b, axis=0)


def test_modes_and_frfs_of_the_fe_model_from_its_lowest_level(beam):
    fit = fit_linear(lowest_level(beam), BAND, points=NAMES)
    fn = beam.natural_frequencies()
    fn = fn[fn < BAND[1]]
    assert fit.modes.freqs_hz.size == fn.size == 4          # every mode in band, found alone
    np.testing.assert_allclose(fit.modes.freqs_hz, fn, rtol=0.005)
    np.testing.assert_allclose(fit.modes.damping, 0.01, rtol=0.10)
    # the model's FRFs at the sensors (the measured kind) against the FE model's exact ones
    err = accelerance_error(fit.model, beam, np.arange(*BAND, 0.05))
    assert err.max() < 0.05, err
    assert fit.frf_error.max() < 0.05                       # and against the data it fitted
    assert fit.model.points == NAMES and fit.model.is_modal


def test_plant_on_the_modal_model_equals_the_fe_model_at_the_sensors(beam):
    sensors = [beam.points[k] for k in NAMES]
    modal = beam.model.modal_form(sensors, NAMES)
    force = np.random.default_rng(0).standard_normal((4096, 1))
    full = Plant(beam.model, 2048.0, [beam.points["drive"]], response_kind="acceleration")
    mine = Plant(modal, 2048.0, [0], response_kind="acceleration")
    a, b = full.run(force).response[:, sensors], mine.run(force).response
    assert np.abs(a - b).max() <= 1e-6 * np.abs(a).max()
    back = Model.loads(modal.dumps())                       # and through its file
    np.testing.assert_allclose(back.linear_frf([10.0, 50.0], [0]),
                               modal.linear_frf([10.0, 50.0], [0]), rtol=1e-12)


def test_cli_writes_a_model_the_other_commands_load(beam, tmp_path, capsys):
    rec = tmp_path / "low.npz"
    write_npz(rec, lowest_level(beam))
    out, png, js = tmp_path / "gvt.toml", tmp_path / "stab.png", tmp_path / "fit.json"
    assert main(["fit-linear", str(rec), "--out", str(out), "--band", "3", "200",
                 "--points", ",".join(NAMES), "--plot", str(png), "--json", str(js)]) == 0
    text = capsys.readouterr().out
    assert "4 mode(s)" in text and "FRF error" in text and "drive" in text
    model = Model.load(out)
    assert model.points == NAMES and model.n_dof == 4
    result = json.loads(js.read_text())
    assert [round(m["freq_hz"], 1) for m in result["modes"]] == \
        [round(f, 1) for f in model.natural_frequencies() if 3.0 < f < 200.0]  # no pseudo
    assert png.stat().st_size > 10_000
    pseudo = result["residual_pseudo_modes_hz"]
    assert len(pseudo) == model.n_residual
    assert all(f < 3.0 or f > 200.0 for f in pseudo)      # outside the band, as written
    # never overwritten without --force; a bad --modes is one line, exit 2
    assert main(["fit-linear", str(rec), "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["fit-linear", str(rec), "--out", str(tmp_path / "x.toml"),
                 "--modes", "many"]) == 2
    assert "--modes many" in capsys.readouterr().err
