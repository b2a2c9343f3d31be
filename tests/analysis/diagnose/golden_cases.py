"""The `nlid-lab diagnose` command paths whose ``--json`` outputs are kept as golden files
(``golden/<case>.json``): random levels (a cubic spring; two effects from a held-back
segment; an adequate model; an unexplained misfit after a rejected correction), stepped sine
(a linear error; a friction joint refitted by harmonic balance) and periodic multisines of a
modal model seen through a sensor map.

The goldens were written by the command before the diagnosis result became typed
(`analysis.diagnose._result`); `test_diagnose_golden` proves the JSON unchanged but for the
added ``schema_version``. They lock the numbers too: a change meant to move them (the plant,
the spectral estimate) regenerates them, on purpose and said so in its commit::

    .venv/bin/python tests/analysis/diagnose/golden_cases.py
"""

from __future__ import annotations

import json
import re
import sys
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

GOLDEN = Path(__file__).parent / "golden"


def _scenario(name: str):
    import diagnose_scenarios as S
    return {"random-cubic": lambda: S.hidden_cubic(n=1 << 15),
            "random-segment": lambda: _last_level(S.hidden_cubic(n=1 << 15)),
            "random-adequate": lambda: S.no_discrepancy(n=1 << 15),
            "random-unexplained": S.drifting_structure,
            "stepped-stiffness": S.stepped_stiffness_error,
            "stepped-friction": S.masked_friction}[name]()


def _last_level(sc):
    sc.recordings = sc.recordings[-1:]
    return sc


def _gvt():
    import gvt_scenarios as G
    return G.stiffness_error()


CASES: dict[str, tuple[Callable, list[str]]] = {
    "random-cubic": (lambda: _scenario("random-cubic"), []),
    "random-segment": (lambda: _scenario("random-segment"), []),
    "random-adequate": (lambda: _scenario("random-adequate"), []),
    "random-unexplained": (lambda: _scenario("random-unexplained"), []),
    "stepped-stiffness": (lambda: _scenario("stepped-stiffness"), []),
    "stepped-friction": (lambda: _scenario("stepped-friction"), []),
    "modal-sensors": (_gvt, ["--band", "3", "200"]),
}
"""Case name -> (scenario with ``start`` and ``recordings``, extra command options)."""


def run_case(name: str, root: Path) -> str:
    """The text the command writes with ``--json`` for case ``name`` (files under ``root``),
    less the runs' data checks."""
    from nlid_lab.cli import main
    from nlid_lab.store import save_recording

    make, options = CASES[name]
    sc = make()
    sc.start.save(root / "start.toml")
    runs = []
    for i, rec in enumerate(sc.recordings):
        save_recording(root / f"level{i}.h5", rec)
        runs.append(str(root / f"level{i}.h5"))
    out = root / "out.json"
    rc = main(["diagnose", str(root / "start.toml"), *runs, "--json", str(out), "--quiet",
               *options])
    assert rc == 0, f"diagnose failed on case {name}"
    data = json.loads(out.read_text())
    # the runs' data checks (added with issue 26) come last: one per run, each whole
    checks = data.pop("data_checks")
    assert [c["path"] for c in checks] == runs and not any(c["left_out"] for c in checks)
    return json.dumps(data, indent=2, allow_nan=False) + "\n"


def without_added_keys(text: str) -> str:
    """The JSON text without the keys added since the golden files were written: the
    top-level ``schema_version`` and the runs' ``data_checks`` (the command's own formatting,
    so the result compares byte for byte with a golden file)."""
    data = json.loads(text)
    data.pop("schema_version", None)
    data.pop("data_checks", None)
    return json.dumps(data, indent=2, allow_nan=False) + "\n"


NUMBER = re.compile(r"-?\d+\.\d+(?:[eE][-+]?\d+)?|-?\d+[eE][-+]?\d+")
RTOL = 1e-5
"""Numbers of a golden may move this much, relative: the same code gives FRF errors 1.5e-6
apart with one BLAS thread (`make test`) or several (a plain pytest) on the modal-sensors case
(its modal fit's least squares follow the summation order); the other cases are identical.
Every character but the numbers must match exactly."""


def same_as_golden(text: str, golden: str) -> bool:
    """``text`` (`without_added_keys`) is the golden one: identical, or identical but for
    numbers within `RTOL`."""
    if text == golden:
        return True
    if NUMBER.sub("#", text) != NUMBER.sub("#", golden):
        return False
    a = np.array([float(x) for x in NUMBER.findall(text)])
    b = np.array([float(x) for x in NUMBER.findall(golden)])
    return bool(np.all(np.abs(a - b) <= RTOL * np.abs(b)))


if __name__ == "__main__":
    tests = Path(__file__).resolve().parents[2]
    sys.path[:0] = [str(tests.parent)]                  # the project before tests/nlid_lab
    sys.path += [str(tests), str(Path(__file__).parent)]
    GOLDEN.mkdir(exist_ok=True)
    for case in sys.argv[1:] or CASES:
        with tempfile.TemporaryDirectory() as tmp:
            (GOLDEN / f"{case}.json").write_text(without_added_keys(
                run_case(case, Path(tmp))))
        print("wrote", GOLDEN / f"{case}.json")
