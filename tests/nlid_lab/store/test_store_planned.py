"""How much of its plan a run holds: the count the campaign stored with the run
(``planned_blocks``), and for runs written before that attribute the count read from their
plan's settings, as readers did then; the store names no excitation kind for it."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from nlid_lab import store

ROOT = Path(__file__).resolve().parents[3]


def _run(path: Path, excitation, planned_blocks=None, blocks: int = 1) -> store.Run:
    with store.RunWriter(path, fs=100.0, excitation=excitation, force_dofs=[0], n_dof=1,
                         planned_blocks=planned_blocks) as w:
        lw = w.level(0, 1.0)
        for _ in range(blocks):
            lw.append_block(np.ones((8, 1)), np.ones((8, 1)))
    return store.open_run(path)


@pytest.mark.parametrize("settings, planned", [
    ({"kind": "random", "levels": [1.0, 2.0], "averages": 4, "block_size": 8}, 8),
    ({"kind": "random", "levels": [1.0], "averages": 3, "periodic": True}, 3),
    ({"kind": "stepped-sine", "levels": [1.0, 2.0], "freqs": [5.0, 6.0, 7.0]}, 6),
    ({"kind": "swept-sine", "levels": [1.0, 1.0], "laws": [{}, {}]}, 2),
    ({"kind": "random", "band": [5, 30]}, None),           # imported: no plan
    ({"kind": "stepped-sine", "table": True}, None),        # a stepped-sine table
])
def test_runs_written_before_the_attribute_count_their_plan_as_before(tmp_path, settings,
                                                                      planned):
    run = _run(tmp_path / "old.h5", settings)
    assert "planned_blocks" not in run.meta
    assert run.planned == planned and run.check().planned == planned
    assert run.check().to_json()["blocks_planned"] == planned


def test_a_run_counts_the_plan_its_campaign_stored_whatever_its_settings(tmp_path):
    """A kind the store knows nothing of: its settings hold no count a reader could guess."""
    run = _run(tmp_path / "new.h5", {"kind": "random", "levels": [1.0, 2.0], "bursts": 7},
               planned_blocks=10, blocks=3)
    assert run.meta["planned_blocks"] == 10 and run.planned == 10
    assert run.check().to_json()["blocks_stored"] == 3
    assert run.check().to_json()["blocks_planned"] == 10


def test_the_store_tests_no_excitation_kind_for_the_count():
    text = (ROOT / "nlid_lab" / "store" / "_integrity.py").read_text()
    assert not re.search(r"Excitation|\"(random|stepped-sine|swept-sine)\"|\.get\(\"kind\"\)",
                         text)
