"""CAN DAQ on a python-can virtual bus against the CAN emulator; DBC layout checks."""

import struct
from pathlib import Path

import can
import numpy as np
import pytest

from analysis.models import Model
from drivers import can_protocol as proto, open_daq, open_shaker
from drivers.base import Channel
from drivers.outputs import RandomOutput
from drivers.emulators._can_emu import CanDaqEmulator
from drivers.emulators._faults import FaultPlan
from drivers.errors import DeviceError, DriverTimeout
from drivers.rig import SimRig

MODEL = Path(__file__).resolve().parents[2] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
FS = 1024.0
CHANNELS = [Channel("F0", "force", 0, 0.01), Channel("x0", "displacement", 0, 1000.0),
            Channel("v0", "velocity", 0, 10.0)]


def make_rig(seed=3):
    return SimRig(Model.load(MODEL), FS, 0, shaker_gain=10.0, seed=seed)


@pytest.fixture
def can_rig(request):
    made = []

    def make(faults=None, pace=20.0):
        rig = make_rig()
        channel = f"test-{request.node.name}-{len(made)}"
        emu = CanDaqEmulator(rig, CHANNELS, "virtual", channel, pace=pace, faults=faults)
        emu.start()
        daq = open_daq(f"can://virtual/{channel}", stall_timeout=0.1)
        made.extend([daq, emu])
        shaker = open_shaker("sim://", rig=rig)
        shaker.configure(RandomOutput((5.0, 200.0), 1), 0.5)
        daq.configure(FS, CHANNELS, frame_size=32)
        shaker.start()
        daq.start()
        return emu, daq

    yield make
    for obj in made:
        obj.close()
    assert all(getattr(o, "error", None) is None for o in made)


def test_hand_packed_frames_match_the_dbc():
    msg = proto.database().get_message_by_frame_id(proto.SAMPLES_ID + 1)
    for cnt, a, b in [(0, 0, 0), (65535, 8388607, -8388607), (1234, -1, 77), (9, -5000, 1)]:
        want = msg.encode({"Counter": cnt, "Ch2": a, "Ch3": b}, scaling=False)
        got = struct.pack("<HI", cnt, (a & 0xFFFFFF) | ((b & 0xFF) << 24)) + \
            struct.pack("<H", (b >> 8) & 0xFFFF)
        assert got == want


def test_can_stream_equals_in_process_sim(can_rig):
    rig = make_rig()
    sim_daq = open_daq("sim://", rig=rig)
    sh = open_shaker("sim://", rig=rig)
    sh.configure(RandomOutput((5.0, 200.0), 1), 0.5)
    sim_daq.configure(FS, CHANNELS, frame_size=32)
    sh.start()
    sim_daq.start()
    a = np.vstack([sim_daq.read().data for _ in range(40)])
    _, daq = can_rig()
    blocks = [daq.read(timeout=2.0) for _ in range(40)]
    b = np.vstack([x.data for x in blocks])
    # 24-bit samples over +-10 V: one count is 10 / (2**23 - 1) V
    lsb = proto.volt_scale() / np.array([c.sensitivity for c in CHANNELS])
    assert np.all(np.abs(b - a) <= 0.5 * lsb + 1e-12)
    assert daq.stats.lost_samples == 0 and [x.first_sample for x in blocks][:3] == [0, 32, 64]


def test_drops_duplicates_and_garbage_are_counted(can_rig):
    emu, daq = can_rig(FaultPlan(drop_every=37, duplicate_every=23, garbage_every=11))
    blocks = [daq.read(timeout=2.0) for _ in range(40)]
    s = daq.stats
    assert s.lost_frames > 0 and s.duplicate_frames > 0 and s.garbage_bytes > 0
    assert s.lost_samples == sum(b.gap for b in blocks) > 0
    # a sample row is lost whenever one of its two frames (2 groups) was dropped
    last_row = blocks[-1].first_sample + len(blocks[-1].data) - 1
    dropped_rows = {k // 2 for k in range(1, 2 * last_row + 2) if k % 37 == 0}
    assert s.lost_samples == len({r for r in dropped_rows if r <= last_row})


def test_stall_and_disconnect_raise_timeouts(can_rig):
    _, daq = can_rig(FaultPlan(stall_at=300))
    with pytest.raises(DriverTimeout, match="stalled"):
        for _ in range(40):
            daq.read(timeout=2.0)
    _, daq = can_rig(FaultPlan(disconnect_at=300))
    with pytest.raises(DriverTimeout):
        for _ in range(40):
            daq.read(timeout=2.0)


def test_wrong_configuration_is_refused():
    rig = make_rig()
    emu = CanDaqEmulator(rig, CHANNELS, "virtual", "test-refuse", pace=1.0)
    emu.start()
    try:
        with open_daq("can://virtual/test-refuse") as daq:
            daq.configure(2 * FS, CHANNELS)
            with pytest.raises(DeviceError, match="error code 1"):
                daq.start()
    finally:
        emu.close()


def test_control_frames_decode_with_cantools():
    db = proto.database()
    bus = can.Message(arbitration_id=proto.CONTROL_ID,
                      data=db.encode_message("HOST_Control", {"Command": 1, "NumChannels": 3,
                                                              "RateHz": 25600.0}))
    decoded = db.decode_message(bus.arbitration_id, bus.data)
    assert decoded["NumChannels"] == 3 and decoded["RateHz"] == pytest.approx(25600.0)
