"""Damaged data is never used in silence, and damaged run files end as exit 2 with one line
naming the problem and the fix: real campaign runs in tmp dirs, damaged the way disks and
tools damage them."""

import copy
import json
import shutil
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from nlid_lab.campaign import parse_campaign, run_campaign
from nlid_lab.cli import main
from nlid_lab.store import LeftOutReason, open_run

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"
RANDOM = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())
MODEL = EXAMPLES / "candidates" / "sdof-candidate.toml"


def _random_campaign(levels=(5.0, 20.0), averages=4):
    data = copy.deepcopy(RANDOM)
    data["random"].update(levels=list(levels), averages=averages)
    return parse_campaign(data, EXAMPLES)


def _stepped_campaign():
    data = copy.deepcopy(RANDOM)
    del data["random"]
    data["kind"] = "stepped-sine"
    data["stepped"] = {"levels": [8.0], "start": 44.0, "stop": 56.0, "step": 4.0,
                       "block_size": 512, "harmonics": 3}
    return parse_campaign(data, EXAMPLES)


@pytest.fixture(scope="module")
def random_run(tmp_path_factory):
    """A complete random run, 2 levels x 4 blocks (copied by each test that damages it)."""
    out = tmp_path_factory.mktemp("runs") / "random.h5"
    run_campaign(_random_campaign(), out)
    return out


def _copy(src: Path, tmp_path: Path, name="run.h5") -> Path:
    dst = tmp_path / name
    shutil.copy(src, dst)
    return dst


def _corrupt_block(path: Path, level: int, seq: int) -> None:
    """Flip one bit in a stored block's response samples (its checksum then fails)."""
    with h5py.File(path, "r+") as f:
        seg = f["segments"][:]
        row = seg[(seg["level"] == level) & (seg["seq"] == seq)][0]
        i = int(row["start"]) + int(row["length"]) // 2
        value = f["data/response"][i, 0]
        f["data/response"][i, 0] = np.frombuffer(
            (np.frombuffer(value.tobytes(), np.uint64) ^ np.uint64(1 << 40)).tobytes(),
            np.float64)[0]


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# --- damaged blocks: readers say what they leave out ----------------------------------------

def test_detect_and_analyze_name_the_corrupt_block_in_summary_and_json(random_run, tmp_path,
                                                                        capsys):
    path = _copy(random_run, tmp_path)
    _corrupt_block(path, 1, 2)
    for argv in (["detect", str(path)],
                 ["analyze", "reverse-path", str(path), "--model", str(MODEL)]):
        out = tmp_path / f"{argv[0]}.json"
        assert main(argv + ["--json", str(out), "-q"]) == 0
        err = capsys.readouterr().err
        assert "1 block(s) left out: level 1 block 2 (failed its checksum)" in err, err
        check = json.loads(out.read_text())["data_checks"][0]
        assert check["left_out"] == [{"level": 1, "seq": 2, "reason": "failed its checksum"}]
        assert check["blocks_stored"] == 7 and check["blocks_planned"] == 8
    run = open_run(path)
    assert len(run.recording(1).force) == 3 * 4096        # the corrupt block is not used
    assert run.left_out[0].reason is LeftOutReason.CHECKSUM


def test_export_uff_and_report_say_it_too(random_run, tmp_path, capsys):
    path = _copy(random_run, tmp_path)
    _corrupt_block(path, 0, 0)
    assert main(["export-uff", str(path), "--out", str(tmp_path / "r.uff"),
                 "--json", str(tmp_path / "u.json")]) == 0
    assert "level 0 block 0 (failed its checksum)" in capsys.readouterr().err
    checks = json.loads((tmp_path / "u.json").read_text())["data_checks"]
    assert checks[0]["left_out"][0]["seq"] == 0


def test_a_running_run_is_named_incomplete(random_run, tmp_path, capsys):
    """A run still being written (status running): "run is incomplete: 3 of 8 blocks"."""
    path = _copy(random_run, tmp_path)
    with h5py.File(path, "r+") as f:
        f["state/status"][()] = b"running"
        seg = f["segments"][:]
        keep = seg[(seg["level"] == 0) & (seg["seq"] < 3)]
        f["segments"].resize((len(keep),))
        f["segments"][:] = keep
    assert main(["analyze", "reverse-path", str(path), "--model", str(MODEL), "-q",
                 "--json", str(tmp_path / "a.json")]) == 0
    assert "run is incomplete: 3 of 8 blocks" in capsys.readouterr().err
    check = json.loads((tmp_path / "a.json").read_text())["data_checks"][0]
    assert check["incomplete"].startswith("incomplete: 3 of 8 blocks")


def test_a_block_naming_a_missing_level_is_reported_not_dropped(random_run, tmp_path,
                                                                   capsys):
    path = _copy(random_run, tmp_path)
    with h5py.File(path, "r+") as f:                 # level 1's row lost from /levels
        levels = f["levels"][:]
        f["levels"].resize((1,))
        f["levels"][:] = levels[levels["index"] == 0]
    run = open_run(path)
    assert [lv.index for lv in run.levels] == [0, 1] and run.levels[1].n_segments == 4
    assert np.isnan(run.levels[1].nominal) and "level 1" in run.notes[0]
    assert main(["detect", str(path), "-q"]) == 0
    assert "4 block(s) name level 1, which the run's /levels table does not list" in \
        capsys.readouterr().err


# --- resume records damaged blocks again ----------------------------------------------------

def test_resume_of_a_complete_run_records_its_corrupt_block_again(random_run, tmp_path):
    path = _copy(random_run, tmp_path)
    _corrupt_block(path, 0, 1)
    result = run_campaign(_random_campaign(), path, resume=True)
    assert result.status == "complete" and result.segments == {0: 4, 1: 4}
    assert "1 damaged block(s) dropped and recorded again" in result.warnings[0]
    run = open_run(path)
    assert [len(r.force) for r in run.recordings()] == [4 * 4096] * 2
    assert run.left_out == [] and run.warnings == []
    assert [e for e in run.log if e["kind"] == "resume"][-1]["dropped"] == [
        {"level": 0, "seq": 1, "reason": "failed its checksum"}]


def test_resume_of_a_stepped_run_records_the_corrupt_step_at_its_frequency(tmp_path):
    path = tmp_path / "stepped.h5"
    c = _stepped_campaign()
    run_campaign(c, path)
    freqs = open_run(path).recording(0).freqs
    _corrupt_block(path, 0, 1)
    assert len(open_run(path).recording(0).freqs) == len(freqs) - 1
    run_campaign(c, path, resume=True)
    run = open_run(path)
    rec = run.recording(0)
    assert run.left_out == [] and np.array_equal(rec.freqs, freqs)   # in frequency order


# --- damaged run files: exit 2, one line, the fix ---------------------------------------------

def test_run_missing_segments_is_one_line_exit_2(random_run, tmp_path, capsys):
    path = _copy(random_run, tmp_path)
    with h5py.File(path, "r+") as f:
        del f["segments"]
    for argv in (["detect", str(path)], ["export-uff", str(path), "--out",
                                         str(tmp_path / "x.uff")], ["repair", str(path)]):
        assert main(argv) == 2
        line = _one_error_line(capsys)
        assert "/segments is missing" in line and "restore the file from a copy" in line


def test_log_text_overwritten_with_ff_is_named_and_repaired(random_run, tmp_path, capsys):
    path = _copy(random_run, tmp_path)
    with h5py.File(path, "r+") as f:
        row = f["log"][1]
        f["text"][row["start"]:row["start"] + row["length"]] = 0xFF
    assert main(["detect", str(path)]) == 2
    line = _one_error_line(capsys)
    assert "log entry 1 is damaged (UnicodeDecodeError" in line
    assert f"nlid-lab repair {path}" in line
    assert main(["repair", str(path)]) == 0
    assert "1 damaged log entry dropped" in capsys.readouterr().out
    run = open_run(path)
    assert len(run.segments) == 8 and run.status == "complete"
    assert main(["detect", str(path), "-q"]) == 0


def test_64_flipped_bits_in_the_metadata_are_named_and_repaired(random_run, tmp_path,
                                                                   capsys):
    """Bit rot in the run's settings text (the campaign it ran, JSON in the file)."""
    path = _copy(random_run, tmp_path)
    raw = bytearray(path.read_bytes())
    with h5py.File(path, "r") as f:
        settings = f.attrs["settings"].encode()
    at = raw.find(settings)
    assert at > 0
    rng = np.random.default_rng(64)
    for bit in rng.choice(len(settings) * 8, 64, replace=False):
        raw[at + bit // 8] ^= 1 << (bit % 8)
    path.write_bytes(bytes(raw))
    assert main(["detect", str(path)]) == 2
    line = _one_error_line(capsys)
    assert "attribute 'settings'" in line and "damaged" in line
    assert f"nlid-lab repair {path}" in line
    assert main(["repair", str(path)]) == 0
    assert "damaged attribute(s) settings reset" in capsys.readouterr().out
    run = open_run(path)
    assert run.meta["settings"] == {} and len(run.segments) == 8
    assert main(["detect", str(path), "-q"]) == 0
