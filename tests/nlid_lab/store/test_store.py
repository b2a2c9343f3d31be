"""HDF5 run store: round trips, levels, losses, results, crash safety and resume."""

from __future__ import annotations

import random
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from analysis.recordings import Recording
from nlid_lab import formats as recordings_io
from nlid_lab import store

BLOCK = 512

# Writes blocks whose samples all equal the block counter, printing the counter after each
# append returns; run in a subprocess and killed with SIGKILL.
WRITER = textwrap.dedent(f"""
    import sys
    import numpy as np
    from nlid_lab import store
    with store.RunWriter(sys.argv[1], fs=1000.0, excitation="random", force_dofs=[0],
                         n_dof=2, mode="overwrite") as run:
        i = 0
        for lv in range(3):
            level = run.level(lv, 1.0 + lv)
            for _ in range(200):
                level.append_block(np.full(({BLOCK}, 1), float(i)),
                                   np.full(({BLOCK}, 2), -float(i)))
                print(i, flush=True)
                i += 1
            level.complete()
        print("done", flush=True)
        import time; time.sleep(60)
""")


def _random_run(path, rng, n_blocks=(3, 2), block=700):
    force = {lv: rng.normal(size=(n * block, 2)) for lv, n in enumerate(n_blocks)}
    resp = {lv: rng.normal(size=(n * block, 3)) for lv, n in enumerate(n_blocks)}
    with store.RunWriter(path, fs=2048.0, excitation={"kind": "random", "band": [5, 300]},
                         force_dofs=[0, 2], n_dof=3, model_toml="name = 'x'\n",
                         settings={"backend": "sim"}) as run:
        for lv, n in enumerate(n_blocks):
            level = run.level(lv, 10.0 * (lv + 1))
            for b in range(n):
                sl = slice(b * block, (b + 1) * block)
                level.append_block(force[lv][sl], resp[lv][sl])
            level.complete()
        run.count_loss(frames=2, samples=100, note="usb hiccup")
        run.save_result("reverse-path", {"p": 3.0e9})
    return force, resp


def test_random_round_trip_with_levels(tmp_path):
    path = tmp_path / "r.h5"
    force, resp = _random_run(path, np.random.default_rng(0))
    run = store.open_run(path)
    assert run.status == "complete"
    assert run.meta["schema_version"] == store.SCHEMA_VERSION
    assert run.meta["fs"] == 2048.0 and run.meta["n_dof"] == 3
    assert run.meta["excitation_settings"] == {"kind": "random", "band": [5, 300]}
    assert run.meta["model_toml"] == "name = 'x'\n"
    assert run.meta["software"].startswith("nlid-lab ")
    assert run.meta["created_utc"].endswith("+00:00")
    assert [(c["name"], c["dof"], c["kind"]) for c in run.channels] == [
        ("force0", 0, "force"), ("force1", 2, "force"),
        ("d0", 0, "response"), ("d1", 1, "response"), ("d2", 2, "response")]
    assert [(lv.index, lv.nominal, lv.complete, lv.n_segments) for lv in run.levels] == [
        (0, 10.0, True, 3), (1, 20.0, True, 2)]
    assert run.losses == {"frames": 2, "samples": 100}
    assert run.results == {"reverse-path": {"p": 3.0e9}}
    recs = run.recordings()
    for lv, rec in enumerate(recs):
        assert rec.excitation == "random" and rec.level == 10.0 * (lv + 1)
        np.testing.assert_array_equal(rec.force, force[lv])
        np.testing.assert_array_equal(rec.response, resp[lv])
        np.testing.assert_array_equal(rec.force_dofs, [0, 2])
        assert rec.meta["seq"].tolist() == list(range(len(rec.meta["seq"])))
    with pytest.raises(store.StoreError, match="choose one"):
        run.recording()


def test_stepped_round_trip_uneven_steps(tmp_path):
    rng = np.random.default_rng(1)
    path = tmp_path / "s.h5"
    lengths, freqs = [300, 256, 410], [20.0, 25.0, 30.0]
    steps = [(rng.normal(size=(n, 1)), rng.normal(size=(n, 2))) for n in lengths]
    with store.RunWriter(path, fs=1000.0, excitation="stepped-sine", force_dofs=[1],
                         n_dof=2) as run:
        level = run.level(0, 5.0)
        for f, (fo, re) in zip(freqs, steps):
            level.append_step(f, fo, re, amplitude=5.0, extra={"settled": True})
    rec = store.open_run(path).recording()
    assert rec.excitation == "stepped-sine" and rec.force.shape == (3, 256, 1)
    np.testing.assert_array_equal(rec.freqs, freqs)
    for i, (fo, re) in enumerate(steps):  # the last (most settled) samples are kept
        np.testing.assert_array_equal(rec.force[i], fo[-256:])
        np.testing.assert_array_equal(rec.response[i], re[-256:])
    assert rec.meta["step_extra"] == [{"settled": True}] * 3
    assert rec.meta["step_lengths"].tolist() == lengths


def test_save_recording_and_load_recordings(tmp_path):
    rng = np.random.default_rng(2)
    rec = Recording(fs=500.0, excitation="stepped-sine", force_dofs=[0],
                    force=rng.normal(size=(4, 100, 1)), response=rng.normal(size=(4, 100, 3)),
                    response_kind="acceleration", freqs=[10, 11, 12, 13], level=2.5)
    store.save_recording(tmp_path / "x.h5", rec, source="import")
    (back,) = recordings_io.load_recordings(tmp_path / "x.h5")
    for key in ("force", "response", "freqs", "force_dofs"):
        np.testing.assert_array_equal(getattr(back, key), getattr(rec, key))
    assert (back.response_kind, back.level, back.fs) == ("acceleration", 2.5, 500.0)


def test_save_result_on_closed_run_and_status(tmp_path):
    path = tmp_path / "r.h5"
    with pytest.raises(RuntimeError):
        with store.RunWriter(path, fs=100.0, excitation="random", force_dofs=[0],
                             n_dof=1) as run:
            run.level(0, 1.0).append_block(np.ones(10), np.ones(10))
            raise RuntimeError("amplifier tripped")
    run = store.open_run(path)
    assert run.status == "aborted" and "amplifier tripped" in run.reason
    store.save_result(path, "hbm", {"cost": 1.0})
    store.save_result(path, "hbm", {"cost": 0.5})
    assert store.open_run(path).results == {"hbm": {"cost": 0.5}}


def test_writer_rejects_bad_input(tmp_path):
    path = tmp_path / "r.h5"
    kw = dict(fs=100.0, excitation="random", force_dofs=[0], n_dof=2)
    with pytest.raises(store.StoreError, match="excitation kind"):
        store.RunWriter(path, **{**kw, "excitation": "chirp"})
    with pytest.raises(store.StoreError, match="force_dofs"):
        store.RunWriter(path, **{**kw, "force_dofs": [2]})
    with store.RunWriter(path, **kw) as run:
        with pytest.raises(store.StoreError, match="block shapes"):
            run.level(0, 1.0).append_block(np.ones((10, 1)), np.ones((10, 3)))
    with pytest.raises(store.StoreError, match="already exists"):
        store.RunWriter(path, **kw)
    with pytest.raises(store.StoreError, match="fs is"):
        store.RunWriter(path, **{**kw, "fs": 200.0}, mode="resume")
    with pytest.raises(store.StoreError, match="not found"):
        store.open_run(tmp_path / "missing.h5")
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(store.StoreError, match="cannot open"):
        store.open_run(tmp_path / "junk.h5")


def _kill_writer(path, n_lines: int, extra_delay: float) -> int:
    """Start the writer, kill it with SIGKILL after ``n_lines`` blocks (+ a delay)."""
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)],
                            stdout=subprocess.PIPE, text=True)
    try:
        printed = -1
        for _ in range(n_lines):
            printed = int(proc.stdout.readline())
        time.sleep(extra_delay)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    return printed


def _check_killed_file(path, printed: int) -> int:
    run = store.open_run(path)
    assert run.status == "running"  # as last written: the writer never got to close
    recs = run.recordings()
    values = np.concatenate([rec.force[:, 0] for rec in recs])
    n_blocks = values.size // BLOCK
    assert n_blocks >= printed + 1  # every block whose append returned is there
    np.testing.assert_array_equal(values, np.repeat(np.arange(n_blocks), BLOCK))
    np.testing.assert_array_equal(np.concatenate([rec.response[:, 1] for rec in recs]),
                                  -values)
    assert not run.warnings
    return n_blocks


@pytest.mark.parametrize("n_lines,delay", [(1, 0.0), (37, 0.0), (200, 0.0), (250, 0.003)])
def test_sigkill_keeps_every_completed_block_and_resumes(tmp_path, n_lines, delay):
    path = tmp_path / "k.h5"
    printed = _kill_writer(path, n_lines, delay)
    n_blocks = _check_killed_file(path, printed)
    # resume: the crashed file is rebuilt, then appended to; nothing is lost
    last = store.open_run(path).levels[-1]
    with store.RunWriter(path, fs=1000.0, excitation="random", force_dofs=[0], n_dof=2,
                         mode="resume") as run:
        level = run.level(last.index, last.nominal)
        assert level.next_seq == last.n_segments
        level.append_block(np.full((BLOCK, 1), float(n_blocks)),
                           np.full((BLOCK, 2), -float(n_blocks)))
    run = store.open_run(path)
    assert run.status == "complete"
    assert any(e["kind"] == "resume" and e["rebuilt_after_crash"] for e in run.log)
    values = np.concatenate([rec.force[:, 0] for rec in run.recordings()])
    np.testing.assert_array_equal(values, np.repeat(np.arange(n_blocks + 1), BLOCK))


def test_sigkill_at_random_moments(tmp_path):
    rng = random.Random(7)
    for i in range(4):
        path = tmp_path / f"k{i}.h5"
        printed = _kill_writer(path, 1, rng.uniform(0.0, 0.3))
        _check_killed_file(path, printed)


def test_corrupted_block_is_skipped_with_warning(tmp_path):
    path = tmp_path / "r.h5"
    _random_run(path, np.random.default_rng(3))
    import h5py  # the test tampers with the file directly
    with h5py.File(path, "r+") as f:
        f["data/force"][5, 0] += 1.0  # inside block 0 of level 0
    run = store.open_run(path)
    rec = run.recording(0)
    assert rec.force.shape[0] == 2 * 700
    assert "checksum" in run.warnings[0]


def test_live_read_while_writing_same_process(tmp_path):
    path = tmp_path / "live.h5"
    with store.RunWriter(path, fs=100.0, excitation="random", force_dofs=[0], n_dof=1) as run:
        level = run.level(0, 1.0)
        for i in range(3):
            level.append_block(np.full(10, float(i)), np.zeros(10))
            live = store.open_run(path)
            assert live.status == "running" and live.levels[0].n_segments == i + 1
            assert live.recording(0).force[-1, 0] == i


def test_keyboard_interrupt_marks_run_interrupted(tmp_path):
    path = tmp_path / "i.h5"
    with pytest.raises(KeyboardInterrupt):
        with store.RunWriter(path, fs=100.0, excitation="random", force_dofs=[0],
                             n_dof=1) as run:
            run.level(0, 1.0).append_block(np.ones(10), np.ones(10))
            raise KeyboardInterrupt
    run = store.open_run(path)
    assert run.status == "interrupted" and run.levels[0].n_segments == 1
    assert [e["status"] for e in run.log if e["kind"] == "status"] == ["running", "interrupted"]
