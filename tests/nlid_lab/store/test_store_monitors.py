"""Monitor channels in the run store: /data/monitor beside force and response, in the block
checksum, kept by repair, fixed for a run (resume checks them)."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from nlid_lab import store

ROOT = Path(__file__).resolve().parents[3]
BLOCK, BLOCKS = 256, 4

WRITER = textwrap.dedent(f"""
    import sys, time
    import numpy as np
    from nlid_lab import store
    run = store.RunWriter(sys.argv[1], fs=100.0, excitation="random", force_dofs=[0], n_dof=2,
                          monitors={{"Voltage": "V", "Current": "A"}})
    lv = run.level(0, 1.0)
    for i in range({BLOCKS}):
        lv.append_block(np.full(({BLOCK}, 1), i), np.full(({BLOCK}, 2), -i),
                        monitor=np.column_stack([np.full({BLOCK}, 10.0 * i),
                                                 np.arange({BLOCK}) + i]))
    print("ready", flush=True)
    time.sleep(600)
""")


def _write(path: Path, rng) -> np.ndarray:
    mon = rng.normal(size=(BLOCKS * BLOCK, 1))
    with store.RunWriter(path, fs=100.0, excitation="random", force_dofs=[0], n_dof=1,
                         monitors={"Voltage": "V"}) as run:
        lv = run.level(0, 1.0)
        for b in range(BLOCKS):
            sl = slice(b * BLOCK, (b + 1) * BLOCK)
            lv.append_block(rng.normal(size=(BLOCK, 1)), rng.normal(size=(BLOCK, 1)),
                            monitor=mon[sl])
        lv.complete()
    return mon[:, 0]


def test_a_corrupted_monitor_sample_fails_its_block_checksum(tmp_path):
    path = tmp_path / "r.h5"
    volt = _write(path, np.random.default_rng(0))
    run = store.open_run(path)
    np.testing.assert_array_equal(run.recording(0).monitors["Voltage"], volt)
    assert run.monitor_units == {"Voltage": "V"}
    with h5py.File(path, "r+") as f:
        f["data/monitor"][BLOCK + 3, 0] += 1.0               # inside block 1
    run = store.open_run(path)
    rec = run.recording(0)
    assert rec.force.shape[0] == (BLOCKS - 1) * BLOCK and "checksum" in run.warnings[0]
    np.testing.assert_array_equal(rec.monitors["Voltage"],
                                  np.r_[volt[:BLOCK], volt[2 * BLOCK:]])


def test_blocks_must_carry_the_runs_monitors_and_resume_checks_them(tmp_path):
    path = tmp_path / "r.h5"
    _write(path, np.random.default_rng(1))
    with pytest.raises(store.StoreError, match="monitor channels differ"):
        store.RunWriter(path, fs=100.0, excitation="random", force_dofs=[0], n_dof=1,
                        mode="resume")
    with store.RunWriter(path, fs=100.0, excitation="random", force_dofs=[0], n_dof=1,
                         monitors={"Voltage": "V"}, mode="resume") as run:
        with pytest.raises(store.StoreError, match="1 monitor channel"):
            run.level(0, 1.0).append_block(np.zeros((8, 1)), np.zeros((8, 1)))


def test_repair_keeps_the_monitors_of_a_killed_writer(tmp_path):
    path = tmp_path / "killed.h5"
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], cwd=ROOT,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    assert store.repair_run(path)
    rec = store.open_run(path).recording(0)
    blocks = np.arange(BLOCKS).repeat(BLOCK)
    np.testing.assert_array_equal(rec.monitors["Voltage"], 10.0 * blocks)
    np.testing.assert_array_equal(rec.monitors["Current"], np.tile(np.arange(BLOCK), BLOCKS)
                                  + blocks)
    assert list(rec.monitors) == ["Voltage", "Current"]
    assert rec.monitor_units == {"Voltage": "V", "Current": "A"}


def test_only_runs_with_monitors_are_schema_2(tmp_path):
    _write(tmp_path / "m.h5", np.random.default_rng(2))
    assert store.open_run(tmp_path / "m.h5").meta["schema_version"] == 2
    with store.RunWriter(tmp_path / "p.h5", fs=100.0, excitation="random", force_dofs=[0],
                         n_dof=1) as run:
        run.level(0, 1.0).append_block(np.ones((8, 1)), np.ones((8, 1)))
    assert store.open_run(tmp_path / "p.h5").meta["schema_version"] == store.SCHEMA_VERSION == 1
