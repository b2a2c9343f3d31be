"""A run whose writer was SIGKILLed: readable by nlid-lab, said to be incomplete, and made
readable by ordinary HDF5 tools by ``nlid-lab repair`` (never while a live writer has it)."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from nlid_lab.cli import main
from nlid_lab.store import open_run

ROOT = Path(__file__).resolve().parents[3]
BLOCKS = 5

WRITER = """
import os, signal, sys, time
import numpy as np
from nlid_lab.store import RunWriter, _writer as writer
path, mode = sys.argv[1], sys.argv[2]
if mode == "kill-at-open":   # die the instant the new file is opened for writing
    real = writer._open_swmr_write
    def open_then_die(p):
        f = real(p)
        os.kill(os.getpid(), signal.SIGKILL)
    writer._open_swmr_write = open_then_die
rng = np.random.default_rng(0)
run = RunWriter(path, fs=1024.0, excitation="random", force_dofs=[0], n_dof=1)
lv = run.level(0, 5.0)
for i in range({blocks}):
    lv.append_block(rng.normal(size=(512, 1)), rng.normal(size=(512, 1)))
if mode == "corrupt-block-2":  # a torn write: block 2's samples change after indexing
    run._file["data/response"][2 * 512, 0] += 1.0
    run._file.flush()
print("ready", flush=True)
time.sleep(600)
""".format(blocks=BLOCKS)


def _writer(path: Path, mode: str = "hang") -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(WRITER), str(path), mode],
                            cwd=ROOT, stdout=subprocess.PIPE, text=True)
    if mode != "kill-at-open":
        assert proc.stdout.readline().strip() == "ready"
    return proc


def _killed_run(path: Path) -> None:
    proc = _writer(path)
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)


def test_killed_run_is_reported_incomplete_and_repaired(tmp_path, capsys):
    path = tmp_path / "run.h5"
    _killed_run(path)
    with pytest.raises(OSError, match="open for write"):
        h5py.File(path, "r")                    # what HDFView / MATLAB / h5py users meet
    run = open_run(path)
    before = run.recording(0)
    assert run.left_open and run.status == "running" and len(run.segments) == BLOCKS
    assert "incomplete" in run.incomplete and "killed" in run.incomplete

    capsys.readouterr()
    assert main(["report", str(path), "--out", str(tmp_path / "rep")]) == 0
    err = capsys.readouterr().err
    assert "run is incomplete: 5 blocks" in err and f"nlid-lab repair {path}" in err

    assert main(["repair", str(path)]) == 0
    assert f"{BLOCKS} of {BLOCKS} indexed blocks intact" in capsys.readouterr().out
    with h5py.File(path, "r") as f:             # plain open works now
        assert f["segments"].shape == (BLOCKS,)
    after = open_run(path)
    assert not after.left_open and "incomplete" in after.incomplete
    np.testing.assert_array_equal(after.recording(0).force, before.force)
    np.testing.assert_array_equal(after.recording(0).response, before.response)
    assert main(["repair", str(path)]) == 0
    assert "nothing to repair" in capsys.readouterr().out


def test_repair_option_of_view_repairs_first(tmp_path, capsys):
    path = tmp_path / "run.h5"
    _killed_run(path)
    capsys.readouterr()
    assert main(["view", str(path), "--snapshot", str(tmp_path / "v.png"), "--repair"]) == 0
    assert "repaired" in capsys.readouterr().err
    h5py.File(path, "r").close()


def test_repair_refuses_a_file_a_live_writer_holds(tmp_path, capsys):
    path = tmp_path / "run.h5"
    proc = _writer(path)
    try:
        data = path.read_bytes()
        capsys.readouterr()
        assert main(["repair", str(path)]) == 2
        err = capsys.readouterr().err
        assert "open in another process" in err and "\n" not in err.strip()
        assert path.read_bytes() == data
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    assert main(["repair", str(path)]) == 0       # dead now: repaired


def test_kill_right_after_the_file_is_opened_for_writing_leaves_a_readable_run(tmp_path):
    """The moment between opening the new file and switching SWMR on no longer exists."""
    path = tmp_path / "run.h5"
    proc = _writer(path, "kill-at-open")
    assert proc.wait(60) == -signal.SIGKILL
    run = open_run(path)
    assert run.levels == [] and len(run.segments) == 0 and run.left_open
    assert main(["repair", str(path)]) == 0
    h5py.File(path, "r").close()


def test_repair_drops_a_block_whose_checksum_fails(tmp_path, capsys):
    path = tmp_path / "run.h5"
    proc = _writer(path, "corrupt-block-2")
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    capsys.readouterr()
    assert main(["repair", str(path)]) == 0
    assert f"{BLOCKS - 1} of {BLOCKS} indexed blocks intact" in capsys.readouterr().out
    run = open_run(path)
    assert sorted(run.segments["seq"]) == [0, 1, 3, 4]
    assert run.recording(0).force.shape == ((BLOCKS - 1) * 512, 1) and not run.warnings
