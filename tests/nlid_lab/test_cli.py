"""CLI: simulate/import/demo end to end, and every class of bad input -> exit 2, one line."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from analysis.plant import simulate
from nlid_lab import formats as recordings_io
from nlid_lab import store
from nlid_lab.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "models"
SDOF = EXAMPLES / "sdof-cubic-quaddamp.toml"
THREE = EXAMPLES / "three-dof-paper.toml"
FS = 1024.0


@pytest.fixture
def drives(tmp_path):
    rng = np.random.default_rng(0)
    np.savez(tmp_path / "random.npz", fs=FS, force=5.0 * rng.normal(size=(4096, 1)),
             force_dofs=[0], force_rms=5.0)
    t = np.arange(600) / FS
    freqs = [60.0, 70.0, 80.0]
    np.savez(tmp_path / "stepped.npz", fs=FS, force_dofs=[2], freqs=freqs,
             force=np.stack([20.0 * np.sin(2 * np.pi * f * t)[:, None] for f in freqs]),
             force_amplitude=20.0)
    return tmp_path


def test_simulate_random_npz_and_h5_agree_with_plant(drives, capsys):
    d = drives
    assert main(["simulate", str(SDOF), "--drive", str(d / "random.npz"), "--out",
                 str(d / "o.npz"), "--noise", "1e-7", "--seed", "4"]) == 0
    assert main(["simulate", str(SDOF), "--drive", str(d / "random.npz"), "--out",
                 str(d / "o.h5"), "--noise", "1e-7", "--seed", "4", "--json",
                 str(d / "o.json")]) == 0
    npz = recordings_io.read_npz(d / "o.npz")
    run = store.open_run(d / "o.h5")
    (h5,) = run.recordings()
    with np.load(d / "random.npz") as drive:
        force = drive["force"]
    expected = simulate(Model.load(SDOF), force, FS, [0], noise_std=1e-7, seed=4)
    np.testing.assert_array_equal(npz.response, expected)  # same plant, same seed
    np.testing.assert_array_equal(h5.response, expected)
    np.testing.assert_array_equal(h5.force, force)
    assert h5.level == 5.0 and run.status == "complete" and run.meta["source"] == "sim"
    assert Model.loads(run.meta["model_toml"]).to_dict() == Model.load(SDOF).to_dict()
    result = json.loads((d / "o.json").read_text())
    assert result["n_samples"] == 4096 and result["excitation"] == "random"
    assert "o.h5" in capsys.readouterr().out


def test_simulate_stepped_round_trip(drives):
    d = drives
    assert main(["simulate", str(THREE), "--drive", str(d / "stepped.npz"), "--out",
                 str(d / "s.h5"), "--response-kind", "acceleration"]) == 0
    assert main(["simulate", str(THREE), "--drive", str(d / "stepped.npz"), "--out",
                 str(d / "s.npz"), "--response-kind", "acceleration"]) == 0
    (rec,) = recordings_io.load_recordings(d / "s.h5")
    npz = recordings_io.read_npz(d / "s.npz")
    assert rec.excitation == "stepped-sine" and rec.response.shape == (3, 600, 3)
    assert rec.response_kind == "acceleration" and rec.level == 20.0
    np.testing.assert_array_equal(rec.freqs, [60.0, 70.0, 80.0])
    np.testing.assert_array_equal(rec.response, npz.response)
    # the steps continue one record: same as simulating them back to back
    with np.load(d / "stepped.npz") as drive:
        joined = drive["force"].reshape(-1, 1)
    whole = simulate(Model.load(THREE), joined, FS, [2], response_kind="acceleration")
    np.testing.assert_allclose(rec.response.reshape(-1, 3), whole, rtol=0,
                               atol=1e-12 * np.abs(whole).max())


def test_import_npz_and_csv(tmp_path):
    rng = np.random.default_rng(5)
    rec_kw = dict(fs=FS, force_dofs=[1], force=rng.normal(size=(2048, 1)),
                  response=rng.normal(size=(2048, 2)))
    np.savez(tmp_path / "r.npz", excitation="random", response_kind="velocity", **rec_kw)
    assert main(["import", str(tmp_path / "r.npz"), "--out", str(tmp_path / "r.h5")]) == 0
    run = store.open_run(tmp_path / "r.h5")
    (back,) = run.recordings()
    np.testing.assert_array_equal(back.response, rec_kw["response"])
    assert back.response_kind == "velocity" and run.meta["source"] == "import"
    rows = np.column_stack([np.arange(2048) / FS, rec_kw["response"][:, 1],
                            rec_kw["force"][:, 0], rec_kw["response"][:, 0]])
    np.savetxt(tmp_path / "r.csv", rows, delimiter=",", fmt="%.17g",
               header="t,v1@1,shaker@1,v0@0", comments="")
    assert main(["import", str(tmp_path / "r.csv"), "--out", str(tmp_path / "c.h5"),
                 "--force-cols", "shaker", "--response-kind", "velocity", "--level",
                 "1.0"]) == 0
    (back,) = recordings_io.load_recordings(tmp_path / "c.h5")
    np.testing.assert_array_equal(back.force, rec_kw["force"])
    np.testing.assert_array_equal(back.response, rec_kw["response"])
    assert back.level == 1.0 and back.fs == pytest.approx(FS, rel=1e-12)


def _write(path: Path, text: str) -> str:
    path.write_text(text)
    return str(path)


def _bad_cases(d: Path) -> dict[str, list[str]]:
    drive = str(d / "random.npz")
    out = str(d / "o.npz")
    unknown = SDOF.read_text().replace("cubic_spring", "spline_spring")
    partial = SDOF.read_text().replace("p = 6.0e10\n", "")
    np.savez(d / "nan.npz", fs=FS, force_dofs=[0], force=np.full((64, 1), np.nan))
    np.savez(d / "shape.npz", fs=FS, force_dofs=[0, 1], force=np.ones((64, 1)))
    np.savez(d / "dof.npz", fs=FS, force_dofs=[3], force=np.ones((64, 1)))
    np.savez(d / "nanrec.npz", fs=FS, force_dofs=[0], force=np.ones((64, 1)),
             response=np.full((64, 1), np.nan))
    return {
        "missing model": ["simulate", str(d / "none.toml"), "--drive", drive, "--out", out],
        "malformed toml": ["simulate", _write(d / "bad.toml", "[linear\n"), "--drive", drive,
                           "--out", out],
        "wrong matrix shape": ["simulate", _write(d / "shape.toml", "[linear]\nmass = [[1.0, 0]]"
                                                  "\ndamping = [[1.0]]\nstiffness = [[1.0]]\n"),
                               "--drive", drive, "--out", out],
        "unknown kind": ["simulate", _write(d / "kind.toml", unknown), "--drive", drive,
                         "--out", out],
        "missing parameter": ["simulate", _write(d / "part.toml", partial), "--drive", drive,
                              "--out", out],
        "missing drive": ["simulate", str(SDOF), "--drive", str(d / "none.npz"), "--out", out],
        "nan drive": ["simulate", str(SDOF), "--drive", str(d / "nan.npz"), "--out", out],
        "drive shape": ["simulate", str(SDOF), "--drive", str(d / "shape.npz"), "--out", out],
        "drive dof": ["simulate", str(SDOF), "--drive", str(d / "dof.npz"), "--out", out],
        "bad out suffix": ["simulate", str(SDOF), "--drive", drive, "--out", str(d / "o.txt")],
        "negative noise": ["simulate", str(SDOF), "--drive", drive, "--out", out, "--noise",
                           "-1"],
        "missing option": ["simulate", str(SDOF), "--out", out],
        "import missing": ["import", str(d / "none.npz"), "--out", str(d / "x.h5")],
        "import nan": ["import", str(d / "nanrec.npz"), "--out", str(d / "x.h5")],
        "import csv header": ["import", _write(d / "h.csv", "t,f,x@0\n0,1,2\n1,1,2\n2,1,2\n"),
                              "--out", str(d / "x.h5")],
        "import csv nan": ["import", _write(d / "n.csv", "t,f@0,x@0\n0,1,2\n1,nan,2\n2,1,2\n"),
                           "--out", str(d / "x.h5")],
        "import type": ["import", _write(d / "r.txt", "x"), "--out", str(d / "x.h5")],
        "import out": ["import", drive, "--out", str(d / "x.npz")],
        "demo duration": ["demo", "--out", str(d / "demo"), "--duration", "-1"],
    }


def test_bad_input_exit_2_one_line(drives, capsys):
    for name, argv in _bad_cases(drives).items():
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse errors
            code = exc.code
        err = capsys.readouterr().err
        assert code == 2, name
        lines = err.strip().splitlines()
        assert len(lines) == 1, (name, err)
        assert "Traceback" not in err and lines[0].startswith("nlid-lab"), (name, err)


def test_console_script_bad_input_subprocess(drives):
    exe = Path(sys.executable).with_name("nlid-lab")
    env = {**os.environ, "NLID_DEBUG": "0"}
    cases = _bad_cases(drives)
    for name in ("malformed toml", "nan drive", "unknown kind"):
        proc = subprocess.run([str(exe), *cases[name]], capture_output=True, text=True,
                              env=env, timeout=120)
        assert proc.returncode == 2, (name, proc.stderr)
        assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_demo_short(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--duration", "32", "--json",
                 str(tmp_path / "d.json")]) == 0
    printed = capsys.readouterr().out
    run = store.open_run(out / "sdof-random.h5")
    assert run.status == "complete" and [lv.nominal for lv in run.levels] == [0.5, 5, 15, 30]
    assert all(lv.complete and lv.n_samples == 32 * 1024 for lv in run.levels)
    assert (out / "frf-levels.png").stat().st_size > 10_000
    assert str(out / "sdof-random.h5") in printed and "frf-levels.png" in printed
    peaks = json.loads((tmp_path / "d.json").read_text())["levels"]
    # hardening spring + quadratic damping: the resonance moves up and drops with level
    hz = [p["peak_hz"] for p in peaks]
    height = [p["peak_m_per_n"] for p in peaks]
    assert hz == sorted(hz) and hz[-1] > hz[0] + 2.0
    assert height == sorted(height, reverse=True) and height[-1] < 0.5 * height[0]
    # the lowest level is linear-ish: its resonance is the linear one within a bin (0.25 Hz)
    model = Model.load(SDOF)
    assert abs(hz[0] - model.natural_frequencies()[0]) <= 0.25


def test_progress_switch(monkeypatch, capsys):
    from nlid_lab.progress import progress
    monkeypatch.setenv("NLID_PROGRESS", "1")
    assert list(progress(range(3), desc="forced")) == [0, 1, 2]
    assert "forced" in capsys.readouterr().err
    monkeypatch.setenv("NLID_PROGRESS", "0")
    list(progress(range(3), desc="silent"))
    assert capsys.readouterr().err == ""


def test_diagnose_prints_its_verdict_unless_quiet(tmp_path, capsys, diagnose_once):
    """With --json FILE the verdict still reaches the terminal; --json - keeps stdout pure
    JSON (the verdict goes to stderr); --quiet prints nothing (one diagnosis for the three
    calls on the same runs: `diagnose_once`)."""
    from diagnose_scenarios import hidden_cubic
    sc = hidden_cubic(n=1 << 13)
    sc.start.save(tmp_path / "start.toml")
    runs = []
    for i, rec in enumerate(sc.recordings):
        recordings_io.write_npz(tmp_path / f"level{i}.npz", rec)
        runs.append(str(tmp_path / f"level{i}.npz"))
    base = ["diagnose", str(tmp_path / "start.toml"), *runs]
    assert main([*base, "--json", str(tmp_path / "d.json")]) == 0
    result = json.loads((tmp_path / "d.json").read_text())
    shown = f"{result['verdict']}: {result['explanation']}"
    out = capsys.readouterr().out
    assert out.startswith(shown)
    # then the ranked locations, the best first, with the numbers behind the rank
    best = result["evidence"]["locations"][0]
    assert "where (best candidate per location" in out
    assert f"{' - '.join(best['points'])}" in out.split("where (")[1].splitlines()[1]
    assert main([*base, "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["verdict"] == result["verdict"]
    assert shown in captured.err
    assert main([*base, "--json", str(tmp_path / "q.json"), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    assert json.loads((tmp_path / "q.json").read_text())["verdict"] == result["verdict"]


def test_quiet_commands_print_nothing(drives, capsys):
    """--quiet: no summary on either stream, the JSON result still written."""
    d = drives
    with np.load(d / "random.npz") as drive:
        np.savez(d / "strong.npz", **{**drive, "force": 4 * drive["force"], "force_rms": 20.0})
    runs = [str(d / "r5.npz"), str(d / "r20.npz")]
    for drive, out in zip(("random.npz", "strong.npz"), runs):
        assert main(["simulate", str(SDOF), "--drive", str(d / drive), "--out", out,
                     "--noise", "1e-7"]) == 0
    _write(d / "cand.toml", SDOF.read_text().replace("p = 6.0e10\n", ""))
    commands = {
        "detect": ["detect", *runs],
        "analyze": ["analyze", "reverse-path", *runs, "--model", str(d / "cand.toml")],
        "predict": ["predict", str(SDOF), "--amplitude", "1", "--band", "5", "40"],
    }
    for name, argv in commands.items():
        capsys.readouterr()
        assert main(argv) == 0, name
        assert capsys.readouterr().out.strip(), name         # a summary by default
        assert main([*argv, "--json", str(d / f"{name}.json"), "--quiet"]) == 0, name
        captured = capsys.readouterr()
        assert captured.out == "" and captured.err == "", (name, captured)
        assert json.loads((d / f"{name}.json").read_text()), name
