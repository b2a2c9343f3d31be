"""A model file's ``[support]`` (contracts section 7): read, kept through copies, written back;
bad tables refused naming the fix."""

from __future__ import annotations

from pathlib import Path

import pytest

from analysis.errors import ModelError
from analysis.models import Model, Support

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
CHAIN = """name = "chain"
points = ["root", "mid", "tip"]
[linear]
mass = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]
damping = [[2.0, -1, 0], [-1, 2.0, -1], [0, -1, 1.0]]
stiffness = [[2e4, -1e4, 0], [-1e4, 2e4, -1e4], [0, -1e4, 1e4]]
"""


def test_support_points_by_name_survive_copies_and_the_file():
    m = Model.loads(CHAIN + '[support]\npoints = ["root", 2]\n')
    assert m.support == Support((0, 2))
    assert m.with_elements([]).support == Support((0, 2))
    assert Model.loads(m.dumps()).support == Support((0, 2))
    assert m.modal_form(["mid", "tip"]).support == Support((1,))   # root is not kept


def test_free_structure_and_no_table():
    assert Model.loads(CHAIN + "[support]\nfree = true\n").support == Support(free=True)
    assert Model.loads(Model.loads(CHAIN + "[support]\nfree = true\n").dumps()).support.free
    assert Model.load(EXAMPLE).support is None
    assert "[support]" not in Model.load(EXAMPLE).dumps()


@pytest.mark.parametrize("table, words", [
    ('points = ["root"]\nfree = true', "either points"),
    ("free = false", "write free = true"),
    ("points = []", "must list the points held"),
    ('points = ["wing"]', "no point 'wing'"),
    ("held = [0]", "unknown key 'held'"),
])
def test_bad_support_tables_name_the_fix(table, words):
    with pytest.raises(ModelError, match=words):
        Model.loads(CHAIN + "[support]\n" + table + "\n")
