"""Monitor channels (neither force nor response, e.g. a GVT export's amplifier ``Voltage``):
kept through channel maps, NPZ/CSV/MAT files, the run store and export, level by level."""

import json

import numpy as np
import pytest
import scipy.io

from analysis.errors import InputError
from analysis.recordings import Recording
from nlid_lab import store
from nlid_lab.cli import main
from nlid_lab.formats import ChannelMap, apply_map
from nlid_lab import formats as rio

N, FS = 1200, 400.0


def gvt(seed: int) -> dict:
    """The channels of a commercial GVT export: Force 1xN, Voltage 1xN, Acceleration 3xN."""
    rng = np.random.default_rng(seed)
    force = rng.standard_normal(N)
    return {"Force": force[None, :],
            "Voltage": 0.1 * force[None, :] + 1e-3 * rng.standard_normal(N),
            "Acceleration": rng.standard_normal((3, N)), "Fs": FS}


def test_unmapped_channels_are_kept_as_monitors_by_default():
    tree = {f"data.{k}": v for k, v in gvt(0).items()}
    keys = apply_map(tree, ChannelMap.from_items(["force=Force", "response=Acceleration"]), "x")
    assert keys["monitor_names"].tolist() == ["Voltage"]
    np.testing.assert_array_equal(keys["monitor"][:, 0], tree["data.Voltage"][0])
    rec = rio.recording_from_keys({**keys, "force_dofs": 0}, "x")
    np.testing.assert_array_equal(rec.monitors["Voltage"], tree["data.Voltage"][0])


def test_map_names_monitors_with_columns_and_units_or_none(tmp_path):
    tree = gvt(1)
    keys = apply_map(tree, ChannelMap.from_items(
        ["force=Force", "response=Acceleration[0:2]", "monitor=Voltage:V",
         "monitor=Acceleration[2]:g"]), "x")
    assert keys["monitor_names"].tolist() == ["Voltage", "Acceleration[2]"]
    assert keys["monitor_units"].tolist() == ["V", "g"]
    np.testing.assert_array_equal(keys["monitor"][:, 1], tree["Acceleration"][2])  # as recorded
    keys = apply_map(tree, ChannelMap.from_items(["force=Force", "response=Acceleration",
                                                  "monitor=none"]), "x")
    assert "monitor" not in keys
    mapfile = tmp_path / "map.toml"
    mapfile.write_text('force = "Force"\nresponse = ["Acceleration[0:2]"]\n'
                       'monitor = ["Voltage:V"]\n')
    keys = apply_map(tree, ChannelMap.from_toml(mapfile), "x")
    assert keys["monitor_names"].tolist() == ["Voltage"]
    with pytest.raises(InputError, match="no model point"):
        ChannelMap.from_items(["force=Force", "response=Acceleration", "monitor=Voltage@tip"])


def _voltage(path) -> np.ndarray:
    return np.asarray(scipy.io.loadmat(path)["Voltage"], dtype=float).ravel()


def test_mat_import_run_export_import_keeps_voltage(tmp_path, capsys):
    """MAT -> import -> run -> export MAT/NPZ/CSV -> import: Voltage identical, per level."""
    files = []
    for i in range(2):
        files.append(tmp_path / f"level{i}.mat")
        scipy.io.savemat(files[-1], gvt(10 + i))
    run = tmp_path / "gvt.h5"
    js = tmp_path / "import.json"
    assert main(["import", *map(str, files), "--out", str(run), "--map", "force=Force",
                 "response=Acceleration[0:3]:g", "monitor=Voltage:V", "force_dofs=0",
                 "--json", str(js)]) == 0
    assert json.loads(js.read_text())["monitors"] == {"Voltage": "V"}
    recs = store.open_run(run).recordings()
    for i, rec in enumerate(recs):
        np.testing.assert_array_equal(rec.monitors["Voltage"], _voltage(files[i]))
        assert rec.monitor_units == {"Voltage": "V"}
    for suffix in (".mat", ".npz", ".csv"):
        out, back = tmp_path / f"exported{suffix}", tmp_path / f"back{suffix}.h5"
        assert main(["export", str(run), "--level", "1", "--out", str(out)]) == 0
        assert main(["import", str(out), "--out", str(back)]) == 0
        rec = store.open_run(back).recording()
        np.testing.assert_array_equal(rec.monitors["Voltage"], _voltage(files[1]))
        assert rec.monitor_units == {"Voltage": "V"}
        np.testing.assert_array_equal(rec.force, recs[1].force)


def test_default_monitors_said_on_import_and_levels_must_share_them(tmp_path, capsys):
    a, b = tmp_path / "a.mat", tmp_path / "b.mat"
    scipy.io.savemat(a, gvt(3))
    scipy.io.savemat(b, {k: v for k, v in gvt(4).items() if k != "Voltage"})
    out = tmp_path / "r.h5"
    assert main(["import", str(a), "--out", str(out), "--map", "force=Force",
                 "response=Acceleration", "force_dofs=0"]) == 0
    said = capsys.readouterr().out
    assert "monitor channel(s) kept" in said and "Voltage" in said and "monitor=none" in said
    assert main(["import", str(a), str(b), "--out", str(out), "--force", "--map",
                 "force=Force", "response=Acceleration", "force_dofs=0"]) == 2
    err = capsys.readouterr().err
    assert "has monitor channels [] but the first ['Voltage']" in err and "monitor=none" in err
    assert main(["import", str(a), str(b), "--out", str(out), "--force", "--map",
                 "force=Force", "response=Acceleration", "force_dofs=0", "monitor=none"]) == 0


def test_csv_export_without_time_column_keeps_voltage(tmp_path):
    """The F-16 benchmark layout: Force,Voltage,Acceleration1,Acceleration2,Acceleration3."""
    ch = gvt(5)
    path = tmp_path / "f16.csv"
    cols = [ch["Force"][0], ch["Voltage"][0], *ch["Acceleration"]]
    np.savetxt(path, np.column_stack(cols), delimiter=",", fmt="%.17g",
               header="Force,Voltage (V),Acceleration1,Acceleration2,Acceleration3",
               comments="")
    out = tmp_path / "f16.h5"
    assert main(["import", str(path), "--out", str(out), "--map", "force=Force",
                 "response=Acceleration1,Acceleration2,Acceleration3:m/s^2", "fs=400",
                 "force_dofs=0"]) == 0
    rec = store.open_run(out).recording()
    np.testing.assert_array_equal(rec.monitors["Voltage"], ch["Voltage"][0])
    assert rec.monitor_units == {"Voltage": "V"}


def test_stepped_sine_monitors_through_the_store(tmp_path):
    rng = np.random.default_rng(6)
    volt = rng.standard_normal((3, 64))
    rec = Recording(FS, "stepped-sine", [0], rng.standard_normal((3, 64, 1)),
                    rng.standard_normal((3, 64, 2)), freqs=[5.0, 6.0, 7.0],
                    monitors={"Voltage": volt})
    store.save_recording(tmp_path / "s.h5", rec)
    back = store.open_run(tmp_path / "s.h5").recording()
    np.testing.assert_array_equal(back.monitors["Voltage"], volt)
    rio.write_npz(tmp_path / "s.npz", back)
    np.testing.assert_array_equal(rio.read_npz(tmp_path / "s.npz").monitors["Voltage"], volt)


@pytest.mark.parametrize("keys, words", [
    ({"monitor": np.zeros((N, 2)), "monitor_names": np.array(["V"])}, "one name and unit"),
    ({"monitor": np.zeros((N - 1, 1)), "monitor_names": np.array(["V"])}, "shape"),
    ({"monitor": np.zeros((N, 1))}, "without monitor_names"),
    ({"monitor": np.zeros((N, 2)), "monitor_names": np.array(["V", "V"])}, "repeats"),
])
def test_bad_monitor_keys_name_the_problem(tmp_path, keys, words):
    rng = np.random.default_rng(7)
    base = {"fs": FS, "force": rng.standard_normal((N, 1)),
            "response": rng.standard_normal((N, 2)), "force_dofs": np.array([0])}
    with pytest.raises(InputError) as info:
        rio.recording_from_keys({**base, **keys}, tmp_path / "x.npz")
    assert words in str(info.value)


def test_an_estimated_sweep_trims_the_monitors_with_the_force(tmp_path):
    """Lead-in and trailing zeros cut from an export whose sweep law is estimated: the
    monitors lose the same samples (a sample counter stays aligned)."""
    t = np.arange(8000) / FS
    chirp = np.sin(2 * np.pi * (2.0 * t + 0.5 * 8.0 * t**2 / t[-1]))
    force = np.r_[np.zeros(500), chirp, np.zeros(300)][:, None]
    rng = np.random.default_rng(8)
    keys = {"fs": FS, "excitation": "swept-sine", "force": force, "force_dofs": np.array([0]),
            "response": rng.standard_normal((force.shape[0], 1)),
            "monitor": np.arange(force.shape[0], dtype=float)[:, None],
            "monitor_names": np.array(["counter"])}
    rec = rio.recording_from_keys(keys, tmp_path / "sweep.npz")
    lead = rec.sweep.trimmed_lead
    assert lead > 0 and rec.sweep.trimmed_tail > 0
    np.testing.assert_array_equal(rec.monitors["counter"],
                                  np.arange(lead, lead + rec.force.shape[0]))
