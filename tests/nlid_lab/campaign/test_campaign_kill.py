"""SIGKILL a running campaign at random moments: the file stays readable with every completed
block or step intact, ``--resume`` finishes it with the same totals as an uninterrupted run,
and the shaker controller's link watchdog zeroes the drive of a killed host."""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from drivers.emulators._serial_emu import ESTOP_RAMP, SerialDaqEmulator, SerialShakerEmulator
from drivers.rig import SimRig
from drivers.serial_shaker import FEEDS_PER_PERIOD
from nlid_lab.campaign import load_campaign, run_campaign
from nlid_lab.cli import main
from nlid_lab.store import open_run

ROOT = Path(__file__).resolve().parents[3]
MODELS = ROOT / "examples" / "models"
LEVELS, AVERAGES = 3, 6
STEPPED_LEVELS, STEPS = 2, 11
#: kills per test in `make test` (each a campaign process and a resume): one at a random
#: moment; the stepped test kills twice (before the first step and mid-run);
#: test_sigkill_many_trials (slow) kills the random campaign ten times
TRIALS = 1


def _campaign(tmp_path: Path, example: str, edits: dict[str, str]) -> Path:
    text = (ROOT / "examples" / example).read_text()
    text = text.replace('model = "models/', f'model = "{MODELS}/')
    for old, new in edits.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "campaign.toml"
    path.write_text(text)
    return path


def random_campaign(tmp_path: Path) -> Path:
    return _campaign(tmp_path, "campaign-sim-random.toml", {
        "levels = [5.0, 20.0]": "levels = [5.0, 10.0, 20.0]",
        "averages = 8": f"averages = {AVERAGES}"})


def stepped_campaign(tmp_path: Path) -> Path:
    return _campaign(tmp_path, "campaign-sim-stepped.toml", {"step = 2.0": "step = 4.0"})


def _spawn(campaign: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "nlid_lab.cli", "campaign", "run",
                             str(campaign), "--out", str(out)], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _stored(out: Path) -> int:
    """Blocks or steps a running campaign has stored so far (0 while unreadable)."""
    try:
        return sum(lv.n_segments for lv in open_run(out).levels)
    except Exception:  # noqa: BLE001 - the writer may be between its first flushes
        return 0


def _kill_and_resume(campaign: Path, out: Path, per_level: int, n_levels: int,
                     delay: float = 0.0, at: int = 0) -> tuple[int, list]:
    """Kill a campaign once its run file holds ``at`` blocks or steps (seen by reading the
    file as the writer commits them: an event, not a time, so a loaded machine moves the
    kill but never past it), ``delay`` s after that; check it; resume it.
    Returns the segment count found after the kill and the recordings before resuming."""
    proc = _spawn(campaign, out)
    try:
        deadline = time.monotonic() + 120
        while not out.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        while at and _stored(out) < at and proc.poll() is None \
                and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(delay)
        assert not at or proc.poll() is None, "the campaign ended before the kill"
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait(30)
    run = open_run(out)                          # readable after SIGKILL
    before = sum(lv.n_segments for lv in run.levels)
    assert before >= at                          # what was seen committed survives the kill
    assert all(lv.n_segments <= per_level for lv in run.levels)
    kept = []
    for lv in run.levels:
        if lv.n_segments:
            rec = run.recording(lv.index)         # every block/step passes its checksum
            assert not run.warnings
            n = rec.force.shape[0] * (rec.force.shape[1] if rec.force.ndim == 3 else 1)
            assert n == lv.n_samples             # blocks intact
            kept.append((lv.index, rec))
    assert main(["campaign", "run", str(campaign), "--out", str(out), "--resume"]) == 0
    run = open_run(out)
    assert run.status == "complete"
    assert [lv.n_segments for lv in run.levels] == [per_level] * n_levels
    assert all(lv.complete for lv in run.levels)
    return before, kept


def test_sigkill_then_resume(tmp_path):
    rng = random.Random(int(os.environ.get("NLID_KILL_SEED", "5")))
    for trial in range(TRIALS):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        _kill_and_resume(random_campaign(d), d / "run.h5", AVERAGES, LEVELS,
                         delay=rng.uniform(0.0, 2.0))


def test_stepped_sigkill_then_resume(tmp_path):
    """Steps recorded before the kill are bit-identical to an uninterrupted run's (the sim is
    deterministic); ``--resume`` adds exactly the missing steps, every one level-controlled."""
    campaign = stepped_campaign(tmp_path)
    run_campaign(load_campaign(campaign), tmp_path / "ref.h5")
    ref = open_run(tmp_path / "ref.h5")
    assert [lv.n_segments for lv in ref.levels] == [STEPS] * STEPPED_LEVELS
    rng = random.Random(int(os.environ.get("NLID_KILL_SEED", "7")))
    cut = []
    for trial in range(2):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        out = d / "run.h5"
        # the first kill lands as soon as the file exists, before the first step; the
        # next once 1 .. n - 4 steps are committed (a few to spare: steps stored between
        # the poll that sees the count and the kill), so they hit mid-run on any machine
        at = 0 if trial == 0 else rng.randint(1, STEPS * STEPPED_LEVELS - 4)
        before, kept = _kill_and_resume(campaign, out, STEPS, STEPPED_LEVELS, at=at)
        cut.append(before)
        run = open_run(out)
        for index, rec in kept:
            full, whole = run.recording(index), ref.recording(index)
            n = len(rec.freqs)
            np.testing.assert_array_equal(full.force[:n], rec.force)   # untouched by resume
            np.testing.assert_array_equal(rec.force, whole.force[:n])  # same as no kill
            np.testing.assert_array_equal(rec.response, whole.response[:n])
        for lv in run.levels:
            rec = run.recording(lv.index)
            np.testing.assert_array_equal(rec.freqs, ref.recording(lv.index).freqs)
            np.testing.assert_allclose(rec.meta["step_amplitude"], lv.nominal, rtol=0.02)
    print(f"steps on file when killed: {cut} of {STEPS * STEPPED_LEVELS}")
    assert any(0 < n < STEPS * STEPPED_LEVELS for n in cut), cut  # some kills hit mid-run


def test_periodic_sigkill_then_resume(tmp_path):
    """Realizations on file when killed stay intact; ``--resume`` adds the missing ones with
    the seeds an uninterrupted run uses, and the level keeps its periodic layout."""
    campaign = _campaign(tmp_path, "campaign-sim-periodic.toml", {
        "averages = 8": "averages = 6", "periods = 8 ": "periods = 3 "})
    rng = random.Random(int(os.environ.get("NLID_KILL_SEED", "3")))
    cut = []
    for trial in range(TRIALS):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        # killed once 1 .. 3 of the 6 realizations are committed (three to spare)
        before, _ = _kill_and_resume(campaign, d / "run.h5", 6, 1, at=rng.randint(1, 3))
        cut.append(before)
        rec = open_run(d / "run.h5").recording(0)
        assert (rec.layout.realizations, rec.layout.period) == (6, 4096)
    print(f"realizations on file when killed: {cut} of 6")
    assert any(0 < n < 6 for n in cut), cut  # some kills hit mid-run


@pytest.mark.slow
def test_sigkill_many_trials(tmp_path):
    rng = random.Random(11)
    for trial in range(10):
        d = tmp_path / f"t{trial}"
        d.mkdir()
        _kill_and_resume(random_campaign(d), d / "run.h5", AVERAGES, LEVELS,
                         delay=rng.uniform(0.0, 2.0))


WATCHDOG = 0.2


@pytest.mark.realtime
def test_sigkill_host_watchdog_zeroes_drive(tmp_path):
    """The campaign runs in its own process on real ``serial://`` ports served by emulators
    in this one; after SIGKILL nobody feeds the controller's watchdog, which ramps the drive
    to zero within 100 ms of its deadline."""
    fs = 1024.0
    rig = SimRig(Model.load(MODELS / "sdof-cubic-quaddamp.toml"), fs, 0, shaker_gain=20.0,
                 noise_std=1e-8, seed=1)
    camp = load_campaign(random_campaign(tmp_path))
    shaker, daq = SerialShakerEmulator(rig), SerialDaqEmulator(rig, camp.channels, pace=4.0)
    shaker.start()
    daq.start()
    rng = random.Random(3)
    try:
        text = (tmp_path / "campaign.toml").read_text()
        text = text.replace('url = "sim://"', f'url = "serial://{shaker.port}"\nwatchdog = '
                            f'{WATCHDOG}', 1).replace('url = "sim://"',
                                                      f'url = "serial://{daq.port}"\n'
                                                      'comms_timeout = 0.25', 1)
        text = text[:text.index("[plant]")] + text[text.index("[shaker]"):]
        real = tmp_path / "real.toml"
        real.write_text(text)
        assert main(["campaign", "check", str(real)]) == 0
        proc = _spawn(real, tmp_path / "run.h5")
        try:
            deadline = time.monotonic() + 60
            while not any(line == "OUTP ON" for _, line in list(shaker.log)) \
                    and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.01)
            time.sleep(rng.uniform(0.1, 1.0))
            assert proc.poll() is None and shaker.trips == []  # running, watchdog fed
            killed = time.monotonic()
            proc.send_signal(signal.SIGKILL)
        finally:
            proc.wait(30)
        # The host is dead (its descriptors closed, the beat process's pipe with them) by the
        # time `wait` returns: on a loaded machine the killed process may be scheduled tens of
        # ms after the signal, and its beat process keeps beating until then.
        died = time.monotonic()
        deadline = time.monotonic() + 10 * WATCHDOG
        while not shaker.trips and time.monotonic() < deadline:
            time.sleep(0.005)
        assert shaker.trips, "watchdog never tripped"
        due, tripped = shaker.trips[0]
        # the last beat came before the host died: one written just before may be read by the
        # emulator (a thread of this process) up to one beat period later
        assert killed < due <= died + WATCHDOG + WATCHDOG / FEEDS_PER_PERIOD
        assert 0 <= rig.zero_commanded_at - due + ESTOP_RAMP < 0.1
        print(f"watchdog: deadline {due - killed:.3f} s after the kill ({died - killed:.3f} s to "
              f"die), drive zero "
              f"{rig.zero_commanded_at - due + ESTOP_RAMP:.4f} s after the deadline")
        force = rig.advance(int(0.05 * fs)).force[:, 0]  # what the DAQ sees from now on
        assert np.all(force[int(ESTOP_RAMP * fs) + 1:] == 0.0)
        assert open_run(tmp_path / "run.h5").levels  # the killed run's file is readable
    finally:
        shaker.close()
        daq.close()
    assert shaker.error is None and daq.error is None
