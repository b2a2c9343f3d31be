"""Stepped-sine tables (contracts section 6): NPZ, CSV and MAT files round trip through a
run with every key; a controller's struct-array export reads through a table map with its
phase convention; table runs are checked on read; backbone, fit-linear, detect, view and
report take them."""

import json

import numpy as np
import pytest
import scipy.io

from analysis.recordings import StepTable
from nlid_lab.cli import main
from nlid_lab.store import StoreError, open_run, save_result

FN, ZETA, A = 80.0, 0.003, 0.5          # mode of the tables, modal constant (1/kg)


def receptance(f: np.ndarray, zeta: float = ZETA, fn: float = FN) -> np.ndarray:
    w, wn = 2 * np.pi * f, 2 * np.pi * fn
    return A / (wn**2 - w**2 + 2j * zeta * wn * w)


def table(level: float, zeta: float = ZETA, fn: float = FN, harmonics: bool = False
          ) -> StepTable:
    """A response-controlled accelerance table holding ``level`` m/s^2."""
    f = np.arange(78.0, 82.0, 0.1)
    acc = -(2 * np.pi * f) ** 2 * receptance(f, zeta, fn)
    force = level / np.abs(acc)
    more = {}
    if harmonics:
        more = dict(harmonics=(2, 3), force_harmonics=np.full((f.size, 2, 1), 1e-3 + 0j),
                    response_harmonics=np.full((f.size, 2, 1), 0.05 - 0.01j))
    return StepTable(f, force[:, None], (acc * force)[:, None], [0], "response", level,
                     response_kind="acceleration", control_dof=0,
                     extra={"operator": np.str_("rig 2"), "temperature_c": np.float64(21.5)},
                     **more)


def write_npz(path, t: StepTable):
    from nlid_lab.formats import recording_keys
    np.savez(path, **recording_keys(t))


def test_npz_csv_mat_round_trip_keeps_every_key(tmp_path):
    src = tmp_path / "level.npz"
    write_npz(src, table(10.0, harmonics=True))
    keys = dict(np.load(src))
    assert main(["import", str(src), "--out", str(tmp_path / "run.h5")]) == 0
    for suffix in ("npz", "csv", "mat"):
        out = tmp_path / f"back.{suffix}"
        assert main(["export", str(tmp_path / "run.h5"), "--out", str(out)]) == 0
        assert main(["import", str(out), "--out", str(tmp_path / f"{suffix}.h5")]) == 0
        again = tmp_path / f"again_{suffix}.npz"
        assert main(["export", str(tmp_path / f"{suffix}.h5"), "--out", str(again)]) == 0
        back = dict(np.load(again))
        assert sorted(back) == sorted(keys), suffix
        for k, v in keys.items():
            assert np.array_equal(back[k], v), (suffix, k)


def test_levels_of_several_files_make_one_table_run(tmp_path):
    paths = []
    for i, level in enumerate((5.0, 20.0, 40.0)):
        paths.append(str(tmp_path / f"l{i}.npz"))
        write_npz(paths[-1], table(level, zeta=ZETA * (1 + i)))
    assert main(["import", *paths, "--out", str(tmp_path / "run.h5")]) == 0
    run = open_run(tmp_path / "run.h5")
    assert [lv.nominal for lv in run.levels] == [5.0, 20.0, 40.0]
    assert [lv.n_segments for lv in run.levels] == [40, 40, 40]       # steps
    recs = run.recordings()
    assert all(isinstance(r, StepTable) for r in recs)
    save_result(tmp_path / "run.h5", "note", {"ok": True})        # results as in any run
    assert open_run(tmp_path / "run.h5").results["note"] == {"ok": True}


def test_a_damaged_table_fails_its_checksum(tmp_path):
    import h5py
    write_npz(tmp_path / "l.npz", table(5.0))
    main(["import", str(tmp_path / "l.npz"), "--out", str(tmp_path / "run.h5")])
    with h5py.File(tmp_path / "run.h5", "r+") as f:
        f["steptables/0/response_phasor"][3, 0] *= 1.001
    with pytest.raises(StoreError, match="checksum"):
        open_run(tmp_path / "run.h5").recording(0)


def struct_export(path, tables: list[StepTable], convention: str):
    """What a controller writes: FRdata.ResponseControl(k) with frequency, force amplitude,
    response amplitude and a phase in ``convention``, units text."""
    elements = np.zeros((1, len(tables)), dtype=[("frequency", "O"), ("force", "O"),
                                                 ("amplitude", "O"), ("phase", "O"),
                                                 ("units", "O")])
    for k, t in enumerate(tables):
        H = t.frf()[:, 0, 0]
        phase = {"lead": np.angle(H), "lag": -np.angle(H),
                 "receptance": np.angle(-H)}[convention]      # accelerance = -w^2 receptance
        elements[0, k] = (t.freqs, np.abs(t.force_phasor[:, 0]),
                          np.abs(t.response_phasor[:, 0]), np.rad2deg(phase)
                          if convention == "lag" else phase, "Hz, N, m/s^2, rad")
    scipy.io.savemat(path, {"FRdata": {"ResponseControl": elements}})


@pytest.mark.parametrize("convention", ["lead", "lag", "receptance"])
def test_table_map_reads_a_struct_array_in_its_phase_convention(tmp_path, convention):
    tables = [table(level, zeta=ZETA * (1 + i)) for i, level in enumerate((5.0, 20.0))]
    struct_export(tmp_path / "rc.mat", tables, convention)
    phase = f"phase:{convention}" + (":deg" if convention == "lag" else "")
    argv = ["import", str(tmp_path / "rc.mat"), "--out", str(tmp_path / "run.h5"), "--map",
            "table=FRdata.ResponseControl", "freqs=frequency", "force_amplitude=force:N",
            "response_amplitude=amplitude:m/s^2", f"response_phase={phase}",
            "control=response", "units=units"]
    assert main(argv) == 0
    back = open_run(tmp_path / "run.h5").recordings()
    assert len(back) == 2
    for t, b in zip(tables, back):
        assert b.response_kind == "acceleration" and b.control == "response"
        np.testing.assert_allclose(b.frf(), t.frf() * np.exp(-1j * np.angle(
            t.force_phasor[:, :, None])), rtol=1e-12)
        assert b.level == pytest.approx(np.median(np.abs(t.response_phasor)))
        assert str(b.extra["units"]) == "Hz, N, m/s^2, rad"


@pytest.mark.parametrize("items, message", [
    (["table=FRdata.Missing", "freqs=frequency", "force_amplitude=force",
      "response_amplitude=amplitude", "control=response"], "no struct array"),
    (["table=FRdata.ResponseControl", "freqs=frequency", "force_amplitude=force",
      "response_amplitude=amplitude"], "control=response"),
    (["table=FRdata.ResponseControl", "freqs=frequency", "force_amplitude=force",
      "response_amplitude=amplitude", "response_phase=phase:behind", "control=response"],
     "convention"),
    (["table=FRdata.ResponseControl", "freqs=frequency", "force_amplitude=amplitude:m/s^2",
      "response_amplitude=amplitude", "control=response"], "acceleration unit"),
])
def test_table_map_mistakes_are_one_line(tmp_path, capsys, items, message):
    struct_export(tmp_path / "rc.mat", [table(5.0)], "lead")
    argv = ["import", str(tmp_path / "rc.mat"), "--out", str(tmp_path / "run.h5"), "--map",
            *items]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and not (tmp_path / "run.h5").exists()


def test_backbone_fit_linear_detect_report_view_on_a_table_run(tmp_path, capsys):
    paths = []
    for i, level in enumerate((5.0, 20.0, 40.0)):
        paths.append(str(tmp_path / f"l{i}.npz"))
        write_npz(paths[-1], table(level, zeta=ZETA * (1 + i), fn=FN - 0.2 * i))
    run = str(tmp_path / "run.h5")
    assert main(["import", *paths, "--out", run]) == 0
    out = tmp_path / "bb.json"
    assert main(["backbone", run, "--json", str(out), "--plot", str(tmp_path / "bb.png")]) == 0
    bb = json.loads(out.read_text())
    assert [lv["level"] for lv in bb["levels"]] == [5.0, 20.0, 40.0]
    for i, lv in enumerate(bb["levels"]):            # noise-free linear modes: exact
        assert lv["frequency_hz"] == pytest.approx(FN - 0.2 * i, rel=1e-9)
        assert lv["damping_ratio"] == pytest.approx(ZETA * (1 + i), rel=1e-7)
        assert lv["modal_constant"] == pytest.approx(A, rel=1e-7)
        assert lv["amplitude_kind"] == "acceleration" and lv["fit_error"] < 1e-9
    assert main(["backbone", run, "--json", str(out)]) == 2          # no overwrite
    model = tmp_path / "lin.toml"
    assert main(["fit-linear", run, "--out", str(model)]) == 0
    import tomllib
    modal = tomllib.loads(model.read_text())["modal"]           # the lowest level's mode
    assert modal["frequencies_hz"][0] == pytest.approx(FN, rel=1e-6)
    assert modal["damping_ratios"][0] == pytest.approx(ZETA, rel=1e-4)
    det = tmp_path / "det.json"
    assert main(["detect", run, "--json", str(det)]) == 0
    assert json.loads(det.read_text())["verdict"] == "nonlinear"
    assert main(["report", run, "--out", str(tmp_path / "rep")]) == 0
    assert (tmp_path / "rep" / "backbone.png").is_file()
    assert main(["view", run, "--snapshot", str(tmp_path / "view.png")]) == 0


def _held_twin_run(tw, amplitudes: list[float], half_span: float, tmp_path) -> str:
    """A run of the Jenkins twin's response-controlled tables (one level per held
    displacement amplitude, steps 0.05 Hz apart within ``half_span`` Hz of its backbone)."""
    from nlid_lab.formats import recording_keys

    paths = []
    for i, a in enumerate(amplitudes):
        fn = tw.backbone_at(np.array([a]))[0][0]
        f = np.arange(fn - half_span, fn + half_span, 0.05)
        force = tw.dynamic_stiffness(2 * np.pi * f, np.full(f.shape, a)) * a
        t = StepTable(f, force[:, None], np.full((f.size, 1), a, complex), [0], "response", a,
                      control_dof=0)
        paths.append(str(tmp_path / f"l{i}.npz"))
        np.savez(paths[-1], **recording_keys(t))
    run = str(tmp_path / "twin.h5")
    assert main(["import", *paths, "--out", run]) == 0
    return run


def test_analyze_hbm_recovers_a_jenkins_joint_from_response_controlled_tables(tmp_path):
    """The Jenkins twin (tests/analysis/backbone/jenkins_twin.py: single-harmonic balance)
    held at five displacement amplitudes, below and through slip: the harmonic-balance fit of
    a stick-slip element on the underlying linear model finds kd and fd (issue 25: within
    5 %), inside its own 95 % intervals."""
    from jenkins_twin import JenkinsSDOF

    tw = JenkinsSDOF(kd=1.25e4, fd=0.5)
    run = _held_twin_run(tw, [1e-5, 6e-5, 1.2e-4, 2.5e-4, 5e-4], 1.5, tmp_path)
    model = tmp_path / "cand.toml"
    model.write_text(f'name = "twin"\n[linear]\nmass = [[{tw.m}]]\ndamping = [[{tw.c}]]\n'
                     f'stiffness = [[{tw.k}]]\n[[element]]\nkind = "stick_slip"\nw = [1.0]\n')
    out = tmp_path / "hbm.json"
    assert main(["analyze", "hbm", run, "--model", str(model), "--harmonics", "1",
                 "--json", str(out)]) == 0
    el = json.loads(out.read_text())["elements"][0]
    for name, true in (("kd", tw.kd), ("fd", tw.fd)):
        lo, hi = el["ci95"][name]
        assert lo <= true <= hi and el["params"][name] == pytest.approx(true, rel=0.05)


def test_backbone_with_a_model_holds_its_levels_and_reads_them_alike(tmp_path, capsys):
    """``backbone RUN --model M``: the Jenkins twin as a model file through its own held
    levels gives their backbone (JSON ``model``); a model of other DOFs is one line."""
    from jenkins_twin import JenkinsSDOF

    tw = JenkinsSDOF(kd=1.25e4, fd=0.5)
    run = _held_twin_run(tw, [1e-5, 1.2e-4], 1.0, tmp_path)
    model = tmp_path / "twin.toml"
    model.write_text(f'[linear]\nmass = [[{tw.m}]]\ndamping = [[{tw.c}]]\nstiffness = '
                     f'[[{tw.k}]]\n[[element]]\nkind = "stick_slip"\nw = [1.0]\n'
                     f'kd = {tw.kd}\nfd = {tw.fd}\n')
    out = tmp_path / "bb.json"
    assert main(["backbone", run, "--model", str(model), "--json", str(out)]) == 0
    bb = json.loads(out.read_text())
    for p, q in zip(bb["levels"], bb["model"]["levels"]):
        assert q["amplitude"] == pytest.approx(p["amplitude"], rel=1e-5)     # held
        assert q["frequency_hz"] == pytest.approx(p["frequency_hz"], rel=1e-5)
        assert q["damping_ratio"] == pytest.approx(p["damping_ratio"], rel=0.01)
    two = tmp_path / "two.toml"
    two.write_text("[linear]\nmass = [[1.0, 0.0], [0.0, 1.0]]\ndamping = [[1.0, 0.0], "
                   "[0.0, 1.0]]\nstiffness = [[1e4, 0.0], [0.0, 1e4]]\n")
    capsys.readouterr()
    assert main(["backbone", run, "--model", str(two)]) == 2
    err = capsys.readouterr().err.strip()
    assert "2 DOFs" in err and "\n" not in err


@pytest.mark.parametrize("control,control_dof", [("response", 1), ("force", None)])
def test_time_block_stepped_run_keeps_what_the_controller_held(tmp_path, control, control_dof):
    """A stepped-sine run of time blocks (as a response-controlled campaign records it)
    keeps ``control`` and ``control_dof`` through export and import (NPZ and MAT), as a
    table does, with every other key."""
    from analysis.recordings import Recording
    from nlid_lab.formats import recording_keys
    from nlid_lab.store import save_recording
    rng = np.random.default_rng(3)
    rec = Recording(fs=512.0, excitation="stepped-sine", force_dofs=[0],
                    force=rng.normal(size=(3, 64, 1)), response=rng.normal(size=(3, 64, 2)),
                    freqs=[10.0, 20.0, 30.0], level=2.0, control=control,
                    control_dof=control_dof, extra={"operator": np.str_("rig 2")})
    save_recording(tmp_path / "run.h5", [rec], source="test")
    held = open_run(tmp_path / "run.h5").recording(0)
    assert (held.control, held.control_dof) == (control, control_dof)
    keys = recording_keys(held)
    assert keys["control"] == control and ("control_dof" in keys) == (control_dof is not None)
    for suffix in ("npz", "mat"):
        out = tmp_path / f"back.{suffix}"
        assert main(["export", str(tmp_path / "run.h5"), "--out", str(out), "--force"]) == 0
        assert main(["import", str(out), "--out", str(tmp_path / f"{suffix}.h5")]) == 0
        back = open_run(tmp_path / f"{suffix}.h5").recording(0)
        assert (back.control, back.control_dof) == (control, control_dof), suffix
        again = recording_keys(back)
        assert sorted(again) == sorted(keys), suffix
        for k, v in keys.items():
            assert np.array_equal(np.asarray(again[k]), np.asarray(v)), (suffix, k)


def test_levels_held_differently_are_not_one_run(tmp_path):
    from analysis.recordings import Recording
    from nlid_lab.store import save_recording
    recs = [Recording(fs=512.0, excitation="stepped-sine", force_dofs=[0],
                      force=np.ones((2, 32, 1)), response=np.ones((2, 32, 1)),
                      freqs=[10.0, 20.0], level=1.0, control=c, control_dof=d)
            for c, d in (("force", None), ("response", 0))]
    with pytest.raises(StoreError, match="control"):
        save_recording(tmp_path / "run.h5", recs, source="test")
