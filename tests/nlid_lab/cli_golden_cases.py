"""The ``--json`` outputs of `simulate`, `analyze reverse-path`, `analyze hbm`, `backbone` and
`predict` on small fixtures, kept as golden files in ``tests/data/cli_golden/<case>.json``
(`detect` and `fit-linear` have theirs in `test_result_json`, `diagnose` in
``tests/analysis/diagnose/golden_cases.py``).

The goldens were written by main (df3bb52) before the results became typed; the test proves
every command's JSON unchanged but for added ``schema_version`` keys. The fixtures' folder is
written ``<root>`` in the text (the runs' paths appear in it), the project's ``<project>``
(the model's path). Regenerate only from a commit
whose output is the reference::

    .venv/bin/python tests/nlid_lab/cli_golden_cases.py
"""

from __future__ import annotations

import json
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

PROJECT = Path(__file__).resolve().parents[2]
GOLDEN = PROJECT / "tests" / "data" / "cli_golden"
SDOF = PROJECT / "examples" / "models" / "sdof-cubic-quaddamp.toml"
CANDIDATE = PROJECT / "examples" / "candidates" / "sdof-candidate.toml"
FS = 1024.0


def _drives(root: Path) -> None:
    """A random drive (two levels) and a stepped-sine drive (two levels) of the SDOF example."""
    rng = np.random.default_rng(0)
    white = rng.normal(size=(8192, 1))
    for name, rms in (("random5", 5.0), ("random20", 20.0)):
        np.savez(root / f"drive-{name}.npz", fs=FS, force=rms * white, force_dofs=[0],
                 force_rms=rms)
    freqs = np.linspace(40.0, 60.0, 9)
    t = np.arange(2048) / FS
    for name, amp in (("stepped2", 2.0), ("stepped8", 8.0)):
        np.savez(root / f"drive-{name}.npz", fs=FS, force_dofs=[0], freqs=freqs,
                 force=np.stack([amp * np.sin(2 * np.pi * f * t)[:, None] for f in freqs]),
                 force_amplitude=amp)


def _simulated(root: Path) -> None:
    """The runs the analysis cases read, written by `simulate` (its cases, with their JSON)."""
    import contextlib
    import io
    from nlid_lab.cli import main
    for name, out in (("random5", "random5.h5"), ("random20", "random20.h5"),
                      ("stepped2", "stepped2.npz"), ("stepped8", "stepped8.npz")):
        argv = ["simulate", str(SDOF), "--drive", str(root / f"drive-{name}.npz"), "--out",
                str(root / out), "--noise", "1e-6", "--seed", "4",
                "--json", str(root / f"simulate-{name}.json")]
        with contextlib.redirect_stdout(io.StringIO()):      # simulate has no --quiet
            assert main(argv) == 0, name


CASES: dict[str, list[str]] = {
    "simulate-random": [],                      # written by `_simulated`
    "simulate-stepped": [],
    "analyze-reverse-path": ["analyze", "reverse-path", "{root}/random5.h5",
                             "{root}/random20.h5", "--model", str(CANDIDATE)],
    "analyze-hbm": ["analyze", "hbm", "{root}/stepped2.npz", "{root}/stepped8.npz",
                    "--model", str(CANDIDATE)],
    "backbone": ["backbone", "{root}/stepped2.npz", "{root}/stepped8.npz"],
    "backbone-model": ["backbone", "{root}/stepped2.npz", "{root}/stepped8.npz",
                       "--model", str(SDOF)],
    "predict": ["predict", str(SDOF), "--amplitude", "1", "4", "--band", "30", "60",
                "--step", "0.5"],
}
"""Case name -> the command line (``{root}``: the fixtures' folder)."""


def outputs(root: Path) -> dict[str, str]:
    """The JSON text of every case, the fixtures' folder written ``<root>``, the project's
    ``<project>``."""
    from nlid_lab.cli import main
    root.mkdir(parents=True, exist_ok=True)
    _drives(root)
    _simulated(root)
    texts = {"simulate-random": (root / "simulate-random20.json").read_text(),
             "simulate-stepped": (root / "simulate-stepped8.json").read_text()}
    for name, argv in CASES.items():
        if argv:
            dest = root / f"{name}.json"
            argv = [a.replace("{root}", str(root)) for a in argv]
            assert main([*argv, "--json", str(dest), "--quiet"]) == 0, name
            texts[name] = dest.read_text()
    return {name: text.replace(str(root), "<root>").replace(str(PROJECT), "<project>")
            for name, text in texts.items()}


def without_schema_versions(text: str) -> str:
    """The JSON text without its ``schema_version`` keys (at any depth), in the command's own
    formatting, so it compares byte for byte with a golden file."""
    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if k != "schema_version"}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value
    return json.dumps(strip(json.loads(text)), indent=2, allow_nan=False) + "\n"


NUMBER = re.compile(r"-?\d+\.\d+(?:[eE][-+]?\d+)?|-?\d+[eE][-+]?\d+")


if __name__ == "__main__":
    sys.path[:0] = [str(PROJECT)]
    sys.path.append(str(PROJECT / "tests"))
    GOLDEN.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for case, text in outputs(Path(tmp)).items():
            (GOLDEN / f"{case}.json").write_text(without_schema_versions(text))
            print("wrote", GOLDEN / f"{case}.json")
