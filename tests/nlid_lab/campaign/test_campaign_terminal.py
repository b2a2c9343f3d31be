"""What ``campaign run`` tells people: one summary line per level built from the stored run,
per-level summaries in ``--json``, nothing with ``--quiet``, and after Ctrl-C what was kept
and the ``--resume`` command that continues it."""

import json
import re
import shlex
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from nlid_lab.cli import main
from nlid_lab.store import open_run

from test_campaign_kill import ROOT, _campaign

LINE = re.compile(r"^level (\d+)/(\d+) \(([\d.]+) N (rms|amplitude)\): (\d+)/(\d+) "
                  r"(blocks|steps), force (?:rms|mean amplitude) (\S+) N "
                  r"\(target ([\d.]+) N, (?:worst step )?([+-][\d.]+%)\), drive (\S+) V")


def _small_random(tmp_path, averages=3):
    return _campaign(tmp_path, "campaign-sim-random.toml", {
        "averages = 8": f"averages = {averages}", "block_size = 4096": "block_size = 2048"})


def _human(err: str) -> list[str]:
    """stderr without the one-off notice of a cold numba cache."""
    return [line for line in err.splitlines() if not line.startswith("nlid-lab: compiling")]


def test_level_lines_and_json_come_from_the_stored_run(tmp_path, capsys):
    campaign, out = _small_random(tmp_path), tmp_path / "run.h5"
    assert main(["campaign", "run", str(campaign), "--out", str(out), "--json", "-"]) == 0
    captured = capsys.readouterr()
    levels = json.loads(captured.out)["levels"]          # stdout stays pure JSON
    lines = [m for m in map(LINE.match, _human(captured.err)) if m]
    run = open_run(out)
    assert len(lines) == len(levels) == len(run.levels) == 2
    for m, summary, lv in zip(lines, levels, run.levels):
        stored = float(np.std(run.recording(lv.index).force))
        assert (int(m[1]), int(m[2]), m[4], m[7]) == (lv.index + 1, 2, "rms", "blocks")
        assert (int(m[5]), int(m[6])) == (lv.n_segments, 3) and float(m[3]) == lv.nominal
        assert m[8] == f"{stored:.4g}" and m[10] == f"{stored / lv.nominal - 1:+.2%}"
        assert summary["level"] == lv.index and summary["done"] == lv.n_segments == 3
        assert summary["target"] == lv.nominal and summary["planned"] == 3
        assert summary["force"] == pytest.approx(stored, rel=1e-12)     # rounding only
        assert summary["measure"] == "rms"
        assert summary["control_error"] == pytest.approx(stored / lv.nominal - 1, abs=1e-12)
        # the drive the level control settled on: target / 20 N/V (the simulated shaker),
        # not the first guess (gain_guess 10 N/V: twice that)
        assert abs(summary["drive"] * 20.0 / lv.nominal - 1) < 0.1
        assert m[11] == f"{summary['drive']:.4g}"


def test_stepped_lines_and_quiet(tmp_path, capsys):
    campaign = _campaign(tmp_path, "campaign-sim-stepped.toml", {"step = 2.0": "step = 20.0"})
    out = tmp_path / "run.h5"
    assert main(["campaign", "run", str(campaign), "--out", str(out)]) == 0
    lines = [m for m in map(LINE.match, _human(capsys.readouterr().err)) if m]
    run = open_run(out)
    assert len(lines) == len(run.levels) == 2
    for m, lv in zip(lines, run.levels):
        amps = run.recording(lv.index).meta["step_amplitude"]
        errors = amps / lv.nominal - 1
        assert (m[4], m[7], int(m[5]), int(m[6])) == ("amplitude", "steps", len(amps),
                                                      lv.n_segments)
        assert m[8] == f"{np.mean(amps):.4g}"
        assert m[10] == f"{errors[np.argmax(np.abs(errors))]:+.2%}"
    assert main(["campaign", "run", str(campaign), "--out", str(tmp_path / "q.h5"),
                 "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and _human(captured.err) == []
    assert open_run(tmp_path / "q.h5").status == "complete"


def test_ctrl_c_says_what_was_kept_and_the_resume_command_resumes(tmp_path, capsys):
    """SIGINT once the first of three levels is stored: the message counts the blocks on file
    per level, and the printed command (run as it is) completes the run."""
    campaign = _campaign(tmp_path, "campaign-sim-random.toml", {
        "levels = [5.0, 20.0]": "levels = [5.0, 10.0, 20.0]", "averages = 8": "averages = 6"})
    out = tmp_path / "run.h5"
    proc = subprocess.Popen([sys.executable, "-m", "nlid_lab.cli", "campaign", "run",
                             str(campaign), "--out", str(out)], cwd=ROOT, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline, seen = time.monotonic() + 120, []
        while time.monotonic() < deadline:
            seen.append(proc.stderr.readline())
            if seen[-1].startswith("level 1/3") or not seen[-1]:
                break
        assert seen[-1].startswith("level 1/3"), seen
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    kept = re.search(r"campaign interrupted: kept (\d+) blocks \((.*); (\d) of 3 level\(s\) "
                     r"complete\) in (\S+), marked interrupted", err)
    assert kept, err
    run = open_run(out)
    assert run.status == "interrupted" and kept[4] == str(out)
    assert int(kept[1]) == sum(lv.n_segments for lv in run.levels) < 18
    assert int(kept[3]) == sum(lv.complete for lv in run.levels) >= 1
    assert kept[2].startswith("level 1: 6/6 (complete), level 2: ")
    command = re.search(r"^continue it with: (.*)$", err, re.M)[1]
    argv = shlex.split(command)
    assert argv == ["nlid-lab", "campaign", "run", str(campaign), "--out", str(out),
                    "--resume"]
    capsys.readouterr()
    assert main(argv[1:]) == 0
    run = open_run(out)
    assert run.status == "complete" and [lv.n_segments for lv in run.levels] == [6, 6, 6]
    assert "level 1/3 (5 N rms): 6/6 blocks" in capsys.readouterr().err
