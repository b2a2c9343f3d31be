"""`benchmarks/zoo_compare.py`: two zoo runs compared row by row."""

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))

from zoo_compare import JUDGED, compare  # noqa: E402


def _row(name: str, **changes) -> dict:
    row = {k: None for k in JUDGED} | {"name": name, "param_errors": {"p": float("nan")},
                                        "held_back": [0.5, 0.25]}
    return row | changes


def _run(*rows: dict) -> dict:
    return {"cases": list(rows), "totals": {"cases": len(rows)}, "confusion": {}}


def test_a_changed_row_is_named_with_its_field_and_nan_equals_nan():
    before = _run(_row("a"), _row("b"), _row("gone"))
    after = _run(_row("a"), _row("b", verdict="adequate", held_back=[0.5, 0.1]), _row("new"))
    lines = compare(before, after)
    assert [ln.split(":")[0] for ln in lines[:3]] == ["CHG  b", "NEW  new", "GONE gone"]
    assert "verdict None -> adequate" in lines[0] and "held_back [0.5, 0.25] -> [0.5, 0.1]" \
        in lines[0] and "param_errors" not in lines[0]
    assert "identical: 1 of 3 rows" in lines
