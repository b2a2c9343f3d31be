"""A new device backend is one module and one registry line: campaigns take its scheme.

The campaign's URL schemes come from the driver registry (`drivers.SHAKERS`, `drivers.DAQS`),
so a backend registered there is accepted, opened and run with no edit elsewhere; a scheme
the registry does not know is refused with the list it does.
"""

import copy
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from drivers import DAQS, SHAKERS
from drivers.rig import SimRig
from drivers.sim import register_rig, unregister_rig
from nlid_lab.campaign import CampaignError, parse_campaign, run_campaign
from nlid_lab.store import open_run

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
BASE = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())

#: The whole backend: a module with a shaker and a DAQ class (here thin wrappers of the
#: in-process simulated devices, reaching a rig registered by name).
TOY_MODULE = '''
from drivers.sim import SimDaq, SimShaker


class ToyShaker(SimShaker):
    def __init__(self, name="", *, ramp_time=0.05, watchdog=None):
        super().__init__(name, ramp_time=ramp_time)


class ToyDaq(SimDaq):
    def __init__(self, name="", *, stall_timeout=None):
        super().__init__(name)
'''


@pytest.fixture
def toy_backend(tmp_path, monkeypatch):
    """``toy://`` written as one module and registered with one line per device role."""
    (tmp_path / "toy_backend.py").write_text(TOY_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(SHAKERS, "toy", ("toy_backend", "ToyShaker"))
    monkeypatch.setitem(DAQS, "toy", ("toy_backend", "ToyDaq"))
    yield "toy"
    sys.modules.pop("toy_backend", None)


def _campaign(url: str) -> dict:
    data = copy.deepcopy(BASE)
    data["shaker"]["url"] = data["daq"]["url"] = url
    data.pop("plant")                      # a real backend: no simulated plant to start
    data["random"].update(levels=[30.0], averages=2, block_size=2048)
    return data


def test_a_registered_backend_runs_a_campaign(toy_backend, tmp_path):
    model = Model.load(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")
    campaign = parse_campaign(_campaign("toy://bench"), EXAMPLES)
    assert not campaign.simulated
    register_rig("bench", SimRig(model, campaign.fs, 0, shaker_gain=20.0, seed=1))
    try:
        result = run_campaign(campaign, tmp_path / "run.h5")
    finally:
        unregister_rig("bench")
    assert result.status == "complete" and result.segments == {0: 2}
    rec = open_run(tmp_path / "run.h5").recording(0)
    assert np.std(rec.force) == pytest.approx(30.0, rel=0.05)     # level control ran


def test_an_unregistered_scheme_is_refused_with_the_registered_ones():
    with pytest.raises(CampaignError) as err:
        parse_campaign(_campaign("toy://bench"), EXAMPLES)
    message = str(err.value)
    assert "toy://" in message and "[shaker] url" in message
    assert all(f"{s}://" in message for s in SHAKERS)


def test_a_daq_only_backend_is_refused_as_a_shaker(toy_backend, monkeypatch):
    monkeypatch.delitem(SHAKERS, "toy")
    with pytest.raises(CampaignError, match=r"\[shaker\] url"):
        parse_campaign(_campaign("toy://bench"), EXAMPLES)
    data = _campaign("serial:///dev/null")
    data["daq"]["url"] = "toy://bench"
    assert parse_campaign(data, EXAMPLES).daq_url == "toy://bench"
