"""Serial shaker + serial DAQ end to end through the pty emulators, faults included."""

import time
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from drivers import open_daq, open_shaker
from drivers.base import Channel
from drivers.outputs import MultisineOutput, RandomOutput, SineOutput
from drivers.emulators._faults import FaultPlan
from drivers.emulators._serial_emu import ESTOP_RAMP, SerialDaqEmulator, SerialShakerEmulator
from drivers.errors import (CommsError, DeviceError, Disconnected, DriverConfigError,
                            DriverTimeout, StateError, UnknownBackendError)
from drivers.rig import SimRig

MODEL = Path(__file__).resolve().parents[2] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
FS = 1024.0
CHANNELS = [Channel("F0", "force", 0, 0.01), Channel("x0", "displacement", 0, 1000.0)]


def make_rig(seed=3):
    return SimRig(Model.load(MODEL), FS, 0, shaker_gain=10.0, seed=seed)


def stream(shaker, daq, n_frames, output=RandomOutput((5.0, 200.0), 1)):
    shaker.configure(output, 0.5)
    daq.configure(FS, CHANNELS, frame_size=32)
    shaker.start()
    daq.start()
    return [daq.read(timeout=2.0) for _ in range(n_frames)]


@pytest.fixture
def emulated():
    made = []

    def make(pace=0.0, faults=None, watchdog=0.5):
        rig = make_rig()
        se, de = SerialShakerEmulator(rig), SerialDaqEmulator(rig, CHANNELS, pace=pace,
                                                              faults=faults)
        se.start()
        de.start()
        made.extend([se, de])
        sh = open_shaker(f"serial://{se.port}", watchdog=watchdog)
        dq = open_daq(f"serial://{de.port}?baud=921600", stall_timeout=0.1)
        made[:0] = [sh, dq]
        return rig, se, de, sh, dq

    yield make
    for obj in made:
        obj.close()
    for obj in made:
        assert getattr(obj, "error", None) is None


def test_serial_stream_equals_in_process_sim(emulated):
    rig = make_rig()
    sim = stream(open_shaker("sim://", rig=rig), open_daq("sim://", rig=rig), 100)
    _, _, _, sh, dq = emulated()
    ser = stream(sh, dq, 100)
    a = np.vstack([b.data for b in sim])
    b = np.vstack([b.data for b in ser])
    # float32 volts on the wire: relative precision 2**-24 of each sample
    scale = np.abs(a).max(0)
    np.testing.assert_allclose(b / scale, a / scale, rtol=2e-7, atol=1e-7)
    assert [blk.first_sample for blk in ser] == list(range(0, 3200, 32))
    assert dq.stats.lost_samples == 0 and dq.stats.samples == 3200
    assert ser[5].t0 == pytest.approx(5 * 32 / FS)


def test_multisine_over_serial_is_periodic_and_equals_sim(emulated):
    """SOUR:FUNC MSIN with its band, period and seed reaches the rig: the force repeats
    with the period once the start ramp is over, sample for sample as in-process."""
    out = MultisineOutput((5.0, 200.0), 256, 7)
    rig = make_rig()
    sim = stream(open_shaker("sim://", rig=rig), open_daq("sim://", rig=rig), 64, out)
    rig_e, _, _, sh, dq = emulated()
    ser = stream(sh, dq, 64, out)
    assert rig_e._output == out
    a = np.vstack([b.data for b in sim])[:, 0]
    b = np.vstack([b.data for b in ser])[:, 0]
    np.testing.assert_allclose(b, a, rtol=2e-7, atol=1e-7 * np.abs(a).max())
    np.testing.assert_allclose(b[1024:1280], b[1280:1536], atol=1e-6 * np.abs(b).max())
    with pytest.raises(DriverConfigError, match="no frequency line"):
        make_rig().set_output(MultisineOutput((5.2, 5.8), 256, 1))     # lines every 8 Hz


def test_faults_are_counted_never_silent(emulated):
    faults = FaultPlan(garbage_every=7, drop_every=11, duplicate_every=13, corrupt_every=17)
    _, _, de, sh, dq = emulated(faults=faults)
    blocks = stream(sh, dq, 120)
    s = dq.stats
    last = blocks[-1].seq
    lost = [k for k in range(1, last + 1) if k % 11 == 0 or k % 17 == 0]  # dropped or bad CRC
    assert s.lost_frames == len(lost) and s.frames == 120 == last + 1 - len(lost)
    assert s.duplicate_frames > 0 and s.bad_frames > 0
    assert s.garbage_bytes > 0
    assert s.lost_samples == 32 * s.lost_frames
    assert sum(b.gap for b in blocks) == s.lost_samples
    firsts = [b.first_sample for b in blocks]
    assert firsts == sorted(set(firsts))


def test_stall_raises_timeout_and_disconnect_raises_disconnected(emulated):
    _, _, de, sh, dq = emulated(faults=FaultPlan(stall_at=20))
    with pytest.raises(DriverTimeout, match="stalled"):
        stream(sh, dq, 40)
    _, _, de, sh, dq = emulated(faults=FaultPlan(disconnect_at=20))
    with pytest.raises((Disconnected, DriverTimeout)):
        stream(sh, dq, 40)


def test_shaker_commands_and_errors(emulated):
    rig, se, _, sh, _ = emulated()
    assert "SHAKER-EMU" in sh.idn
    sh.configure(SineOutput(40.0), 0.25)
    assert sh.link.command("SOURce:VOLTage?", 1.0) == "0.25"   # long SCPI forms work
    with pytest.raises(DeviceError, match="-113"):
        sh.link.command("FOO:BAR 1", 1.0)
    with pytest.raises(DeviceError, match="-222"):
        sh.set_level(50.0)
    with pytest.raises(DriverConfigError):
        sh.set_level(-1.0)
    sh.start()
    assert not rig.drive_is_zero
    sh.emergency_stop()
    assert rig.zero_commanded_at is not None
    se.stall = True
    with pytest.raises(DriverTimeout):
        sh.set_level(0.1, timeout=0.1)


def test_lifecycle_and_registry_errors(emulated):
    _, _, _, sh, dq = emulated()
    with pytest.raises(StateError):
        dq.read(0.1)
    with pytest.raises(UnknownBackendError):
        open_daq("gpib://3")
    with pytest.raises(DriverConfigError, match="INTERFACE/CHANNEL"):
        open_daq("can://virtual")
    with pytest.raises(DriverConfigError, match="cannot open"):
        open_shaker("serial:///dev/does-not-exist")
    with pytest.raises(DriverConfigError, match="quantity"):
        Channel("a", "pressure", 0)
    with pytest.raises(DeviceError, match="-222"):
        dq.configure(2 * FS, CHANNELS)


@pytest.mark.realtime
def test_realtime_pacing(emulated):
    _, _, _, sh, dq = emulated(pace=1.0)
    t = time.monotonic()
    stream(sh, dq, 16)  # 512 samples = 0.5 s of real time
    assert time.monotonic() - t == pytest.approx(0.5, abs=0.2)


def wait_for(predicate, timeout):
    deadline = time.monotonic() + timeout
    while not predicate() and time.monotonic() < deadline:
        time.sleep(0.002)
    return predicate()


def drive_after_trip(rig):
    """Force the rig delivers over the next 50 ms of signal (the DAQ's view of the drive)."""
    return rig.advance(int(0.05 * FS)).force[:, 0]


def test_watchdog_fed_while_idle_trips_when_link_dies(emulated):
    period = 0.2
    rig, se, _, sh, _ = emulated(watchdog=period)
    assert sh.link.command("SYST:WDOG?", 1.0) == "0.2"
    sh.configure(SineOutput(40.0), 0.3)
    sh.start()
    assert np.abs(drive_after_trip(rig)).max() > 0
    time.sleep(4 * period)          # no commands from the caller: the feeder keeps it alive
    assert se.trips == [] and sh.feed_error is None
    se.unplugged = True             # cable pulled: nothing reaches the controller any more
    assert wait_for(lambda: se.trips, 10 * period)
    deadline, tripped = se.trips[0]
    last_heard = se.log[-1][0]
    assert deadline == pytest.approx(last_heard + period, abs=1e-6)
    # drive commanded to zero, and ramped out, within 100 ms of the heartbeat deadline
    assert 0 <= rig.zero_commanded_at - deadline + ESTOP_RAMP < 0.1
    force = drive_after_trip(rig)
    assert np.all(force[int(ESTOP_RAMP * FS) + 1:] == 0.0)
    assert wait_for(lambda: sh.feed_error is not None, 4 * period)
    with pytest.raises(CommsError, match="watchdog"):
        sh.check_link()
    se.unplugged = False            # plugged back: the controller says what happened
    assert sh.link.command("OUTP?", 1.0) == "0"
    assert sh.link.command("SYST:ERR?", 1.0).startswith("-300")


def test_watchdog_options(emulated):
    with pytest.raises(DriverConfigError, match="watchdog"):
        emulated(watchdog=0.001)
    _, se, _, sh, _ = emulated(watchdog=0)
    assert se.watchdog == 0 and sh.link.command("SYST:WDOG?", 1.0) == "0"
    sh.close()
    rig = make_rig()
    old = SerialShakerEmulator(rig)  # a controller without the watchdog command
    old._dispatch = lambda head, arg, orig=old._dispatch: (
        'ERR -113,"Undefined header"' if head.startswith("SYST:WDOG") else orig(head, arg))
    old.start()
    try:
        with pytest.raises(DriverConfigError, match="watchdog=0"):
            open_shaker(f"serial://{old.port}")
    finally:
        old.close()
