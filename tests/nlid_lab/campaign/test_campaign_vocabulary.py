"""Vocabularies are StrEnums where values are parsed, and each default is written once."""

import copy
import dataclasses
import tomllib
from pathlib import Path

import pytest

from analysis.models import Model
from analysis.recordings import EXCITATIONS, Excitation, ResponseKind
from drivers import DeviceState, StateError
from drivers.rig import SimRig
from drivers.sim import SimDaq
from nlid_lab.campaign import PLANS, CampaignError, parse_campaign

RandomSpec, SweepSpec = PLANS[Excitation.RANDOM], PLANS[Excitation.SWEPT_SINE]

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
BASE = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())


def test_a_campaign_holds_enum_members_equal_to_the_file_strings():
    c = parse_campaign(copy.deepcopy(BASE), EXAMPLES)
    assert type(c.kind) is Excitation and c.kind == "random"
    assert type(c.response_kind) is ResponseKind and c.response_kind == "displacement"
    assert EXCITATIONS == tuple(Excitation) and "swept-sine" in EXCITATIONS


@pytest.mark.parametrize("key, where, value", [("kind", None, "sine"),
                                               ("response_kind", "daq", "strain")])
def test_a_value_outside_the_vocabulary_names_the_allowed_ones(key, where, value):
    data = copy.deepcopy(BASE)
    (data[where] if where else data)[key] = value
    vocabulary = ResponseKind if where else Excitation
    with pytest.raises(CampaignError) as err:
        parse_campaign(data, EXAMPLES)
    assert ", ".join(vocabulary) in str(err.value) and repr(value) in str(err.value)


@pytest.mark.parametrize("spec, key, table, value", [(RandomSpec, "tolerance", "random", 0.07),
                                                     (RandomSpec, "settle_blocks", "random", 3)])
def test_a_left_out_key_takes_the_default_written_on_its_field(spec, key, table, value,
                                                                monkeypatch):
    field = next(f for f in dataclasses.fields(spec) if f.name == key)
    data = copy.deepcopy(BASE)
    assert key not in data[table]
    monkeypatch.setattr(field, "default", value)        # the one place the default lives
    assert getattr(parse_campaign(data, EXAMPLES).plan, key) == value


def test_the_sweep_default_block_size_is_its_field():
    data = copy.deepcopy(BASE)
    del data["random"]
    data["kind"] = "swept-sine"
    data["sweep"] = {"levels": [1.0], "start": 10.0, "stop": 100.0, "rate": 5.0}
    plan = parse_campaign(data, EXAMPLES).plan
    assert isinstance(plan, SweepSpec) and plan.block_size == SweepSpec.block_size == 1024


def test_a_device_reports_its_lifecycle_as_device_states():
    model = Model.load(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")
    daq = SimDaq(rig=SimRig(model, 1024.0, 0, seed=0))
    assert daq.state is DeviceState.NEW
    with pytest.raises(StateError, match="cannot read while new; expected running"):
        daq.read()
    daq.close()
    assert daq.state is DeviceState.CLOSED and daq.state == "closed"
