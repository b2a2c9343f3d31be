"""An excitation kind is one plan class for the campaign and one output record for the shaker.

A toy kind, burst random, is written here whole and registered, with no edit elsewhere: the
shaker record (`drivers.outputs`: its check and its player, which the simulated rig plays) and
the campaign's plan (`campaign.LevelPlan`: its table, plan record, unit and blocks per level,
and its level loop on the runner's public primitives, `campaign.Runner`). In the tree that is
two files: a module of ``nlid_lab/campaign/_kinds/`` (found by import, as the built-in kinds'
are, their loops beside their plans) and `drivers/outputs.py`. ``campaign check`` names it, a
campaign of it runs on ``sim://`` and stores levels recorded as random (each block a burst
and a silent tail, the burst at the level) with its planned count, which readers take from
the run (the store names no kind). A kind nobody registered is refused naming the registered
ones.
"""

from __future__ import annotations

import copy
import re
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from analysis.plant import burst_random
from analysis.recordings import Excitation
from drivers import DriverConfigError
from nlid_lab.campaign import (PLANS, CampaignError, LevelPlan, Runner, discover_kinds,
                               parse_campaign, register_plan, run_campaign, unregister_plan)
from nlid_lab.cli import main
from nlid_lab.store import open_run

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
BASE = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())


# --- the shaker's record: what it plays ------------------------------------------------------
@dataclass(frozen=True)
class BurstOutput:
    """A burst of band-limited noise over the first ``fraction`` of every ``block`` samples,
    silent after; ``level`` is the burst's rms in volts."""

    band: tuple[float, float]
    block: int
    fraction: float
    seed: int = 0

    def check(self, fs: float | None = None) -> None:
        if not 0 < self.fraction <= 1:
            raise DriverConfigError(f"burst fraction {self.fraction} must be in (0, 1]")

    def player(self, fs: float, seed: int | None) -> "_BurstPlayer":
        return _BurstPlayer(self, fs)


@dataclass
class _BurstPlayer:
    output: BurstOutput
    fs: float
    pos: int = 0            # samples played since the output was configured

    def play(self, n: int) -> np.ndarray:
        o, out = self.output, np.empty(n)
        for i in range(n):          # per sample: a toy, kept plain
            k, j = divmod(self.pos + i, o.block)
            if j == 0 or i == 0:
                burst = burst_random(o.block, self.fs, o.band, 1.0, o.fraction, o.seed + k)
            out[i] = burst[j]
        self.pos += n
        return out

    def idle(self, n: int) -> None:
        self.pos += n

    def resume(self, last: Any) -> None:
        """Bursts start afresh at each configure."""


# --- the campaign's plan: its table, record and level loop ---------------------------------
@dataclass
class BurstSpec(LevelPlan):
    levels: list[float]
    averages: int
    block_size: int
    band: tuple[float, float]
    fraction: float = 0.5
    tolerance: float = 0.05
    max_control_iterations: int = 6

    kind = "burst-random"
    table = "burst"
    excitation = Excitation.RANDOM      # analysed as random data (H1 over the blocks)

    @classmethod
    def from_table(cls, data, fs):
        t = data.get(cls.table)
        if not isinstance(t, dict) or not {"levels", "averages", "block_size", "band"} <= set(t):
            raise CampaignError("[burst] needs levels, averages, block_size and band")
        return cls(list(t["levels"]), t["averages"], t["block_size"], tuple(t["band"]),
                   t.get("fraction", cls.fraction))

    @property
    def per_level(self) -> int:
        return self.averages

    def blocks_per_level(self, fs):
        return 2 + self.averages, 2 * self.max_control_iterations + self.averages

    def run(self, runner: Runner) -> None:
        """The kind's level loop, on the runner's public primitives only."""
        n_burst = round(self.fraction * self.block_size)
        for i, level in enumerate(self.levels):
            lw = runner.level_start(i, level, self.averages)
            drive = min(level / runner.gain, runner.c.max_drive)
            runner.start(BurstOutput(self.band, self.block_size, self.fraction, 100 * i), drive)
            drive = runner.control(level, drive,
                                   lambda data: float(np.std(data[:n_burst, runner.force_col])),
                                   "burst force rms", self.block_size, 1, self.tolerance,
                                   self.max_control_iterations)[0]
            while lw.n_segments < self.averages:
                data, t0 = runner.take(self.block_size)
                force, resp = runner.split(data)
                seq = lw.append_block(force, resp, t=t0)
                runner.observer.block(i, seq, force, resp)
                runner.stored(lw, level, self.averages, float(np.std(force[:n_burst])), drive)
            runner.stop()
            runner.level_end(lw, level, self.averages)


@pytest.fixture
def burst_kind():
    register_plan(BurstSpec)
    yield BurstSpec
    unregister_plan(BurstSpec)


def _burst_campaign(tmp_path: Path) -> Path:
    data = copy.deepcopy(BASE)
    data["kind"] = "burst-random"
    data.pop("random")
    data["burst"] = {"levels": [5.0, 20.0], "averages": 3, "block_size": 2048,
                     "band": [5.0, 200.0], "fraction": 0.5}
    data["plant"]["model"] = str(EXAMPLES / data["plant"]["model"])
    path = tmp_path / "burst.toml"
    lines = [f"{k} = {_toml(v)}" for k, v in data.items() if not isinstance(v, (dict, list))]
    for name, table in data.items():
        for t in (table if isinstance(table, list) else [table]):
            if isinstance(t, dict):
                head = f"[[{name}]]" if isinstance(table, list) else f"[{name}]"
                lines += [head] + [f"{k} = {_toml(v)}" for k, v in t.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def _toml(value) -> str:
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "true" if value is True else "false" if value is False else \
        f'"{value}"' if isinstance(value, str) else repr(value)


def test_a_registered_kind_is_checked_run_and_stored_with_no_other_edit(burst_kind, tmp_path,
                                                                         capsys):
    path = _burst_campaign(tmp_path)
    assert main(["campaign", "check", str(path)]) == 0
    assert "valid burst-random campaign, 2 level(s) x 3 blocks" in capsys.readouterr().out
    campaign = parse_campaign(tomllib.loads(path.read_text()), EXAMPLES)
    assert isinstance(campaign.plan, BurstSpec) and campaign.kind == "burst-random"
    result = run_campaign(campaign, tmp_path / "run.h5")
    assert result.status == "complete" and result.segments == {0: 3, 1: 3}
    assert [lv.unit for lv in result.levels] == ["block", "block"]
    run = open_run(tmp_path / "run.h5")
    n_burst = 1024
    for i, level in enumerate((5.0, 20.0)):
        rec = run.recording(i)
        assert rec.excitation == Excitation.RANDOM
        blocks = rec.force[:, 0].reshape(3, 2048)
        assert np.all(blocks[:, n_burst:] == 0.0)                     # the silent tails
        rms = np.std(blocks[:, :n_burst], axis=1)
        assert np.all(np.abs(rms / level - 1) <= BurstSpec.tolerance)  # level control held
    settings = run.meta["excitation_settings"]
    assert settings["kind"] == "random" and settings["fraction"] == 0.5
    assert run.meta["planned_blocks"] == 6 and run.check().planned == 6
    assert run.incomplete == ""


def test_an_unregistered_kind_is_refused_naming_the_registered_ones(tmp_path):
    data = tomllib.loads(_burst_campaign(tmp_path).read_text())
    with pytest.raises(CampaignError, match=r"unknown key 'burst'.* random, safety"):
        parse_campaign(data, EXAMPLES)        # nor its table: the tables are the kinds'
    data.pop("burst")
    with pytest.raises(CampaignError) as err:
        parse_campaign(data, EXAMPLES)
    assert "kind must be one of " + ", ".join(PLANS) in str(err.value)
    assert "'burst-random'" in str(err.value)


def test_the_campaign_and_the_rig_test_no_kind_but_in_its_plan_class():
    """Each kind is named once, on its plan class: no `isinstance` of a plan or an output
    record and no comparison with an `Excitation` member in the campaign, its command or the
    simulated rig."""
    root = Path(__file__).resolve().parents[3]
    files = sorted((root / "nlid_lab" / "campaign").glob("*.py")) + [
        root / "nlid_lab" / "commands" / "campaign.py", root / "drivers" / "rig.py",
        root / "drivers" / "sim.py", root / "drivers" / "outputs.py"]
    kind_test = re.compile(r"isinstance\([^)]*(Spec|Output)\b|[=!]= *Excitation\.|"
                           r"Excitation\.\w+ *[=!]=|\.kind *[=!]=")
    files += sorted((root / "nlid_lab" / "campaign" / "_kinds").glob("*.py"))
    found = [f"{path.name}:{i}" for path in files
             for i, line in enumerate(path.read_text().splitlines(), 1) if kind_test.search(line)]
    assert found == []
    assert set(PLANS) == set(Excitation)       # every recorded excitation has its plan class


def test_a_new_kind_module_is_found_with_no_other_edit(tmp_path, monkeypatch):
    """`discover_kinds` (what ``nlid_lab/campaign/_kinds`` runs on import): a package's modules
    not imported yet are imported in name order, so a module holding a registered plan class
    and its loop is the whole addition to the campaign."""
    pkg = tmp_path / "toy_kinds"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "_burst.py").write_text(
        "from test_campaign_kinds import BurstSpec\n"
        "from nlid_lab.campaign import register_plan\n"
        "register_plan(BurstSpec)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    try:
        assert "burst-random" not in PLANS
        assert discover_kinds("toy_kinds", [str(pkg)]) == ["toy_kinds._burst"]
        assert PLANS["burst-random"].__name__ == "BurstSpec"
        assert discover_kinds("toy_kinds", [str(pkg)]) == []           # once only
    finally:
        PLANS.pop("burst-random", None)
        for name in ("toy_kinds._burst", "toy_kinds"):
            sys.modules.pop(name, None)
    assert list(PLANS)[:3] == ["random", "stepped-sine", "swept-sine"]  # built-ins in order
