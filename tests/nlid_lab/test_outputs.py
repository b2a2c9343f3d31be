"""No command replaces an existing output file without --force (exit 2, one line, file kept);
outputs are written whole or not at all."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nlid_lab import store
from nlid_lab.cli import main
from nlid_lab.outputs import OverwriteError, atomic_dir, atomic_path, refuse_overwrite

MODELS = Path(__file__).resolve().parents[2] / "examples" / "models"
SDOF = MODELS / "sdof-cubic-quaddamp.toml"
CAMPAIGN = MODELS.parent / "campaign-sim-random.toml"
OLD = b"precious earlier result\n"


@pytest.fixture
def inputs(tmp_path):
    rng = np.random.default_rng(0)
    np.savez(tmp_path / "drive.npz", fs=1024.0, force=5.0 * rng.normal(size=(2048, 1)),
             force_dofs=[0], force_rms=5.0)
    assert main(["simulate", str(SDOF), "--drive", str(tmp_path / "drive.npz"),
                 "--out", str(tmp_path / "rec.npz")]) == 0
    assert main(["import", str(tmp_path / "rec.npz"), "--out", str(tmp_path / "run.h5")]) == 0
    return tmp_path


def _commands(d: Path) -> dict[str, tuple[list[str], str]]:
    """Each command with an output option pointing at the existing file ``target``."""
    run, rec, model = str(d / "run.h5"), str(d / "rec.npz"), str(SDOF)
    return {
        "import --out": (["import", rec, "--out", "{t}.h5"], "{t}.h5"),
        "import --json": (["import", rec, "--out", str(d / "new.h5"), "--json", "{t}"], "{t}"),
        "simulate --out": (["simulate", model, "--drive", str(d / "drive.npz"), "--out",
                            "{t}.npz"], "{t}.npz"),
        "detect --json": (["detect", run, "--json", "{t}"], "{t}"),
        "export-uff --out": (["export-uff", run, "--out", "{t}"], "{t}"),
        "analyze --json": (["analyze", "reverse-path", run, "--model", model, "--json", "{t}"],
                           "{t}"),
        "analyze hbm --figure loop": (["analyze", "hbm", run, "--model", model, "--figure",
                                       "{t}.png"], "{t}-loop.png"),
        "diagnose --model-out": (["diagnose", model, run, "--model-out", "{t}"], "{t}"),
        "diagnose --json": (["diagnose", model, run, "--json", "{t}"], "{t}"),
        "predict --plot": (["predict", model, "--amplitude", "1", "--band", "5", "40",
                            "--plot", "{t}.png"], "{t}.png"),
        "reanalyze --out": (["reanalyze", run, "--model", model, "--out", "{t}"], "{t}"),
        "view --snapshot": (["view", run, "--snapshot", "{t}.png"], "{t}.png"),
        "campaign run --out": (["campaign", "run", str(CAMPAIGN), "--out", "{t}"], "{t}"),
        "campaign run --json": (["campaign", "run", str(CAMPAIGN), "--out", str(d / "c.h5"),
                                 "--json", "{t}"], "{t}"),
    }


@pytest.mark.parametrize("name", list(_commands(Path("x"))))
def test_existing_output_file_is_refused_and_kept(inputs, capsys, name):
    argv, target = _commands(inputs)[name]
    stem = str(inputs / "existing")
    target = Path(target.format(t=stem))
    target.write_bytes(OLD)
    capsys.readouterr()
    assert main([a.format(t=stem) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(target) in err and "--force" in err
    assert target.read_bytes() == OLD
    assert not (inputs / "new.h5").exists() and not (inputs / "c.h5").exists()


@pytest.mark.parametrize("command", ["report", "demo"])
def test_non_empty_output_directory_is_refused(inputs, capsys, command):
    out = inputs / "out"
    out.mkdir()
    (out / "report.html").write_bytes(OLD)
    argv = (["report", str(inputs / "run.h5"), "--out", str(out)] if command == "report"
            else ["demo", "--out", str(out), "--duration", "1"])
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(out) in err and "--force" in err
    assert sorted(p.name for p in out.iterdir()) == ["report.html"]
    assert (out / "report.html").read_bytes() == OLD


def test_force_replaces_the_run_and_its_stored_results(inputs):
    run = inputs / "run.h5"
    store.save_result(run, "analyze-reverse-path", {"elements": []})
    assert "analyze-reverse-path" in store.open_run(run).results
    rc = main(["import", str(inputs / "rec.npz"), "--out", str(run), "--level", "7",
               "--force"])
    assert rc == 0
    replaced = store.open_run(run)
    assert replaced.results == {} and replaced.recordings()[0].level == 7.0


def test_json_to_stdout_is_never_an_existing_file(inputs, capsys, monkeypatch):
    monkeypatch.chdir(inputs)
    Path("-").write_bytes(OLD)           # a file literally named '-' is not the target
    capsys.readouterr()
    assert main(["import", str(inputs / "rec.npz"), "--out", "new.h5", "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["out"] == "new.h5"
    assert Path("-").read_bytes() == OLD


def test_helper_skips_missing_and_stdout_targets(tmp_path):
    refuse_overwrite(False, None, "-", tmp_path / "absent.json",
                     directories=(None, tmp_path / "absent", tmp_path))
    (tmp_path / "x").write_text("1")
    with pytest.raises(OverwriteError):
        refuse_overwrite(False, tmp_path / "x")
    with pytest.raises(OverwriteError):
        refuse_overwrite(False, directories=(tmp_path,))
    refuse_overwrite(True, tmp_path / "x", directories=(tmp_path,))


def _csv_levels(d: Path, levels=(1.0, 30.0)) -> list[Path]:
    """Two random CSV recordings of the cubic SDOF at different force levels."""
    from analysis.models import Model
    from analysis.plant import simulate
    from analysis.recordings import Recording
    from nlid_lab import formats as recordings_io

    rng = np.random.default_rng(3)
    paths = []
    for lvl in levels:
        f = lvl * rng.normal(size=(8192, 1))
        x = simulate(Model.load(SDOF), f, 1024.0, [0])
        path = d / f"l{lvl:g}.csv"
        recordings_io.write_csv(path, Recording(fs=1024.0, excitation="random",
                                                force_dofs=np.array([0]), force=f, response=x))
        paths.append(path)
    return paths


def test_detect_and_report_on_csv_imports_without_level(tmp_path, capsys):
    runs = []
    for csv in _csv_levels(tmp_path):
        assert main(["import", str(csv), "--out", str(csv.with_suffix(".h5"))]) == 0
        runs.append(str(csv.with_suffix(".h5")))
    with_level = []
    for csv, lvl in zip(_csv_levels(tmp_path), ("1", "30")):
        out = str(csv.with_name(csv.stem + "-lv.h5"))
        assert main(["import", str(csv), "--out", out, "--level", lvl]) == 0
        with_level.append(out)
    capsys.readouterr()
    # given in descending force order: ordered by measured force they compare the same pair
    assert main(["detect", *runs[::-1], "--json", str(tmp_path / "d.json")]) == 0
    text = capsys.readouterr().out
    assert "1 N rms vs 29.6 N rms" in text and "no nominal level" in text   # measured force
    assert main(["detect", *with_level, "--json", str(tmp_path / "e.json")]) == 0
    unknown, known = (json.loads((tmp_path / n).read_text())["tests"][0]
                      for n in ("d.json", "e.json"))
    assert unknown["levels"] == [None, None] and known["levels"] == [1.0, 30.0]
    assert unknown["share_flagged"] == known["share_flagged"]
    assert unknown["median_change_db"] == known["median_change_db"]
    assert main(["report", runs[0], "--out", str(tmp_path / "rep")]) == 0


def test_atomic_path_replaces_only_when_whole(tmp_path):
    """A failure while writing leaves the old file as it was and no temporary behind; success
    replaces it; a missing directory is named by the target's name."""
    target = tmp_path / "out.json"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            assert tmp.parent == tmp_path and tmp.suffix == ".json"
            tmp.write_text("half")
            raise RuntimeError("writer failed")
    assert target.read_text() == "old" and sorted(tmp_path.iterdir()) == [target]
    with atomic_path(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new" and sorted(tmp_path.iterdir()) == [target]
    with pytest.raises(FileNotFoundError) as info:
        with atomic_path(tmp_path / "no" / "x.json") as tmp:
            tmp.write_text("x")
    assert info.value.filename == str(tmp_path / "no" / "x.json")


def test_atomic_dir_moves_a_whole_report_or_nothing(tmp_path):
    out = tmp_path / "rep"
    with pytest.raises(RuntimeError):
        with atomic_dir(out) as tmp:
            (tmp / "a.png").write_bytes(b"png")
            raise RuntimeError("figure failed")
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with atomic_dir(out) as tmp:                         # new directory: renamed whole
        (tmp / "a.png").write_bytes(b"png")
        (tmp / "index.html").write_text("page")
    assert sorted(p.name for p in out.iterdir()) == ["a.png", "index.html"]
    (out / "old.txt").write_text("kept")
    with atomic_dir(out) as tmp:                         # --force into a full one: moved in
        (tmp / "index.html").write_text("page 2")
    assert (out / "index.html").read_text() == "page 2" and (out / "old.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]
