"""A full disk loses nothing: run files on a real small file system (a tmpfs mounted for the
test; skipped where mounting is not permitted)."""

import copy
import os
import tomllib
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from nlid_lab.campaign import parse_campaign, run_campaign
from nlid_lab.cli import main
from nlid_lab.store import DiskFullError, open_run

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"
BASE = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())


@pytest.fixture
def small_disk(tmp_path):
    """A factory mounting a tmpfs of the given size (e.g. ``"2m"``) in ``tmp_path``."""
    mounted = []

    def mount(size: str) -> Path:
        where = tmp_path / f"disk{len(mounted)}"
        where.mkdir()
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs",
                               str(where)], capture_output=True)
        if done.returncode:
            pytest.skip(f"cannot mount a small file system here: {done.stderr.decode()}")
        mounted.append(where)
        return where

    yield mount
    for where in mounted:
        subprocess.run(["umount", "-l", str(where)], check=False)


def fill(disk: Path, leave: int) -> Path:
    """Fill ``disk`` with one file, leaving ``leave`` bytes free."""
    free = os.statvfs(disk).f_bavail * os.statvfs(disk).f_frsize
    filler = disk / "filler"
    with open(filler, "ab") as fh:
        fh.write(b"\0" * max(free - leave, 0))
    return filler


def check_valid_interrupted(path: Path) -> int:
    """The run reads in plain h5py, is marked interrupted and every stored block is intact;
    returns the number of blocks."""
    h5py.File(path, "r").close()                      # closed cleanly: any HDF5 tool opens it
    run = open_run(path)
    assert run.status == "interrupted" and "disk" in run.reason
    for lv in run.levels:
        if lv.n_segments:
            run.recording(lv.index)
    assert run.warnings == []                         # no block failed its checksum
    assert not path.with_name(path.name + ".reserve").exists()
    return len(run.segments)


WRITE_UNTIL_FULL = """
import sys, numpy as np
import nlid_lab.store._writer as writer
from nlid_lab.store import DiskFullError, RunWriter
if sys.argv[2] == "no-guard":            # let the write itself fail with ENOSPC
    writer.require = lambda *args: None
try:
    with RunWriter(sys.argv[1], fs=1000.0, excitation="random", force_dofs=[0], n_dof=2) as w:
        lv = w.level(0, 1.0)
        rng = np.random.default_rng(0)
        for i in range(10_000):
            lv.append_block(rng.standard_normal((4096, 1)), rng.standard_normal((4096, 2)))
except DiskFullError as exc:
    print("stored", lv.n_segments, exc)
"""


@pytest.mark.parametrize("guard", ["guard", "no-guard"])
def test_writer_stops_cleanly_when_the_disk_fills(small_disk, guard):
    """Checked before the block (guard) or failing in HDF5's write (no guard): a
    `DiskFullError`, no segmentation fault, the file interrupted with every block valid."""
    disk = small_disk("2m")
    path = disk / "run.h5"
    done = subprocess.run([sys.executable, "-c", WRITE_UNTIL_FULL, str(path), guard],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("stored"), done.stdout + done.stderr[-2000:]
    stored = int(done.stdout.split()[1])
    assert stored >= 4                             # 2 MB hold several 96 kB blocks
    assert check_valid_interrupted(path) == stored


def _campaign(levels, averages):
    data = copy.deepcopy(BASE)
    data["random"].update(levels=levels, averages=averages, block_size=4096)
    return parse_campaign(data, EXAMPLES)


def test_campaign_refused_before_it_starts_when_the_plan_does_not_fit(small_disk, capsys,
                                                                      tmp_path):
    """The issue's case: 4 levels x 16 blocks on 2 MB free -> exit 2 naming the sizes, no
    run file."""
    disk = small_disk("2m")
    toml = tmp_path / "c.toml"
    text = (EXAMPLES / "campaign-sim-random.toml").read_text()
    text = text.replace("levels = [5.0, 20.0]", "levels = [5.0, 10.0, 15.0, 20.0]")
    text = text.replace("averages = 8", "averages = 16").replace(
        'model = "models/', f'model = "{EXAMPLES}/models/')
    toml.write_text(text)
    assert main(["campaign", "run", str(toml), "--out", str(disk / "run.h5"), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not enough free space for the plan" in err[0], err
    assert "4.19 MB of data" in err[0]              # 64 blocks x 4096 x 2 channels x 8 B
    assert list(disk.iterdir()) == []


def test_disk_filling_during_a_campaign_then_resume_completes(small_disk):
    """Another file fills the disk after the third block: the campaign stops with
    `DiskFullError`, the drive ramped to zero, the run interrupted with its blocks intact;
    with room again, ``resume`` records the rest and completes."""
    disk = small_disk("4m")
    out = disk / "run.h5"
    c = _campaign([5.0, 20.0], 8)
    stops, filler = [], []

    class FillAfterThree:
        def block(self, level, seq, force, resp):
            if level == 0 and seq == 2:
                filler.append(fill(disk, 50_000))

    def on_bench(bench):
        estop = bench.shaker.emergency_stop
        bench.shaker.emergency_stop = lambda **kw: (stops.append(1), estop(**kw))

    with pytest.raises(DiskFullError, match="not enough free space for block 3 of level 0"):
        run_campaign(c, out, observer=FillAfterThree(), on_bench=on_bench)
    assert stops                                    # drive ramped to zero
    assert check_valid_interrupted(out) == 3
    filler[0].unlink()
    result = run_campaign(c, out, resume=True)
    assert result.status == "complete" and result.segments == {0: 8, 1: 8}
    run = open_run(out)
    assert run.status == "complete"
    recs = run.recordings()
    assert run.warnings == [] and [len(r.force) for r in recs] == [8 * 4096] * 2


def test_campaign_cli_says_what_was_kept_and_how_to_resume(small_disk, tmp_path, capsys,
                                                           monkeypatch):
    """Disk full mid-campaign at the command line: exit 2, one line with what was kept and
    the ``--resume`` command."""
    disk = small_disk("4m")
    out = disk / "run.h5"
    toml = tmp_path / "c.toml"
    toml.write_text((EXAMPLES / "campaign-sim-random.toml").read_text().replace(
        'model = "models/', f'model = "{EXAMPLES}/models/'))
    import nlid_lab.store._writer as writer
    calls = []
    real = writer.require

    def require(path, nbytes, what):        # the disk is "full" from the 4th block on
        calls.append(what)
        if len(calls) > 3:
            fill(disk, 0)
        real(path, nbytes, what)
    monkeypatch.setattr(writer, "require", require)
    assert main(["campaign", "run", str(toml), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "kept 3 blocks" in err[0] and "marked interrupted" in err[0]
    assert f"--out {out} --resume" in err[0]
    assert check_valid_interrupted(out) == 3


def test_command_outputs_near_a_full_disk_are_whole_or_absent(small_disk, tmp_path, capsys):
    """`simulate` leaves no half ``.npz``, `import` no half run (and no crash), `report` no
    figures without their page: each exits 2 with one line, the disk holding only what was
    there before."""
    rng = np.random.default_rng(0)
    drive = tmp_path / "drive.npz"
    np.savez(drive, fs=1024.0, force=5.0 * rng.normal(size=(65536, 1)), force_dofs=[0],
             force_rms=5.0)
    model = EXAMPLES / "models" / "sdof-cubic-quaddamp.toml"
    small = tmp_path / "small.h5"
    assert main(["simulate", str(model), "--drive", str(drive), "--out", str(small)]) == 0
    assert main(["simulate", str(model), "--drive", str(drive), "--out",
                 str(tmp_path / "rec.npz")]) == 0
    capsys.readouterr()
    disk = small_disk("2m")
    filler = fill(disk, 300_000)
    for argv in (["simulate", str(model), "--drive", str(drive), "--out", str(disk / "o.npz")],
                 ["import", str(tmp_path / "rec.npz"), "--out", str(disk / "run.h5")],
                 ["report", str(small), "--out", str(disk / "rep")]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and ("no room on the disk" in err[0]
                                  or "not enough free space" in err[0]), err
        assert sorted(disk.iterdir()) == [filler], argv


def test_stepped_campaign_on_a_filling_disk_resumes_at_the_missing_steps(small_disk):
    """The same for a stepped-sine campaign: stopped after its second step, resumed with
    room: every step once, in frequency order."""
    disk = small_disk("4m")
    out = disk / "run.h5"
    data = copy.deepcopy(BASE)
    del data["random"]
    data["kind"] = "stepped-sine"
    data["stepped"] = {"levels": [8.0], "start": 44.0, "stop": 56.0, "step": 4.0,
                       "block_size": 512, "harmonics": 3}
    c = parse_campaign(data, EXAMPLES)
    filler = []

    class FillAfterTwo:
        def step(self, level, k, *rest):
            if k == 1:
                filler.append(fill(disk, 50_000))

    with pytest.raises(DiskFullError, match="block 2 of level 0"):
        run_campaign(c, out, observer=FillAfterTwo())
    assert check_valid_interrupted(out) == 2
    filler[0].unlink()
    assert run_campaign(c, out, resume=True).status == "complete"
    rec = open_run(out).recording(0)
    np.testing.assert_array_equal(rec.freqs, [44.0, 48.0, 52.0, 56.0])
