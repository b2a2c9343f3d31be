"""Issue 26: the readers' checksum pass reads each block once. `Run.check` verifies the
blocks and keeps the intact ones for the `recording` that follows (another opening of the same
file included); a file changed since is read afresh, and the blocks left out are said by
every opening (docs/reliability-store.md)."""

from __future__ import annotations

import os

import h5py
import numpy as np
import pytest

import nlid_lab.store._reader as reader
from nlid_lab.store import LeftOutReason, RunWriter, open_run, release_checked


@pytest.fixture
def run_path(tmp_path):
    rng = np.random.default_rng(3)
    path = tmp_path / "run.h5"
    with RunWriter(path, fs=1024.0, excitation="random", force_dofs=[0], n_dof=1) as w:
        for index in range(2):
            lv = w.level(index, 1.0 + index)
            for _ in range(3):
                lv.append_block(rng.standard_normal((256, 1)), rng.standard_normal((256, 1)))
            lv.complete()
    release_checked()
    yield path
    release_checked()


def _reads(monkeypatch) -> list:
    """Count the file openings of the reader from now on."""
    opened = []
    real = reader._open

    def counting(path, mode):
        opened.append(path)
        return real(path, mode)
    monkeypatch.setattr(reader, "_open", counting)
    return opened


def test_the_read_after_a_check_uses_the_checked_samples(run_path, monkeypatch):
    reference = [r.force.copy() for r in open_run(run_path).recordings()]
    release_checked()
    opened = _reads(monkeypatch)
    assert not open_run(run_path).check().left_out
    checked = len(opened)
    assert checked == 1 + 2          # the index, then each level once
    recs = open_run(run_path).recordings()
    assert len(opened) == checked + 1           # the second opening reads the index only
    assert all(np.array_equal(a, r.force) for a, r in zip(reference, recs))
    open_run(run_path).recordings()             # handed out once: read again
    assert len(opened) == checked + 1 + 1 + 2


def test_a_file_changed_after_its_check_is_read_again(run_path, monkeypatch):
    open_run(run_path).check()
    with h5py.File(run_path, "r+") as f:          # one bit of level 1's first block
        i = int(f["segments"][:][3]["start"])
        value = f["data/force"][i, 0]
        f["data/force"][i, 0] = -value
    st = os.stat(run_path)                         # a later mtime, whatever the clock's tick
    os.utime(run_path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    opened = _reads(monkeypatch)
    run = open_run(run_path)
    recs = run.recordings()
    assert len(opened) == 1 + 2
    assert [(b.level, b.seq, b.reason) for b in run.left_out] == \
        [(1, 0, LeftOutReason.CHECKSUM)]
    assert len(recs[1].force) == 2 * 256


def test_blocks_left_out_are_said_by_the_opening_that_reads(run_path):
    with h5py.File(run_path, "r+") as f:
        i = int(f["segments"][:][1]["start"])
        f["data/response"][i + 5, 0] += 1.0
    check = open_run(run_path).check()
    assert [(b.level, b.seq) for b in check.left_out] == [(0, 1)]
    run = open_run(run_path)
    recs = run.recordings()
    assert [(b.level, b.seq) for b in run.left_out] == [(0, 1)]
    assert any("block 1 failed its checksum" in w for w in run.warnings)
    assert len(recs[0].force) == 2 * 256
