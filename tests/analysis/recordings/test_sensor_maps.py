"""Sensor maps: channels are not model DOFs (issue 14 item 3).

A 21-DOF FE beam with five named points, of which a run measures three (drive, joint,
payload) with mixed kinds (two accelerometers, one displacement probe); the force acts at the
measured drive point. Simulate at the mapped points -> NPZ/CSV/run round trip -> fit-linear
names the map's points; reverse path refuses an element at an unmeasured point and restricts
the model to the measured points when both ends are measured.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.plant import multisine, periodic
from analysis.models import Element, Model
from analysis.recordings import PeriodicLayout, Recording, SensorMap, model_at_sensors, one_kind
from nlid_lab import formats as rio
from nlid_lab import store
from nlid_lab.cli import main
from nlid_lab.commands.simulate import simulate_drive
from nlid_lab.formats import Drive
from structures import beam_with_payload, gvt_recording

MEASURED = ["drive", "joint", "payload"]
KINDS = ["acceleration", "acceleration", "displacement"]
FS, N = 1024.0, 2048


@pytest.fixture(scope="module")
def beam():
    return beam_with_payload()


@pytest.fixture(scope="module")
def named(beam):
    """The FE model with its five measurable DOFs named (the others ``n<i>``)."""
    m = beam.model
    names = [f"n{i}" for i in range(m.n_dof)]
    for k, i in beam.points.items():
        names[i] = k
    return Model(m.mass, m.damping, m.stiffness, [], "beam", names)


def _between(model, a, b):
    w = np.zeros(model.n_dof)
    w[model.point_index(a)], w[model.point_index(b)] = -1.0, 1.0
    return w


def _drive(periods=3, level=2.0, n=N, transient=1):
    f = periodic(multisine(n, FS, (3.0, 200.0), level, seed=7), periods + transient)
    return Drive(FS, f[:, None], np.array([0]), "random", level=level,
                 layout=PeriodicLayout(n, transient, periods, 1),
                 sensors={"response_points": MEASURED, "response_kinds": KINDS,
                          "force_points": ["drive"]})


def test_simulate_records_the_mapped_points_each_in_its_kind(named):
    drive = _drive()
    rec = simulate_drive(named, drive)
    assert rec.sensors == SensorMap(tuple(MEASURED), tuple(KINDS), ("drive",))
    assert rec.response_kind == "mixed" and rec.force_dofs.tolist() == [0]
    # the same drive on the full model, every point, one kind at a time
    plain = replace(drive, force_dofs=np.array([named.point_index("drive")]), sensors={})
    idx = [named.point_index(p) for p in MEASURED]
    for j, kind in enumerate(KINDS):
        full = simulate_drive(named, plain, response_kind=kind)
        np.testing.assert_array_equal(rec.response[:, j], full.response[:, idx[j]])


def test_every_sensor_key_survives_npz_run_csv_and_export(named, tmp_path):
    rec = simulate_drive(named, _drive(periods=1))
    rio.write_npz(tmp_path / "a.npz", rec)
    assert main(["import", str(tmp_path / "a.npz"), "--out", str(tmp_path / "r.h5")]) == 0
    assert store.open_run(tmp_path / "r.h5").channels[1]["name"] == "drive"
    for out in ("b.npz", "b.csv"):
        assert main(["export", str(tmp_path / "r.h5"), "--out", str(tmp_path / out)]) == 0
        back = rio.load_recordings(tmp_path / out)[0]
        assert back.sensors == rec.sensors and back.response_kind == "mixed"
        np.testing.assert_allclose(back.response, rec.response, rtol=1e-15)
    keys = rio.recording_keys(rio.read_npz(tmp_path / "b.npz"))
    assert keys["response_points"].tolist() == MEASURED
    assert keys["response_kinds"].tolist() == KINDS
    assert keys["force_points"].tolist() == ["drive"]


def test_import_sensors_toml_and_the_mat_channel_map(tmp_path):
    import scipy.io
    rng = np.random.default_rng(0)
    scipy.io.savemat(tmp_path / "x.mat", {"Force": rng.standard_normal((1, 512)),
                                          "Acc": rng.standard_normal((2, 512)),
                                          "Disp": rng.standard_normal((1, 512)), "Fs": 400.0})
    run = tmp_path / "x.h5"
    assert main(["import", str(tmp_path / "x.mat"), "--out", str(run), "--map", "force=Force:N@a",
                 "response=Acc[0:2]:m/s^2@a,b", "response=Disp:mm@c"]) == 0
    rec = store.open_run(run).recording()
    assert rec.sensors == SensorMap(("a", "b", "c"), ("acceleration",) * 2 + ("displacement",),
                                    ("a",))
    np.testing.assert_allclose(rec.response[:, 2], scipy.io.loadmat(tmp_path / "x.mat")
                               ["Disp"][0] / 1000)
    toml = tmp_path / "s.toml"
    toml.write_text('response_points = ["b", "a", "c"]\nforce_points = ["a"]\n')
    assert main(["import", str(tmp_path / "x.mat"), "--out", str(tmp_path / "y.h5"), "--map",
                 "force=Force:N", "response=Acc[0:2]:m/s^2", "response=Disp:mm",
                 "force_dofs=0", "--sensors", str(toml)]) == 0
    rec = store.open_run(tmp_path / "y.h5").recording()
    assert rec.sensors.response_points == ("b", "a", "c") and rec.force_dofs.tolist() == [1]
    # a force at a point no channel measures: one line, exit 2
    toml.write_text('response_points = ["b", "a", "c"]\nforce_points = ["tip"]\n')
    assert main(["import", str(tmp_path / "x.mat"), "--out", str(tmp_path / "z.h5"), "--map",
                 "force=Force:N", "response=Acc[0:2]:m/s^2", "response=Disp:mm",
                 "force_dofs=0", "--sensors", str(toml)]) == 2


def test_one_kind_differentiates_a_periodic_displacement_exactly(named):
    # 8 s periods, two of them transient: the free response of the first mode (6.6 Hz, 1 %
    # damping, decay rate 0.41 /s) has fallen to exp(-0.41 * 16) = 1.3e-3 of its start
    drive = _drive(periods=1, n=8 * N, transient=2)
    rec = simulate_drive(named, drive)
    acc = simulate_drive(named, replace(drive, sensors={"response_points": MEASURED,
                                                        "force_points": ["drive"]}),
                         response_kind="acceleration")
    got = one_kind(rec)
    assert got.response_kind == "acceleration" and got.sensors.kind == "acceleration"
    np.testing.assert_array_equal(got.response[:, :2], rec.response[:, :2])
    steady = slice(16 * N, None)
    err = np.abs(got.response[steady, 2] - acc.response[steady, 2]).max()
    # exact for a periodic record: what is left is that decayed transient (x10 margin)
    assert err < 1.3e-2 * np.abs(acc.response[steady, 2]).max(), err


def test_reverse_path_needs_the_element_end_points_measured(named, tmp_path, capsys):
    rec = simulate_drive(named, _drive(periods=1))
    at_tip = np.eye(named.n_dof)[named.point_index("tip")]          # grounded at the tip
    tip = named.with_elements([Element("cubic_spring", at_tip, {})])
    with pytest.raises(InputError, match=r"element 0 \(cubic_spring\) acts on point 'tip', "
                       "which no channel measures"):
        model_at_sensors(tip, [rec], "reverse path")
    model = tip.with_elements([Element("cubic_spring", _between(named, "joint", "payload"),
                                       {})])
    at = model_at_sensors(model, [rec])
    assert at.points == MEASURED and at.n_q == named.n_q
    np.testing.assert_array_equal(at.elements[0].w, [0.0, -1.0, 1.0])
    # the CLI: one line naming element and point, exit 2
    run, cand = tmp_path / "r.npz", tmp_path / "tip.toml"
    rio.write_npz(run, rec)
    tip.save(cand)
    assert main(["analyze", "reverse-path", str(run), "--model", str(cand)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines()
           if "compiling numeric kernels" not in line]
    assert len(err) == 1 and "element 0 (cubic_spring) acts on point 'tip'" in err[0], err


def test_report_figures_name_the_mapped_channels(named, tmp_path):
    """FRF figures of a run with a sensor map are titled by point and kind, not DOF."""
    from analysis.spectral import level_frf
    from nlid_lab.reports import _report as report
    from nlid_lab.reports import RunData
    rec = simulate_drive(named, _drive(periods=1))
    run = RunData(tmp_path / "r.h5", [rec])
    names = report.channel_names(run)
    assert names == (["drive (acceleration)", "joint (acceleration)",
                      "payload (displacement)"], ["drive"])
    (sec, *_) = report.frf_sections([level_frf(one_kind(rec))], names)
    titles = [fig.get_suptitle() for _, fig in sec.figures]
    assert titles[2] == "FRF per level: response payload (displacement) / force at drive"
