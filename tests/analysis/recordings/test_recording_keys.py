"""Every recording key survives NPZ/CSV -> import -> run -> export/simulate (contracts 3 and 5).

Issue #13 item 1: `import` dropped ``force_hold`` (and every NPZ key it did not copy), so a
first-order-hold recording was analysed as ``"none"``. These tests write recordings with every
key the contracts name, plus unknown ones, and check them after each hop.
"""

from __future__ import annotations

import ast
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from analysis.recordings import (KEYS as SENSOR_KEYS, STEP_TABLE_KEYS, SWEEP_KEYS, PeriodicLayout,
                                 Recording, RecordingKeys)
from analysis.spectral import stepped_sine_frf
from nlid_lab import formats as rio
from nlid_lab.formats._recording_keys import CORE_KEYS, LEVEL_KEYS, level_key
from nlid_lab.formats._monitors import MONITOR_KEYS
from nlid_lab.formats._tables import CONTROL_KEYS
from nlid_lab import store
from nlid_lab.methods._hbm import _stepped
from nlid_lab.cli import main

ROOT = Path(__file__).resolve().parents[3]
KNOWN = (set(CORE_KEYS) | set(LEVEL_KEYS) | set(rio.LAYOUT_KEYS) | set(MONITOR_KEYS)
         | {"force_hold"})


def _assert_same(got: np.ndarray, want: np.ndarray, key: str) -> None:
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape, key
    if want.dtype.kind in "fc":
        np.testing.assert_array_equal(got, want, err_msg=key)   # NaN == NaN here
    else:
        assert np.array_equal(got, want), key


# --- strategies --------------------------------------------------------------------------

_names = st.from_regex(r"[a-z][a-z0-9_]{0,11}", fullmatch=True).filter(lambda k: k not in KNOWN)
_text = st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc", "Zl", "Zp")),
                max_size=12)
_floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
_scalar_extra = st.one_of(_floats.map(np.float64), st.integers(-2**62, 2**62).map(np.int64),
                          _text.map(np.str_))
_array_extra = st.one_of(
    _scalar_extra,
    st.booleans().map(np.bool_),
    st.lists(_floats, min_size=1, max_size=5).map(np.asarray),
    st.lists(st.integers(-1000, 1000), min_size=1, max_size=5).map(
        lambda v: np.asarray(v, dtype=np.int16)),
    st.lists(_text, min_size=1, max_size=3).map(np.asarray),
    st.tuples(_floats, _floats).map(lambda c: np.complex128(complex(*c))),
    st.lists(st.integers(0, 10**9), min_size=1, max_size=3).map(
        lambda v: np.asarray(v, dtype="datetime64[s]")),
)


@st.composite
def npz_keys(draw, *, csv: bool = False) -> dict[str, np.ndarray]:
    """The keys of an NPZ (or CSV-able) recording: every contract key, some unknown ones."""
    excitation = "random" if csv else draw(st.sampled_from(["random", "stepped-sine",
                                                             "swept-sine"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_dof = draw(st.integers(1, 3))
    force_dofs = np.asarray(draw(st.lists(st.integers(0, n_dof - 1), min_size=1, max_size=2)))
    fs = draw(st.sampled_from([100.0, 1024.0, 2000.5]))
    keys: dict[str, np.ndarray] = {"fs": np.float64(fs), "excitation": np.str_(excitation),
                                   "force_dofs": force_dofs,
                                   "response_kind": np.str_(draw(st.sampled_from(
                                       ["displacement", "velocity", "acceleration"]))),
                                   "force_hold": np.str_(draw(st.sampled_from(["none",
                                                                               "linear"])))}
    if excitation == "swept-sine":             # the law given: no estimation, data kept as is
        lo, hi = sorted(rng.uniform(0.01, 0.45, 2) * fs)
        up = draw(st.booleans())
        keys.update(sweep_start_hz=np.float64(lo if up else hi),
                    sweep_stop_hz=np.float64(hi if up else lo),
                    sweep_law=np.str_(draw(st.sampled_from(["linear", "log"]))),
                    sweep_rate=np.float64(draw(st.floats(0.01, 100))))
        if draw(st.booleans()):
            keys.update(sweep_estimated=np.int64(1), sweep_trimmed_lead=np.int64(
                draw(st.integers(0, 99))), sweep_trimmed_tail=np.int64(draw(st.integers(0, 9))))
        shape = (draw(st.integers(3, 60)),)
    elif excitation == "random":
        periodic = draw(st.booleans())
        if periodic:
            lay = PeriodicLayout(draw(st.integers(2, 16)), draw(st.integers(0, 2)),
                                 draw(st.integers(1, 3)), draw(st.integers(1, 3)))
            n = lay.realizations * lay.realization_samples
            keys.update({k: np.int64(getattr(lay, k)) for k in rio.LAYOUT_KEYS})
        else:
            n = draw(st.integers(3, 60))
        shape = (n,)
    else:
        n_steps = draw(st.integers(1, 4))
        keys["freqs"] = np.sort(rng.uniform(0.01, 0.45, n_steps)) * fs
        shape = (n_steps, draw(st.integers(3, 30)))
    keys["force"] = rng.normal(size=shape + (force_dofs.size,))
    keys["response"] = rng.normal(size=shape + (n_dof,))
    if draw(st.booleans()):                     # monitor channels (the amplifier voltage...)
        names = draw(st.lists(st.from_regex(r"[A-Z][a-z]{2,6}", fullmatch=True).filter(
            lambda s: s != "Time"), min_size=1, max_size=3, unique=True))
        keys.update(monitor=rng.normal(size=shape + (len(names),)),
                    monitor_names=np.array(names))
        if draw(st.booleans()):
            keys["monitor_units"] = np.array(draw(st.lists(st.sampled_from(
                ["V", "A", "", "m/s^2"]), min_size=len(names), max_size=len(names))))
    if draw(st.booleans()):
        keys[level_key(excitation)] = np.float64(draw(st.floats(0.01, 100)))
    extras = draw(st.dictionaries(_names, _scalar_extra if csv else _array_extra, max_size=4))
    keys.update(extras)
    return keys


def _check_keys(path: Path, want: dict[str, np.ndarray]) -> None:
    with np.load(path, allow_pickle=False) as data:
        got = dict(data)
    missing = set(want) - set(got)
    assert not missing, f"keys lost: {sorted(missing)}"
    for key, value in want.items():
        _assert_same(got[key], value, key)
        if key not in KNOWN:
            assert got[key].dtype == np.asarray(value).dtype, key


# --- round trips -------------------------------------------------------------------------

@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(npz_keys())
def test_every_npz_key_survives_import_run_export(keys):
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        with open(d / "in.npz", "wb") as fh:
            np.savez(fh, **keys)
        store.save_recording(d / "run.h5", rio.read_npz(d / "in.npz"), source="import")
        rec = store.open_run(d / "run.h5").recording()
        assert rec.force_hold == str(keys["force_hold"])
        if "period" in keys:
            assert (rec.layout.period, rec.layout.transient_periods, rec.layout.periods,
                    rec.layout.realizations) == tuple(int(keys[k]) for k in rio.LAYOUT_KEYS)
        else:
            assert rec.layout is None
        rio.write_npz(d / "out.npz", rec)
        _check_keys(d / "out.npz", keys)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(npz_keys())
def test_every_mat_key_survives_export_import_run(keys):
    """`export --out X.mat` writes every key MATLAB can hold (numbers and text: not
    datetimes) as a variable; importing the file gives every key back, as NPZ would."""
    from nlid_lab.formats import read_mat_recording, write_mat

    keys = {k: v for k, v in keys.items() if np.asarray(v).dtype.kind != "M"}
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        write_mat(d / "in.mat", _from_keys(keys))
        store.save_recording(d / "run.h5", read_mat_recording(d / "in.mat"), source="import")
        write_mat(d / "out.mat", store.open_run(d / "run.h5").recording())
        rio.write_npz(d / "out.npz", read_mat_recording(d / "out.mat"))
        _check_keys(d / "out.npz", keys)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(npz_keys(csv=True))
def test_every_csv_key_survives_import_run_export(keys):
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        rio.write_csv(d / "in.csv", _from_keys(keys))
        imported = rio.read_csv(d / "in.csv")
        store.save_recording(d / "run.h5", imported, source="import")
        rec = store.open_run(d / "run.h5").recording()
        rio.write_csv(d / "out.csv", rec)
        back = rio.read_csv(d / "out.csv")
        rio.write_npz(d / "out.npz", back)
        _check_keys(d / "out.npz", keys)


def _from_keys(keys: dict[str, np.ndarray]) -> Recording:
    with tempfile.TemporaryDirectory() as d:
        with open(Path(d) / "k.npz", "wb") as fh:
            np.savez(fh, **keys)
        return rio.read_npz(Path(d) / "k.npz")


def _recording_with_keys(excitation: str = "random") -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    keys = {"fs": np.float64(512.0), "excitation": np.str_(excitation),
            "force_dofs": np.asarray([0]), "force_hold": np.str_("linear"),
            "sweep_start_hz": np.float64(5.0), "sweep_law": np.str_("log"),
            "operator_notes": np.asarray(["shaker A", "run 3"])}
    if excitation == "random":
        keys.update(period=np.int64(64), transient_periods=np.int64(1), periods=np.int64(3),
                    realizations=np.int64(2), force_rms=np.float64(2.0))
        keys["force"] = rng.normal(size=(512, 1))
        keys["response"] = rng.normal(size=(512, 2))
    else:
        keys.update(freqs=np.asarray([20.0, 30.0]), force_amplitude=np.float64(3.0))
        keys["force"] = rng.normal(size=(2, 100, 1))
        keys["response"] = rng.normal(size=(2, 100, 2))
    return keys


@pytest.mark.parametrize("excitation", ["random", "stepped-sine"])
def test_cli_import_keeps_force_hold_and_every_key(tmp_path, excitation):
    """The issue #13 bug: ``import`` wrote a run without force_hold, so analyses read
    "none". Through the CLI: import, then export, keys compared."""
    keys = _recording_with_keys(excitation)
    np.savez(tmp_path / "rec.npz", **keys)
    assert main(["import", str(tmp_path / "rec.npz"), "--out", str(tmp_path / "run.h5")]) == 0
    (rec,) = rio.load_recordings(tmp_path / "run.h5")
    assert rec.force_hold == "linear"
    assert main(["export", str(tmp_path / "run.h5"), "--out", str(tmp_path / "out.npz")]) == 0
    _check_keys(tmp_path / "out.npz", keys)


def test_export_refuses_to_overwrite(tmp_path, capsys):
    np.savez(tmp_path / "rec.npz", **_recording_with_keys())
    main(["import", str(tmp_path / "rec.npz"), "--out", str(tmp_path / "run.h5")])
    (tmp_path / "out.npz").write_text("keep me")
    assert main(["export", str(tmp_path / "run.h5"), "--out", str(tmp_path / "out.npz")]) == 2
    assert (tmp_path / "out.npz").read_text() == "keep me"
    assert "--force" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "run.h5"), "--out", str(tmp_path / "out.npz"),
                 "--force"]) == 0


def test_csv_import_keeps_force_hold_and_layout(tmp_path):
    """Sibling of the NPZ loss: CSV recordings carry keys as '# key = value' lines."""
    keys = _recording_with_keys()
    keys.pop("operator_notes")                      # arrays cannot go into a CSV comment
    rio.write_csv(tmp_path / "rec.csv", _from_keys(keys))
    assert main(["import", str(tmp_path / "rec.csv"), "--out", str(tmp_path / "run.h5")]) == 0
    (rec,) = rio.load_recordings(tmp_path / "run.h5")
    assert rec.force_hold == "linear"
    assert rec.layout == PeriodicLayout(64, 1, 3, 2)
    assert float(rec.extra["sweep_start_hz"]) == 5.0 and str(rec.extra["sweep_law"]) == "log"


def test_simulate_carries_the_drive_keys(tmp_path):
    """A drive's layout and unknown keys reach the simulated recording (NPZ and run); the
    force hold is the plant's ("linear") whatever the drive file says."""
    model = tmp_path / "m.toml"
    model.write_text('name = "sdof"\n[linear]\nmass = [[1.0]]\ndamping = [[2.0]]\n'
                     'stiffness = [[1e4]]\n')
    drive = _recording_with_keys()
    drive["force_hold"] = np.str_("none")
    drive.pop("response")
    np.savez(tmp_path / "drive.npz", **drive)
    want = dict(drive, force_hold=np.str_("linear"))
    for out in ("sim.npz", "sim.h5"):
        assert main(["simulate", str(model), "--drive", str(tmp_path / "drive.npz"),
                     "--out", str(tmp_path / out)]) == 0
    _check_keys(tmp_path / "sim.npz", want)
    main(["export", str(tmp_path / "sim.h5"), "--out", str(tmp_path / "sim-run.npz")])
    _check_keys(tmp_path / "sim-run.npz", want)


def test_level_under_another_key_is_written_back(tmp_path):
    keys = _recording_with_keys()
    keys["level"] = keys.pop("force_rms")
    np.savez(tmp_path / "rec.npz", **keys)
    rec = rio.read_npz(tmp_path / "rec.npz")
    assert rec.level == 2.0
    rio.write_npz(tmp_path / "out.npz", rec)
    _check_keys(tmp_path / "out.npz", keys)


def test_old_runs_read_hold_and_layout_from_settings(tmp_path):
    """Runs written before the typed fields kept force_hold in ``settings`` and the layout
    in ``excitation_settings``; they read the same."""
    keys = _recording_with_keys()
    rec = _from_keys(keys)
    exc = {"kind": "random", "periodic": True, "block_size": 64, "transient_periods": 1,
           "periods": 3}
    with store.RunWriter(tmp_path / "old.h5", fs=rec.fs, excitation=exc, force_dofs=[0],
                         n_dof=2, settings={"force_hold": "linear"}) as run:
        lv = run.level(0, 2.0)
        for i in range(0, 512, 256):
            lv.append_block(rec.force[i:i + 256], rec.response[i:i + 256])
    with h5py.File(tmp_path / "old.h5", "r+") as f:     # as written before the attribute
        del f.attrs["force_hold"]
    back = store.open_run(tmp_path / "old.h5").recording()
    assert back.force_hold == "linear"
    assert back.layout == PeriodicLayout(64, 1, 3, 2)


def test_analyze_hbm_honours_the_imported_force_hold(tmp_path):
    """The sine fit scales each step's force by the hold's sinc^2 gain: the same NPZ gives
    the same force amplitudes read directly and after import (it gave the unscaled ones
    before), and --force-hold none undoes the scaling."""
    fs, freqs = 200.0, np.asarray([10.0, 25.0, 40.0])
    t = np.arange(400) / fs
    force = np.stack([np.sin(2 * np.pi * f * t)[:, None] for f in freqs])
    resp = 1e-3 * force
    np.savez(tmp_path / "s.npz", fs=fs, excitation="stepped-sine", force_dofs=[0],
             force=force, response=resp, freqs=freqs, force_hold="linear")
    main(["import", str(tmp_path / "s.npz"), "--out", str(tmp_path / "s.h5")])
    direct = stepped_sine_frf(rio.read_npz(tmp_path / "s.npz"), (1,))
    (imported,) = _stepped(rio.load_recordings(tmp_path / "s.h5"))   # what analyze hbm fits
    stored = stepped_sine_frf(imported, (1,))
    np.testing.assert_allclose(stored.force, direct.force, rtol=1e-12)
    np.testing.assert_allclose(stored.force, np.sinc(freqs / fs) ** 2, rtol=1e-9)
    assert stored.force[-1] < 0.88                          # 40 Hz at 200 Hz: -12.5 %
    (overridden,) = _stepped(rio.load_recordings(tmp_path / "s.h5"), "none")   # --force-hold
    np.testing.assert_allclose(stepped_sine_frf(overridden, (1,)).force, 1.0, rtol=1e-9)


# --- import direction (issue #12 item 6) -----------------------------------------------------

def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            out.append((node.level, node.module or ""))
        elif isinstance(node, ast.Import):
            out += [(0, a.name) for a in node.names]
    return out


def test_store_imports_only_analysis_and_h5py():
    for path in (ROOT / "nlid_lab" / "store").glob("*.py"):
        for level, module in _imports(path):
            assert level <= 1, f"{path.name} imports upward: {'.' * level}{module}"
            assert not module.startswith(("nlid_lab", "drivers")), f"{path.name}: {module}"


def test_campaign_config_does_not_import_emulators():
    for name in ("_campaign_config.py", "_campaign_devices.py"):
        for level, module in _imports(ROOT / "nlid_lab" / "campaign" / name):
            assert "emulators" not in module, name


class _Stop(Exception):
    pass


def test_diagnose_reads_the_period_the_store_writes(tmp_path, monkeypatch):
    """The diagnosis read ``meta["period_samples"]`` while the store wrote ``period``: a
    periodic run was diagnosed as plain random data. It now takes ``layout.period``."""
    import analysis.diagnose._search as dg
    from analysis.models import Model

    seen = []

    def spy(rec, band, label, *, period=None, **kw):
        seen.append(period)
        raise _Stop

    monkeypatch.setattr(dg, "prepare_random", spy)
    model = tmp_path / "m.toml"
    model.write_text('name = "2dof"\n[linear]\nmass = [[1.0, 0.0], [0.0, 1.0]]\n'
                     'damping = [[2.0, 0.0], [0.0, 2.0]]\n'
                     'stiffness = [[2e4, -1e4], [-1e4, 2e4]]\n')
    np.savez(tmp_path / "rec.npz", **_recording_with_keys())
    main(["import", str(tmp_path / "rec.npz"), "--out", str(tmp_path / "run.h5")])
    with pytest.raises(_Stop):
        dg.diagnose(Model.load(model), rio.load_recordings(tmp_path / "run.h5"))
    assert seen == [64]


def test_prepare_drops_the_transient_of_every_realization():
    from analysis.diagnose._prepare import prepare_random

    lay = PeriodicLayout(8, 1, 2, 3)                  # 3 x (1 + 2) periods of 8 samples
    n = lay.realizations * lay.realization_samples
    idx = np.arange(n, dtype=float)
    rec = Recording(100.0, "random", [0], idx[:, None], np.sin(idx)[:, None], layout=lay)
    p = prepare_random(rec, (1.0, 20.0), "x", period=8)
    steady = np.concatenate([np.arange(k * 24 + 8, k * 24 + 24) for k in range(3)])
    np.testing.assert_allclose(p.force[:, 0], steady - steady.mean())


def test_the_schema_names_every_key_the_readers_know():
    """`RecordingKeys` is the schema of a recording file: every key a reader or writer names
    (samples, level, layout, hold, sweep, sensors, monitors, tables) and no other."""
    named = KNOWN | set(SENSOR_KEYS) | set(SWEEP_KEYS) | set(STEP_TABLE_KEYS) | set(CONTROL_KEYS)
    assert set(RecordingKeys.__annotations__) == named
    assert RecordingKeys.__required_keys__ == frozenset()   # the readers say what they need

