"""Shared test configuration."""

import hashlib
import os
import pickle
import sys
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("MPLBACKEND", "Agg")


# test modules import each other and the shared scenarios by name, as when
# tests/ was one flat folder: every folder of tests/ is importable (appended, so nothing in it
# shadows an installed module; test file names are unique).
for _folder in sorted({str(p.parent) for p in Path(__file__).parent.rglob("test_*.py")}):
    if _folder not in sys.path:
        sys.path.append(_folder)


_DIAGNOSES: dict[str, object] = {}


@pytest.fixture
def diagnose_once(monkeypatch):
    """`analysis.diagnose.diagnose` computed once per distinct input in this process: tests
    calling ``nlid-lab diagnose`` several times on the same runs (printing modes, ``--store``)
    pay for one diagnosis. The key hashes every argument but the progress callback (the
    model and the recordings as loaded, metadata included), so any other input computes
    afresh; the result is frozen, so sharing it changes nothing a test sees."""
    import analysis.diagnose as room
    import nlid_lab.commands.diagnose as command

    real = room.diagnose

    def once(model, recordings, **options):
        given = {k: v for k, v in options.items() if k != "progress"}
        key = hashlib.sha256(pickle.dumps((model, recordings, given))).hexdigest()
        if key not in _DIAGNOSES:
            _DIAGNOSES[key] = real(model, recordings, **options)
        return _DIAGNOSES[key]

    monkeypatch.setattr(room, "diagnose", once)
    if hasattr(command, "diagnose"):
        monkeypatch.setattr(command, "diagnose", once)


# NLID_TEST_CPU=FILE appends each test's CPU seconds (this process and the subprocesses it
# waited for) and wall seconds to FILE: durations that hold on a shared machine, where
# pytest's --durations (wall clock) grow with the other jobs' load.
if os.environ.get("NLID_TEST_CPU"):
    import time

    def _cpu() -> float:
        t = os.times()
        return t.user + t.system + t.children_user + t.children_system

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        c0, t0 = _cpu(), time.perf_counter()
        yield
        with open(os.environ["NLID_TEST_CPU"], "a") as fh:
            fh.write(f"{_cpu() - c0:.3f} {time.perf_counter() - t0:.3f} {item.nodeid}\n")
