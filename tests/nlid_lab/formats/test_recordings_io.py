"""NPZ/CSV recordings and drive files <-> `Recording`."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.recordings import Recording
from nlid_lab import formats as rio
from nlid_lab.formats import read_drive
from nlid_lab import store


def _random_rec(rng, n=2000):
    return Recording(fs=1024.0, excitation="random", force_dofs=[1],
                     force=rng.normal(size=(n, 1)), response=rng.normal(size=(n, 3)) * 1e-4,
                     response_kind="velocity", level=3.0)


def test_npz_round_trip_random_and_stepped(tmp_path):
    rng = np.random.default_rng(0)
    rec = _random_rec(rng)
    rio.write_npz(tmp_path / "r.npz", rec)
    back = rio.read_npz(tmp_path / "r.npz")
    np.testing.assert_array_equal(back.force, rec.force)
    np.testing.assert_array_equal(back.response, rec.response)
    assert (back.fs, back.excitation, back.response_kind, back.level) == (
        1024.0, "random", "velocity", 3.0)
    with np.load(tmp_path / "r.npz") as data:  # the contract's key names
        assert {"fs", "excitation", "force_dofs", "force", "response", "response_kind",
                "force_rms"} <= set(data.files)
    step = Recording(fs=512.0, excitation="stepped-sine", force_dofs=[0],
                     force=rng.normal(size=(3, 64, 1)), response=rng.normal(size=(3, 64, 2)),
                     freqs=[10.0, 20.0, 30.0], level=1.5)
    rio.write_npz(tmp_path / "s.npz", step)
    back = rio.read_npz(tmp_path / "s.npz")
    np.testing.assert_array_equal(back.freqs, step.freqs)
    np.testing.assert_array_equal(back.response, step.response)
    assert back.level == 1.5 and back.excitation == "stepped-sine"


def test_npz_minimal_keys_defaults(tmp_path):
    np.savez(tmp_path / "m.npz", fs=100.0, force_dofs=[0], force=np.ones((50, 1)),
             response=np.ones((50, 2)))
    rec = rio.read_npz(tmp_path / "m.npz")
    assert (rec.excitation, rec.response_kind, rec.level) == ("random", "displacement", None)


@pytest.mark.parametrize("keys,match", [
    (dict(fs=100.0, force=np.ones((5, 1)), response=np.ones((5, 1))), "missing key"),
    (dict(fs=100.0, force_dofs=[0], force=np.ones((5, 1)), response=np.ones((6, 1))),
     "differ in length"),
    (dict(fs=100.0, force_dofs=[0], force=np.full((5, 1), np.nan), response=np.ones((5, 1))),
     "NaN"),
    (dict(fs=[1.0, 2.0], force_dofs=[0], force=np.ones((5, 1)), response=np.ones((5, 1))),
     "scalar"),
    (dict(fs=100.0, force_dofs=[3], force=np.ones((5, 1)), response=np.ones((5, 1))),
     "0-based"),
])
def test_npz_bad_input(tmp_path, keys, match):
    np.savez(tmp_path / "b.npz", **keys)
    with pytest.raises(rio.RecordingFileError, match=match):
        rio.read_npz(tmp_path / "b.npz")


def test_npz_missing_and_not_npz(tmp_path):
    with pytest.raises(rio.RecordingFileError, match="not found"):
        rio.read_npz(tmp_path / "nope.npz")
    (tmp_path / "x.npz").write_text("hello")
    with pytest.raises(rio.RecordingFileError, match="not a readable NPZ"):
        rio.read_npz(tmp_path / "x.npz")


def test_csv_round_trip(tmp_path):
    rec = _random_rec(np.random.default_rng(1))
    rio.write_csv(tmp_path / "r.csv", rec)
    lines = (tmp_path / "r.csv").read_text().splitlines()
    assert 'response_kind = "velocity"' in lines[0] + "".join(lines[1:8])
    assert next(ln for ln in lines if not ln.startswith("#")) == "t,f0@1,v0@0,v1@1,v2@2"
    back = rio.read_csv(tmp_path / "r.csv")   # the file's response_kind key
    assert back.response_kind == "velocity"
    np.testing.assert_array_equal(back.force, rec.force)  # %.17g round-trips exactly
    np.testing.assert_array_equal(back.response, rec.response)
    np.testing.assert_array_equal(back.force_dofs, [1])
    assert back.fs == 1024.0                              # the fs key, exactly


def test_csv_hand_written_header_and_force_cols(tmp_path):
    t = np.arange(200) / 100.0
    lines = ["# shaker test 3, operator A", "time, x1@dof1, drive@0, x0@0"]
    lines += [f"{ti:.2f}, {np.sin(ti):.6f}, {np.cos(ti):.6f}, {ti:.6f}" for ti in t]
    (tmp_path / "h.csv").write_text("\n".join(lines) + "\n")
    rec = rio.read_csv(tmp_path / "h.csv", force_cols=["drive"])
    assert rec.fs == pytest.approx(100.0)
    np.testing.assert_array_equal(rec.force_dofs, [0])
    np.testing.assert_allclose(rec.force[:, 0], np.round(np.cos(t), 6))
    np.testing.assert_allclose(rec.response[:, 0], np.round(t, 6))  # sorted by DOF
    np.testing.assert_allclose(rec.response[:, 1], np.round(np.sin(t), 6))


@pytest.mark.parametrize("text,match", [
    ("a,f0@0,x0@0\n0,1,2\n1,1,2\n2,1,2\n", "time column"),
    ("t,f0,x0@0\n0,1,2\n1,1,2\n2,1,2\n", "NAME@DOF"),
    ("t,f0@0,x0@0\n0,1,2\n1,1,\n2,1,2\n", "bad number"),
    ("t,f0@0,x0@0\n0,1,2\n1,1,2\n3,1,2\n", "equal steps"),
    ("t,f0@0,x0@0\n0,1,2\n1,1,nan\n2,1,2\n", "NaN"),
    ("t,f0@0,x0@1\n0,1,2\n1,1,2\n2,1,2\n", "DOFs 0..n-1"),
    ("t,x0@0,x1@1\n0,1,2\n1,1,2\n2,1,2\n", "at least one force"),
    ("t,f0@0,x0@0\n0,1,2\n", "at least two data rows"),
])
def test_csv_bad_input(tmp_path, text, match):
    (tmp_path / "b.csv").write_text(text)
    with pytest.raises(rio.RecordingFileError, match=match):
        rio.read_csv(tmp_path / "b.csv")


def test_read_drive_shapes(tmp_path):
    np.savez(tmp_path / "d.npz", fs=100.0, force_dofs=[0], force=np.ones(20))
    drive = read_drive(tmp_path / "d.npz")
    assert drive.force.shape == (20, 1) and drive.excitation == "random"
    np.savez(tmp_path / "s.npz", fs=100.0, force_dofs=[0], force=np.ones((2, 20, 1)),
             freqs=[5.0, 6.0], force_amplitude=2.0)
    drive = read_drive(tmp_path / "s.npz")
    assert drive.excitation == "stepped-sine" and drive.level == 2.0
    np.savez(tmp_path / "bad.npz", fs=100.0, force_dofs=[0, 1], force=np.ones((20, 1)))
    with pytest.raises(rio.RecordingFileError, match="one column per force_dofs"):
        read_drive(tmp_path / "bad.npz")


def test_load_recordings_dispatch(tmp_path):
    rec = _random_rec(np.random.default_rng(2), n=300)
    rio.write_npz(tmp_path / "a.npz", rec)
    rio.write_csv(tmp_path / "a.csv", rec)
    store.save_recording(tmp_path / "a.h5", rec)
    for name in ("a.npz", "a.csv", "a.h5"):
        (back,) = rio.load_recordings(tmp_path / name)
        np.testing.assert_array_equal(back.response, rec.response)
    with pytest.raises(store.StoreError, match="unknown recording type"):
        rio.load_recordings(tmp_path / "a.txt")
