"""In-process ``sim://`` backend: rigs found by name, like python-can's ``virtual`` channels."""

from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from drivers import open_daq, open_shaker
from drivers.base import Channel
from drivers.outputs import RandomOutput
from drivers.errors import UnknownBackendError
from drivers.rig import SimRig
from drivers.sim import register_rig, unregister_rig

MODEL = Path(__file__).resolve().parents[2] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
FS = 1024.0


def test_named_rig_is_shared_by_shaker_and_daq_opened_by_url():
    rig = SimRig(Model.load(MODEL), FS, 0, shaker_gain=10.0, seed=1)
    register_rig("bench1", rig)
    try:
        shaker, daq = open_shaker("sim://bench1"), open_daq("sim://bench1")
        shaker.configure(RandomOutput((5.0, 200.0), 1), 0.5)
        daq.configure(FS, [Channel("F0", "force", 0, 1.0)], frame_size=64)
        shaker.start()
        daq.start()
        block = daq.read(timeout=2.0)
        assert block.data.shape == (64, 1) and np.abs(block.data).max() > 0
        shaker.close()
        daq.close()
    finally:
        unregister_rig("bench1")
    with pytest.raises(UnknownBackendError, match="bench1"):
        open_daq("sim://bench1")
