"""Helpers of the malformed-input property tests (tests/nlid_lab/test_input_validation.py).

A mutation replaces, deletes or misspells one entry of a valid input document. Mutations that
break a documented rule are tagged *invalid*: the command must refuse them (exit 2). The
others may be accepted or refused, but only with exit 0 or 2 and one line on stderr.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import signal
import tomllib
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from hypothesis import strategies as st

from analysis.models import MAX_ENTRY, MAX_PARAM
from nlid_lab.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

#: values that no numeric, string or table entry of our formats accepts as given
BAD_VALUES = ["1e4", True, False, [], [True], [["1"]], {"a": 1.0}, "", float("nan"),
              float("inf"), -float("inf")]
#: numbers that are of the right type but may be out of the physical range
EDGE_NUMBERS = [0, 0.0, -1.0, 1, 2**63 - 1, -(2**63), 1e308, -1e308, 1e-300, 1e-12, 1e15,
                1e16, 3.5, 500]


# --- the valid documents the mutations start from, and their documented ranges -----------
MODEL = {
    "name": "two dof",
    "linear": {"mass": [[1.0, 0.0], [0.0, 2.0]], "damping": [[20.0, -10.0], [-10.0, 20.0]],
               "stiffness": [[2e4, -1e4], [-1e4, 2e4]]},
    "element": [{"kind": "cubic_spring", "w": [1.0, 0.0], "p": 1e9},
                {"kind": "gap", "w": [-1.0, 1.0], "k": 1e4, "g": 1e-3},
                {"kind": "hysteresis", "w": [0.0, 1.0], "kd": 1e4, "fd": 2.0, "n": 2.0},
                {"kind": "coulomb_friction", "w": [0.0, 1.0], "fc": 0.5, "v_reg": 1e-2}],
}
POSITIVE = {"g", "k", "kd", "fd", "n", "v_reg"}


def model_number_invalid(path: tuple, value: float) -> bool:
    """Numbers that break a rule of docs/model-format.md for certain in `MODEL`."""
    if path[0] == "linear":
        matrix, r, c = path[1], path[2], path[3]
        old = MODEL["linear"][matrix][r][c]
        return (abs(value) > MAX_ENTRY or (r != c and abs(value - old) > 1e-6)
                or (r == c and value < 0) or (matrix == "mass" and r == c and value < 1e-6))
    if path[2] == "w":
        return abs(value) > MAX_ENTRY
    return abs(value) > MAX_PARAM or (path[2] in POSITIVE and value <= 0)


CAMPAIGN = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())
CAMPAIGN["plant"]["model"] = str(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")
NOT_NEGATIVE = {"fs", "levels", "averages", "block_size", "sensitivity", "shaker_gain",
                "noise_std", "gain_guess", "seed", "band", "x0"}
INTEGERS = {"averages", "block_size", "seed", "dof"}


def campaign_number_invalid(path: tuple, value: float) -> bool:
    """Numbers that break a rule of docs/campaign-format.md for certain."""
    key = next(k for k in reversed(path) if isinstance(k, str))
    return ((key in NOT_NEGATIVE and value < 0) or (key in INTEGERS and value == 3.5)
            or (key == "fs" and value > 1e6) or (key == "averages" and value > 100000)
            or (key == "levels" and value == 0))


def bad_arrays(value: np.ndarray) -> dict[str, tuple[np.ndarray, bool]]:
    """Replacements of one NPZ entry, and whether each breaks a documented rule for sure."""
    arr = np.asarray(value)
    return {"complex": (arr + 1j, True), "text": (np.full(arr.shape, "abc"), True),
            "bool": (arr != 0, True), "nan": (np.full(arr.shape, np.nan), True),
            "huge": (np.full(arr.shape, 1e300), True), "tiny": (arr * 1e-300, False),
            "negative": (-np.abs(arr) - 1, False), "empty": (arr.reshape(-1)[:0], True),
            "first sample": (arr[..., :1, :] if arr.ndim >= 2 else arr, arr.ndim >= 2),
            "transposed": (arr.T, False), "zeros": (np.zeros_like(arr), False)}


class TimeLimit(Exception):
    """A command ran past the test's time bound."""


@contextlib.contextmanager
def time_limit(seconds: float):
    """Raise `TimeLimit` in the main thread after ``seconds`` (SIGALRM)."""
    def alarm(*_: Any) -> None:
        raise TimeLimit(f"no answer within {seconds} s")
    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def run_cli(argv: list[str], seconds: float = 60.0) -> tuple[int, str, str]:
    """Exit code, stderr and stdout of ``nlid-lab argv`` run in this process within
    ``seconds``."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out), time_limit(seconds), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code if isinstance(exc.code, int) else 1
    # the terminal would show each warning (two lines) before the command's own output
    shown = "".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno)
                    for w in caught)
    return code, shown + err.getvalue(), out.getvalue()


def check_outcome(code: int, err: str, invalid: bool, what: str) -> None:
    """The contract: success, or exit 2 with one line and no traceback; invalid -> exit 2."""
    assert "Traceback" not in err, f"{what}: traceback\n{err}"
    if invalid:
        assert code == 2, f"{what}: invalid input accepted (exit {code})\n{err}"
    assert code in (0, 2), f"{what}: exit {code}\n{err}"
    if code == 2:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1, f"{what}: {len(lines)} lines on stderr\n{err}"


# --- mutations of a nested document (dicts and lists) -------------------------------------
def paths(doc: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path to a value in ``doc`` (dict keys and list indices), leaves and tables."""
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) \
        if isinstance(doc, list) else []
    for key, value in items:
        out.append(prefix + (key,))
        out += paths(value, prefix + (key,))
    return out


def _parent(doc: Any, path: tuple) -> Any:
    for key in path[:-1]:
        doc = doc[key]
    return doc


def typo(word: str, i: int) -> str:
    """``word`` with one letter dropped (or one added when it is a single letter)."""
    return word + "x" if len(word) < 2 else word[:i % len(word)] + word[i % len(word) + 1:]


@st.composite
def mutations(draw, base: dict, invalid_numbers: callable) -> tuple[dict, str, bool]:
    """A copy of ``base`` with one mutation, its description, and whether it is invalid.

    ``invalid_numbers(path, value)`` says whether a number at ``path`` breaks a documented
    range (the format's own oracle, written from its docs).
    """
    doc = json.loads(json.dumps(base))
    path = draw(st.sampled_from(paths(doc)))
    parent, key = _parent(doc, path), path[-1]
    action = draw(st.sampled_from(["bad", "number", "typo", "extra"]))
    if action == "typo" and isinstance(key, str):
        new = typo(key, draw(st.integers(0, 20)))
        parent[new] = parent.pop(key)
        return doc, f"{path}: key renamed to {new!r}", True
    if action == "extra" and isinstance(parent, dict):
        parent["colour"] = 1.0
        return doc, f"{path[:-1]}: extra key 'colour'", True
    if action == "number" and isinstance(parent[key], (int, float)) \
            and not isinstance(parent[key], bool):
        value = draw(st.sampled_from(EDGE_NUMBERS))
        parent[key] = value
        return doc, f"{path} = {value!r}", invalid_numbers(path, value)
    value, old = draw(st.sampled_from(BAD_VALUES)), parent[key]
    # another string, or an empty list (a model without elements), may be allowed: no verdict
    undetermined = (isinstance(value, str) and isinstance(old, str)) or (
        value == [] and isinstance(old, list))
    parent[key] = value
    return doc, f"{path} = {value!r}", not undetermined


# --- a small TOML writer (inline tables: enough for any mutated document) -----------------
def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"


def toml_text(doc: dict) -> str:
    return "".join(f"{json.dumps(k)} = {toml_value(v)}\n" for k, v in doc.items())
