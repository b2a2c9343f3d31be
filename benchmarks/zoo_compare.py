"""Compare two runs of the diagnosis zoo, row by row.

    python benchmarks/zoo_compare.py BEFORE.json AFTER.json

Each file is the ``--json`` output of ``benchmarks/bench_diagnose.py --zoo``. Prints every row
whose judged fields differ (verdict, what was found, family and location right, parameters
within tolerance and their errors, intervals holding the truth, held-back errors), the rows
only one run has, how many rows are identical, and both runs' totals and confusion matrices:
what a policy change shows before it lands (docs/diagnose.md).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

JUDGED = ("verdict", "found", "family_right", "location", "params_ok", "param_errors",
          "covered", "unidentifiable", "held_back")


def _rounded(value: object) -> object:
    if isinstance(value, float):
        return round(value, 4)
    if isinstance(value, list):
        return [_rounded(v) for v in value]
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    return value


def _key(value: object) -> str:
    """A judged field as comparable text (NaN equal to NaN)."""
    return json.dumps(_rounded(value), sort_keys=True)


def compare(before: dict, after: dict) -> list[str]:
    """Lines describing how ``after``'s rows differ from ``before``'s."""
    old = {row["name"]: row for row in before["cases"]}
    new = {row["name"]: row for row in after["cases"]}
    lines, same = [], 0
    for name, row in new.items():
        if name not in old:
            lines.append(f"NEW  {name}: " + ", ".join(f"{k}={_rounded(row[k])}" for k in JUDGED))
            continue
        changed = {k: (_rounded(old[name][k]), _rounded(row[k]))
                   for k in JUDGED if _key(old[name][k]) != _key(row[k])}
        if not changed:
            same += 1
            continue
        lines.append(f"CHG  {name}: " + "; ".join(f"{k} {a} -> {b}"
                                                  for k, (a, b) in changed.items()))
    lines += [f"GONE {name}" for name in old if name not in new]
    lines.append(f"identical: {same} of {len(old)} rows")
    for label, run in (("before", before), ("after", after)):
        lines.append(f"{label} totals: {run['totals']}")
        lines.append(f"{label} confusion: {run['confusion']}")
    return lines


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python benchmarks/zoo_compare.py BEFORE.json AFTER.json", file=sys.stderr)
        return 2
    before, after = (json.loads(Path(p).read_text()) for p in argv)
    print("\n".join(compare(before, after)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
