"""`benchmarks/_compare.py`: a case timed on a base commit's worktree and on this tree."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))

from _compare import compare  # noqa: E402


@pytest.mark.skipif(shutil.which("git") is None or not (REPO / ".git").exists(),
                    reason="needs the git checkout")
def test_compare_times_both_trees_and_removes_the_worktree(capsys):
    before = subprocess.run(["git", "-C", str(REPO), "worktree", "list"], capture_output=True,
                            text=True, check=True).stdout
    # each subprocess checks that it imported `analysis` from the tree it was given
    [(base, here)] = compare(["bench_hbm:receptance"], base="HEAD", rounds=1, repeats=1,
                             root=REPO).values()
    assert base.wall > 0 and here.wall > 0 and 0 < base.cpu and 0 < here.cpu
    out = capsys.readouterr().out
    assert "bench_hbm:receptance: HEAD" in out and "ratio this / base" in out
    after = subprocess.run(["git", "-C", str(REPO), "worktree", "list"], capture_output=True,
                           text=True, check=True).stdout
    assert after == before
