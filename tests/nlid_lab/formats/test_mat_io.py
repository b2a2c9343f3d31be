"""MAT recordings as acquisition systems export them (v5 struct, v7.3 HDF5), channel maps."""

import h5py
import numpy as np
import pytest
import scipy.io

from analysis.errors import InputError
from nlid_lab.formats import G0, ChannelMap, apply_map, read_mat_tree, split_label

N = 1000


@pytest.fixture
def channels():
    rng = np.random.default_rng(0)
    return {"Force": rng.standard_normal(N), "Voltage": rng.standard_normal(N),
            "Acceleration": rng.standard_normal((N, 3)), "Fs": 2048.0}


def test_v5_struct_with_units_and_column_selection(tmp_path, channels):
    path = tmp_path / "gvt.mat"
    scipy.io.savemat(path, {"data": channels})
    tree = read_mat_tree(path)
    assert set(tree) == {"data.Force", "data.Voltage", "data.Acceleration", "data.Fs"}
    cmap = ChannelMap.from_items(["force=Force:kN", "response=Acceleration[0:2]:g",
                                  "response=data.Acceleration[2]:g", "fs=Fs", "level=5"])
    rec = apply_map(tree, cmap, str(path))
    assert rec["fs"] == 2048.0 and rec["response_kind"] == "acceleration" and rec["level"] == 5
    np.testing.assert_allclose(rec["force"][:, 0], 1e3 * channels["Force"])
    np.testing.assert_allclose(rec["response"], G0 * channels["Acceleration"])


def test_channel_major_arrays_and_toml_map(tmp_path, channels):
    path = tmp_path / "export.mat"
    scipy.io.savemat(path, {"Force": channels["Force"][None, :],
                            "Acc": channels["Acceleration"].T, "rate": 1024})
    mapfile = tmp_path / "map.toml"
    mapfile.write_text('force = "Force"\nresponse = ["Acc[0,2]:mm/s^2"]\nfs = "rate"\n'
                       'force_dofs = [0]\n')
    rec = apply_map(read_mat_tree(path), ChannelMap.from_toml(mapfile), str(path))
    assert rec["force"].shape == (N, 1) and rec["response"].shape == (N, 2)
    np.testing.assert_allclose(rec["response"], 1e-3 * channels["Acceleration"][:, [0, 2]])
    assert rec["fs"] == 1024.0 and rec["force_dofs"] == [0]


def test_v73_hdf5_file_reads_like_v5(tmp_path, channels):
    path = tmp_path / "gvt73.mat"
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Wed Nov 25 2026 HDF5 schema"
    with h5py.File(path, "w", userblock_size=512) as f:
        g = f.create_group("data")
        g.attrs["MATLAB_class"] = np.bytes_("struct")
        for key in ("Force", "Acceleration", "Fs"):
            value = np.atleast_2d(np.asarray(channels[key], dtype=float))
            value = value.T if key != "Acceleration" else value
            g.create_dataset(key, data=value.T)            # MATLAB writes column-major
            g[key].attrs["MATLAB_class"] = np.bytes_("double")
        g.create_dataset("Title", data=np.frombuffer("run 7".encode("utf-16-le"), np.uint16))
        g["Title"].attrs["MATLAB_class"] = np.bytes_("char")
    with open(path, "r+b") as fh:
        fh.write(header.ljust(128))
    tree = read_mat_tree(path)
    assert tree["data.Title"] == "run 7"
    rec = apply_map(tree, ChannelMap.from_items(["force=Force", "response=Acceleration:g"]),
                    str(path))
    np.testing.assert_allclose(rec["response"], G0 * channels["Acceleration"])
    np.testing.assert_allclose(rec["force"][:, 0], channels["Force"])


@pytest.mark.parametrize("items, words", [
    (["force=Forc", "response=Acceleration"], "no variable 'Forc' (the file holds data.Accel"),
    (["force=Force", "response=Acceleration[5]"], "3 column(s)"),
    (["force=Force", "response=Acceleration:N"], "force unit"),
    (["force=Force:g", "response=Acceleration"], "acceleration unit"),
    (["force=Force", "response=Acceleration:furlong"], "unknown unit 'furlong'"),
    (["force=Force", "response=Acceleration[0]:g", "response=Acceleration[1]:m",
      "response=Voltage"], "different"),
    (["force=Force"], "needs 'response'"),
    (["force"], "KEY=VALUE"),
    (["force=Force", "response=Acceleration[a:b]"], "column range"),
])
def test_map_errors_name_the_problem(tmp_path, channels, items, words):
    path = tmp_path / "gvt.mat"
    scipy.io.savemat(path, {"data": channels})
    with pytest.raises(InputError, match=".*") as info:
        apply_map(read_mat_tree(path), ChannelMap.from_items(items), str(path))
    assert words in str(info.value)


def test_not_a_mat_file(tmp_path):
    bad = tmp_path / "x.mat"
    bad.write_text("hello")
    with pytest.raises(InputError, match="not a readable MAT file"):
        read_mat_tree(bad)


@pytest.mark.parametrize("label, expected", [("Force (N)", ("Force", "N")),
                                             ("Acc1 [m/s^2]", ("Acc1", "m/s^2")),
                                             ("time", ("time", None))])
def test_split_label(label, expected):
    assert split_label(label) == expected


@pytest.mark.parametrize("name, kind", [("Acceleration", "acceleration"),
                                        ("Voltage", "displacement")])
def test_a_unitless_channel_takes_its_kind_from_its_name(tmp_path, channels, name, kind):
    path = tmp_path / "gvt.mat"
    scipy.io.savemat(path, {"data": channels})
    keys = apply_map(read_mat_tree(path), ChannelMap.from_items(["force=Force",
                                                                 f"response={name}"]), str(path))
    assert keys["response_kind"] == kind
