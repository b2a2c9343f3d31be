"""SIGKILL a running campaign at random moments: the file stays readable and --resume finishes
it with the same totals as an uninterrupted run."""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nlid_lab.cli import main
from nlid_lab.store import open_run

ROOT = Path(__file__).resolve().parents[1]
LEVELS, AVERAGES = 3, 6


def _campaign(tmp_path: Path) -> Path:
    text = (ROOT / "examples" / "campaign-sim-random.toml").read_text()
    text = text.replace('model = "models/', f'model = "{ROOT}/examples/models/')
    text = text.replace("levels = [5.0, 20.0]", "levels = [5.0, 10.0, 20.0]")
    text = text.replace("averages = 8", f"averages = {AVERAGES}")
    path = tmp_path / "campaign.toml"
    path.write_text(text)
    return path


def _kill_and_resume(tmp_path: Path, rng: random.Random) -> tuple[int, int]:
    campaign, out = _campaign(tmp_path), tmp_path / "run.h5"
    proc = subprocess.Popen([sys.executable, "-m", "nlid_lab.cli", "campaign", "run",
                             str(campaign), "--out", str(out)], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not out.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(rng.uniform(0.0, 2.0))
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait(30)
    run = open_run(out)                          # readable after SIGKILL
    before = sum(lv.n_segments for lv in run.levels)
    assert all(lv.n_segments <= AVERAGES for lv in run.levels)
    for lv in run.levels:
        if lv.n_segments:
            assert run.recording(lv.index).force.shape[0] == lv.n_samples  # blocks intact
    assert main(["campaign", "run", str(campaign), "--out", str(out), "--resume"]) == 0
    run = open_run(out)
    assert run.status == "complete"
    assert [lv.n_segments for lv in run.levels] == [AVERAGES] * LEVELS
    assert all(lv.complete for lv in run.levels)
    return before, sum(lv.n_segments for lv in run.levels)


def test_sigkill_then_resume(tmp_path):
    rng = random.Random(int(os.environ.get("NLID_KILL_SEED", "5")))
    for trial in range(3):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        _kill_and_resume(d, rng)


@pytest.mark.slow
def test_sigkill_many_trials(tmp_path):
    rng = random.Random(11)
    for trial in range(10):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        _kill_and_resume(d, rng)
