"""Issue 26 item "a fuzz and fault suite": five families of damaged or malformed inputs
(model files, campaign files, NPZ/CSV/MAT recordings, serial DAQ streams, device-fault
campaigns), each case sorted into accepted correctly / exit 2 with one line / internal
error / crash or hang / silent acceptance of damaged input (tests/fuzz_families.py). The
last three must not happen. The fast part draws a few cases per family; the slow part the
counts of the table in docs/reliability-inputs.md (tools/fuzz_table.py prints it)."""

from __future__ import annotations

import pytest

from fuzz_families import BAD, FAMILIES, FAST, TABLE, Outcome, run_family


def _check(name: str, n: int, folder) -> None:
    tally = run_family(name, n, folder)
    print(f"{name}: {dict(tally.counts)}")
    assert sum(tally.counts.values()) == n
    assert not any(tally.counts[o] for o in BAD), f"{name}: case (index, outcome) {tally.bad}"
    assert tally.counts[Outcome.ACCEPTED] + tally.counts[Outcome.REFUSED] == n


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_family_fast(name, tmp_path):
    _check(name, FAST[name], tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_family_table_counts(name, tmp_path):
    _check(name, TABLE[name], tmp_path)
