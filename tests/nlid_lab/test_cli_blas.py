"""The CLI runs BLAS on one thread unless the environment sets its threads (`nlid_lab.cli`)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_info

from nlid_lab import cli

ROOT = Path(__file__).resolve().parents[2]

# a command that loads scipy's BLAS inside `main` and prints the threads of every BLAS library
PROBE = """
import argparse, json, sys
from nlid_lab import cli

def probe(args):
    import scipy.linalg
    from threadpoolctl import threadpool_info
    scipy.linalg.expm(scipy.linalg.hilbert(3))
    print(json.dumps([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]))

def parser():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="command")
    sub.add_parser("probe").set_defaults(func=probe)
    return p

cli.build_parser = parser
sys.exit(cli.main(["probe"]))
"""


def _blas_threads() -> list[int]:
    np.linalg.inv(np.eye(3))        # numpy's BLAS is loaded
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]


@pytest.fixture
def no_blas_variables(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in cli.BLAS_THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def test_one_thread_inside_then_restored(no_blas_variables: None) -> None:
    before = _blas_threads()
    with cli.blas_threads():
        assert _blas_threads() == [1] * len(before)
        assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    assert _blas_threads() == before
    assert "OPENBLAS_NUM_THREADS" not in os.environ


def test_a_set_variable_is_respected(no_blas_variables: None,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    before = _blas_threads()
    with cli.blas_threads():
        assert _blas_threads() == before
        assert "OPENBLAS_NUM_THREADS" not in os.environ


@pytest.mark.parametrize("env, expected", [({}, 1), ({"OPENBLAS_NUM_THREADS": "2"}, 2)])
def test_main_in_a_fresh_process(env: dict[str, str], expected: int) -> None:
    """`main` sets the limit before numpy and scipy load their BLAS (both libraries then run
    on one thread), and a user's ``OPENBLAS_NUM_THREADS`` wins."""
    base = {k: v for k, v in os.environ.items() if k not in cli.BLAS_THREAD_VARIABLES}
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, env={**base, **env},
                         capture_output=True, text=True, check=True, timeout=120)
    threads = json.loads(out.stdout.strip().splitlines()[-1])
    assert threads and all(t == expected for t in threads), threads
