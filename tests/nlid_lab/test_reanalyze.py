"""Reanalysis on Dask: identical tables for 1 and 2 workers, failures per run, --scheduler."""

from __future__ import annotations

import json
import math
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from analysis.plant import Plant, random_gaussian, simulate, sine_block
from analysis.models import Element, Model
from analysis.recordings import Recording
from analysis.reverse_path import ReversePathOptions, reverse_path
from nlid_lab import cli, reanalyze as rea
from nlid_lab.formats import load_recordings
from nlid_lab.methods import BatchOptions
from nlid_lab.store import RunWriter, TableError, read_table, save_recording, write_table

DEFAULTS = BatchOptions()   # every method's defaults

pytest.importorskip("distributed")

MODELS = Path(__file__).resolve().parents[2] / "examples" / "models"
FS = 2000.0
N = 16384
BAND = (5.0, 300.0)
P_COL = "e0.cubic_spring.p"


def _true_model() -> Model:
    return Model.load(MODELS / "sdof-cubic-quaddamp.toml")


def _record(rms: float, seed: int, model: Model) -> tuple[np.ndarray, np.ndarray]:
    force = random_gaussian(N, FS, BAND, rms, seed=seed)[:, None]
    return force, simulate(model, force, FS, [0], noise_std=0.0, seed=seed)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> dict:
    """Three good runs (one with two levels), a damaged file and a run of the wrong size."""
    root = tmp_path_factory.mktemp("campaign")
    true = _true_model()
    good = []
    with RunWriter(root / "r0.h5", fs=FS, excitation="random", force_dofs=[0], n_dof=1) as run:
        for index, rms in enumerate((20.0, 40.0)):
            level = run.level(index, rms)
            level.append_block(*_record(rms, 10 + index, true))
            level.complete()
    good.append(root / "r0.h5")
    for i, rms in enumerate((30.0, 50.0), start=1):
        force, x = _record(rms, 20 + i, true)
        save_recording(root / f"r{i}.h5", Recording(FS, "random", [0], force, x, level=rms))
        good.append(root / f"r{i}.h5")
    corrupt = root / "r9-corrupt.h5"
    damaged = bytearray((root / "r1.h5").read_bytes())
    damaged[:1024] = bytes(1024)                       # superblock overwritten
    corrupt.write_bytes(damaged)
    wrong = root / "r8-two-dof.h5"
    force, x = _record(30.0, 5, true)
    save_recording(wrong, Recording(FS, "random", [0], force, np.hstack([x, x]), level=30.0))
    cand = root / "candidate.toml"
    true.with_elements([Element(el.kind, el.w, {}) for el in true.elements]).save(cand)
    return {"root": root, "good": [str(p) for p in good], "corrupt": str(corrupt),
            "wrong": str(wrong), "candidate": str(cand), "true": true}


@pytest.fixture(scope="module")
def one_worker(campaign) -> rea.Reanalysis:
    """Reference result: every run of the campaign on one local worker."""
    runs = campaign["good"] + [campaign["corrupt"], campaign["wrong"]]
    with rea.dask_client(workers=1) as client:
        return rea.reanalyze(runs, Model.load(campaign["candidate"]), client, progress=False)


def _differences(a: list[dict], b: list[dict]) -> list[tuple]:
    """(row, column, a, b) wherever two tables differ (NaN equals NaN); [] when identical."""
    def same(x, y):
        return x == y or (isinstance(x, float) and isinstance(y, float)
                          and math.isnan(x) and math.isnan(y))
    if len(a) != len(b) or any(list(ra) != list(rb) for ra, rb in zip(a, b)):
        return [("shape", None, [list(r) for r in a], [list(r) for r in b])]
    return [(i, k, ra[k], rb[k]) for i, (ra, rb) in enumerate(zip(a, b)) for k in ra
            if not same(ra[k], rb[k])]


# --- results table ---------------------------------------------------------------------------
def test_table_round_trip(tmp_path):
    rows = [{"path": "a.h5", "level_index": 0, "x": 1.5, "flag": True, "note": None},
            {"path": "b.h5", "level_index": -1, "x": None, "flag": False, "note": "héllo"}]
    write_table(tmp_path / "t.h5", rows, {"method": "reverse-path", "options": {"band": [1, 2]},
                                          "n": 2})
    back, attrs = read_table(tmp_path / "t.h5")
    assert [r["path"] for r in back] == ["a.h5", "b.h5"]
    assert back[0]["level_index"] == 0 and back[1]["level_index"] == -1
    assert back[0]["x"] == 1.5 and math.isnan(back[1]["x"])
    assert back[0]["note"] == "" and back[1]["note"] == "héllo"
    assert [r["flag"] for r in back] == [True, False]
    assert list(back[0]) == ["path", "level_index", "x", "flag", "note"]
    assert attrs == {"method": "reverse-path", "options": {"band": [1, 2]}, "n": 2}


def test_read_table_rejects_other_files(tmp_path, campaign):
    with pytest.raises(TableError, match="reanalyze"):
        read_table(campaign["good"][1])        # a run, not a table
    (tmp_path / "x.h5").write_text("not hdf5")
    with pytest.raises(TableError, match="cannot open"):
        read_table(tmp_path / "x.h5")


def test_expand_runs(campaign, tmp_path):
    runs = rea.expand_runs([campaign["root"]])
    assert runs == sorted(runs) and set(campaign["good"]) <= set(runs)
    assert campaign["candidate"] not in runs
    with pytest.raises(rea.ReanalysisError, match="no such run"):
        rea.expand_runs([tmp_path / "missing.h5"])
    with pytest.raises(rea.ReanalysisError, match="holds no"):
        rea.expand_runs([tmp_path])


def test_rows_flatten_into_one_table_with_every_column():
    ok = rea.LevelRow("a.h5", 0, 20.0, "random", "reverse-path", "ok",
                      {P_COL: 6e10, P_COL + ".ci95_lo": 5e10, P_COL + ".ci95_hi": 7e10},
                      coherence_min=0.99)
    failed = rea.LevelRow("b.h5", -1, None, None, "reverse-path", "failed", error="cut")
    table = rea.table_json([ok, failed])
    assert list(table[0]) == list(table[1]) == [*rea.HEAD, P_COL, P_COL + ".ci95_lo",
                                                P_COL + ".ci95_hi", "coherence_min",
                                                "warnings", "error"]     # no row has a cost
    assert table[0][P_COL] == 6e10 and table[1][P_COL] is None
    assert table[1]["status"] == "failed" and table[1]["error"] == "cut"
    result = rea.Reanalysis([ok, failed], "reverse-path", 2, 1, "local", 0.1)
    assert result.parameter_columns() == [P_COL] and result.failed_runs == ["b.h5"]
    assert result.to_json()["schema_version"] == 1


# --- the task, in this process -----------------------------------------------------------------
def test_task_matches_direct_reverse_path(campaign):
    """A worker row carries exactly what reverse path reports for that level."""
    model = Model.load(campaign["candidate"])
    rows = rea.analyse_run(campaign["good"][0], model, "reverse-path", DEFAULTS)
    assert [r.level_index for r in rows] == [0, 1]
    assert [r.level for r in rows] == [20.0, 40.0]
    for row, rec in zip(rows, load_recordings(campaign["good"][0])):
        direct = reverse_path(rec, model).to_json()
        el = direct["elements"][0]
        assert row.status == "ok"
        assert row.estimates[P_COL] == el["params"]["p"]
        assert [row.estimates[P_COL + ".ci95_lo"],
                row.estimates[P_COL + ".ci95_hi"]] == el["ci95"]["p"]
        assert row.coherence_min == direct["multiple_coherence"]["min"]
        assert row.warnings == " | ".join(direct["warnings"])
    seq = rea.analyse_run(campaign["good"][1], model, "reverse-path",
                          BatchOptions.of(refine="sequential"))
    direct = reverse_path(load_recordings(campaign["good"][1])[0], model,
                          ReversePathOptions(refine="sequential"))
    assert seq[0].estimates[P_COL] == direct.to_json()["elements"][0]["params"]["p"]


def test_task_turns_failures_into_rows(campaign):
    model = Model.load(campaign["candidate"])
    (bad,) = rea.analyse_run(campaign["corrupt"], model, "reverse-path", DEFAULTS)
    assert bad.status == "failed" and bad.level_index == -1
    assert bad.error and "\n" not in bad.error
    (wrong,) = rea.analyse_run(campaign["wrong"], model, "reverse-path", DEFAULTS)
    assert wrong.status == "failed" and wrong.level_index == 0
    assert "DOF" in wrong.error


@pytest.fixture(scope="module")
def stepped_run(tmp_path_factory) -> str:
    """One stepped-sine level through the resonance (settled steps, no noise)."""
    true = _true_model()
    plant = Plant(true, FS, [0])
    freqs, amp, n_settle, n_keep = np.linspace(40.0, 65.0, 12), 50.0, 2000, 1000
    force, response = [], []
    for f in freqs:                       # one continuous drive, as on the shaker
        block = sine_block(f, amp, n_settle + n_keep, FS)[:, None]
        force.append(block[-n_keep:])
        response.append(plant.run(block).response[-n_keep:])
    path = tmp_path_factory.mktemp("stepped") / "s0.h5"
    save_recording(path, Recording(FS, "stepped-sine", [0], np.stack(force), np.stack(response),
                                   freqs=freqs, level=amp))
    return str(path)


def test_task_hbm_on_stepped_sine(stepped_run):
    """auto picks HBM for stepped sine; only estimated parameters become columns."""
    true = _true_model()
    cand = true.with_elements([Element("cubic_spring", true.elements[0].w, {}),
                               true.elements[1]])
    (row,) = rea.analyse_run(stepped_run, cand, "auto", BatchOptions.of(harmonics="1,3,5"))
    assert row.status == "ok" and row.method == "hbm", row.error
    assert row.cost >= 0 and "e1.quadratic_damping.p" not in row.estimates
    half = (row.estimates[P_COL + ".ci95_hi"] - row.estimates[P_COL + ".ci95_lo"]) / 2
    assert abs(row.estimates[P_COL] - true.elements[0].params["p"]) <= 2 * half
    (bad,) = rea.analyse_run(stepped_run, cand, "reverse-path", DEFAULTS)
    assert bad.status == "failed" and bad.error and "\n" not in bad.error


def test_task_reports_a_truncated_run(campaign, tmp_path):
    """A copy cut short fails at once with a clear line (no SWMR retry loop)."""
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(Path(campaign["good"][1]).read_bytes()[:3000])
    (row,) = rea.analyse_run(str(truncated), Model.load(campaign["candidate"]),
                             "reverse-path", DEFAULTS)
    assert row.status == "failed" and "truncated" in row.error


# --- on Dask -----------------------------------------------------------------------------------
def test_one_and_two_workers_give_identical_tables(campaign, one_worker):
    runs = campaign["good"] + [campaign["corrupt"], campaign["wrong"]]
    with rea.dask_client(workers=2) as client:
        two = rea.reanalyze(runs, Model.load(campaign["candidate"]), client, progress=False)
    assert one_worker.n_workers == 1 and two.n_workers == 2
    assert _differences(rea.table_json(one_worker.rows), rea.table_json(two.rows)) == []
    # Input order (run, then level), whatever the completion order.
    assert [(r.path, r.level_index) for r in two.rows] == [
        (campaign["good"][0], 0), (campaign["good"][0], 1), (campaign["good"][1], 0),
        (campaign["good"][2], 0), (campaign["corrupt"], -1), (campaign["wrong"], 0)]
    assert (two.n_ok, two.n_failed) == (4, 2)
    assert two.failed_runs == [campaign["corrupt"], campaign["wrong"]]


def test_estimates_agree_with_the_true_plant(one_worker, campaign):
    """Cubic stiffness within twice its reported 95 % half-width (about 4 sigma) of the truth."""
    p_true = campaign["true"].elements[0].params["p"]
    ok = [r for r in one_worker.rows if r.ok]
    assert len(ok) == 4
    for row in ok:
        half = (row.estimates[P_COL + ".ci95_hi"] - row.estimates[P_COL + ".ci95_lo"]) / 2
        assert 0 < half < 0.2 * p_true
        assert abs(row.estimates[P_COL] - p_true) <= 2 * half, row


def test_cli_writes_table_and_reports_failures(campaign, tmp_path, capsys):
    out, js = tmp_path / "res.h5", tmp_path / "res.json"
    code = cli.main(["reanalyze", str(campaign["root"]), "--model", campaign["candidate"],
                     "--workers", "2", "--out", str(out), "--json", str(js), "--no-progress"])
    assert code == 1                                   # some runs failed, table still written
    text = capsys.readouterr().out
    assert "4 ok, 2 failed" in text and "r9-corrupt.h5" in text
    rows, attrs = read_table(out)
    assert attrs["method"] == "reverse-path" and attrs["n_failed"] == 2
    assert Model.loads(attrs["model_toml"]).n_dof == 1
    by_path = {(Path(r["path"]).name, r["level_index"]): r for r in rows}
    assert by_path[("r9-corrupt.h5", -1)]["status"] == "failed"
    assert by_path[("r9-corrupt.h5", -1)]["error"]
    assert all(by_path[(f"r{i}.h5", 0)]["status"] == "ok" for i in range(3))
    result = json.loads(js.read_text())
    assert result["n_ok"] == 4 and result["n_failed"] == 2 and len(result["rows"]) == 6
    assert result["rows"][-1]["e0.cubic_spring.p"] is None     # NaN -> null in JSON


def test_cli_exit_0_when_all_runs_succeed(campaign, tmp_path, capsys):
    code = cli.main(["reanalyze", *campaign["good"][1:], "--model", campaign["candidate"],
                     "--workers", "1", "--out", str(tmp_path / "r.h5"), "--json", "-",
                     "--no-progress"])
    assert code == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["n_failed"] == 0   # stdout is pure JSON with --json -
    assert "2 ok, 0 failed" in captured.err


def test_cli_bad_input_exits_2(campaign, tmp_path, capsys, monkeypatch):
    base = ["reanalyze", "--model", campaign["candidate"], "--out", str(tmp_path / "r.h5")]
    assert cli.main(base + [str(tmp_path / "missing.h5")]) == 2
    assert "no such run file" in capsys.readouterr().err
    (tmp_path / "bad.toml").write_text("name = 'x'\n")
    assert cli.main(["reanalyze", campaign["good"][1], "--model", str(tmp_path / "bad.toml"),
                     "--out", str(tmp_path / "r.h5")]) == 2
    assert "no [linear] table" in capsys.readouterr().err
    assert cli.main(["reanalyze", campaign["good"][1], "--model",
                     str(MODELS / "sdof-cubic-quaddamp.toml"), "--out", str(tmp_path / "r.h5"),
                     "--workers", "1"]) == 2
    assert "no unknown parameter" in capsys.readouterr().err
    assert cli.main(["reanalyze", campaign["good"][1], "--model", campaign["candidate"],
                     "--out", str(tmp_path / "nowhere" / "r.h5")]) == 2
    assert "directory does not exist" in capsys.readouterr().err
    monkeypatch.setattr(rea, "CONNECT_TIMEOUT_S", 1.0)
    port = _free_port()
    assert cli.main(base + [campaign["good"][1], "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err
    assert "cannot reach Dask scheduler" in err and err.count("\n") == 1


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes")
def test_run_time_limit_frees_a_stuck_worker(campaign, tmp_path):
    """A run that never returns (a named pipe nobody writes: open() blocks inside HDF5)
    becomes a failed row once its time limit is over; the run before it is kept."""
    import dask

    stuck = tmp_path / "stuck.h5"
    os.mkfifo(stuck)
    model = Model.load(campaign["candidate"])
    good = campaign["good"][1]
    # two single-thread workers: each run gets its own, so the stuck run's worker dying
    # cannot take the good run (queued behind it on one worker) down with it
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            rea.dask_client(workers=2) as client:
        client.run(rea.analyse_run, good, model, "reverse-path", DEFAULTS)   # imports, numba
        result = rea.reanalyze([good, str(stuck)], model, client, progress=False,
                               run_timeout_s=3.0)
    ok, lost = result.rows
    assert ok.status == "ok", ok.error
    assert lost.status == "failed" and "3 s run time limit" in lost.error


# --- a real cluster on loopback ----------------------------------------------------------------
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)


@pytest.fixture
def dask_cluster(tmp_path):
    """``dask scheduler`` and one ``dask worker`` (1 process, 1 thread) on 127.0.0.1."""
    from distributed import Client

    dask_cli = shutil.which("dask", path=str(Path(sys.executable).parent))
    if dask_cli is None:
        pytest.skip("the dask CLI is not installed in this environment")
    address = f"tcp://127.0.0.1:{_free_port()}"
    logs = [open(tmp_path / name, "w") for name in ("scheduler.log", "worker.log")]
    procs = [subprocess.Popen([dask_cli, "scheduler", "--host", "127.0.0.1", "--port",
                               address.rsplit(":", 1)[1], "--no-dashboard"],
                              stdout=logs[0], stderr=subprocess.STDOUT, cwd=tmp_path)]
    try:
        procs.append(subprocess.Popen([dask_cli, "worker", address, "--host", "127.0.0.1",
                                       "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                                      stdout=logs[1], stderr=subprocess.STDOUT, cwd=tmp_path,
                                      env={**os.environ, "PYTHONUNBUFFERED": "1"}))
        deadline = time.monotonic() + 60
        while True:
            try:
                with Client(address, timeout=5) as client:
                    client.wait_for_workers(1, timeout=max(1.0, deadline - time.monotonic()))
                break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline or any(p.poll() is not None for p in procs):
                    raise RuntimeError("dask cluster did not come up:\n" + "".join(
                        (tmp_path / n).read_text()[-2000:] for n in ("scheduler.log",
                                                                      "worker.log")))
        yield address
    finally:
        for proc in reversed(procs):
            _stop(proc)
        for log in logs:
            log.close()


def test_cli_through_an_existing_scheduler(campaign, one_worker, dask_cluster, tmp_path):
    out = tmp_path / "res.h5"
    runs = campaign["good"] + [campaign["corrupt"], campaign["wrong"]]
    code = cli.main(["reanalyze", *runs, "--model", campaign["candidate"],
                     "--scheduler", dask_cluster, "--out", str(out), "--no-progress"])
    assert code == 1
    rows, attrs = read_table(out)
    assert attrs["n_workers"] == 1 and attrs["n_failed"] == 2
    rea.write_results(one_worker, tmp_path / "ref.h5")
    assert _differences(rows, read_table(tmp_path / "ref.h5")[0]) == []
