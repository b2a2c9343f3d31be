"""`backbone --model` holding the measured amplitudes (`analysis.backbone.model_tables`): the
model through its own response-controlled tables, timed against a base commit in the same run
(`benchmarks/_compare.py`, alternating subprocesses, best of each).

1. ``friction_twin``: the Jenkins SDOF twin of tests/analysis/backbone (kd 1.25e4, fd 0.5) as
   a stick-slip model, held at 10, 60 and 250 um over +-1 Hz (40 steps each), harmonics
   1,3,5,7: the softening case the secant handled before.
2. ``iwan_beam``: examples/models/sdof-iwan-beam.toml held at 4, 20 and 80 um over
   76-81 Hz (101 steps each), harmonics 1,3,5,7.
3. ``stiffening``: the gap mode of the same tests (5 levels x 240 steps, one harmonic),
   whose middle branch the secant did not reach (held steps off are printed).

    python benchmarks/bench_backbone_hold.py [--base REF | --no-compare]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _compare import add_options, compare, project_root, search_path  # noqa: E402

ROOT = project_root(__file__)
sys.path[:0] = search_path(ROOT)

from analysis.backbone import model_tables  # noqa: E402
from analysis.models import Element, Model  # noqa: E402
from analysis.recordings import StepTable  # noqa: E402
from test_backbone import C, GAP, K, TWIN, gap_tables, held_displacement  # noqa: E402


def friction_twin() -> Callable[[], object]:
    model = Model(np.eye(1), np.array([[TWIN.c]]), np.array([[TWIN.k]]),
                  [Element("stick_slip", np.array([1.0]), {"kd": TWIN.kd, "fd": TWIN.fd})])
    tables = [held_displacement(a) for a in (1e-5, 6e-5, 2.5e-4)]
    return lambda: model_tables(model, tables)


IWAN_LEVELS = (4e-6, 2e-5, 8e-5)


def iwan_tables() -> list:
    """Held displacements of the Iwan beam mode (the forces are the model's to find)."""
    f = np.arange(76.0, 81.0001, 0.05)
    return [StepTable(f, np.ones((f.size, 1), complex), np.full((f.size, 1), a + 0j), [0],
                      "response", a, control_dof=0) for a in IWAN_LEVELS]


def iwan_beam() -> Callable[[], object]:
    model = Model.load(ROOT / "examples" / "models" / "sdof-iwan-beam.toml")
    tables = iwan_tables()
    return lambda: model_tables(model, tables)


def stiffening() -> Callable[[], object]:
    model = Model(np.eye(1), np.array([[C]]), np.array([[K]]),
                  [Element("gap", np.array([1.0]), GAP)])
    tables = gap_tables()
    return lambda: model_tables(model, tables, harmonics=(1,))


def held_error(case: Callable[[], Callable[[], object]], tables: list) -> np.ndarray:
    """Relative amplitude error of every held step (a step the balance did not converge at,
    left out of the model's table: infinite)."""
    sim = case()()
    out = []
    for t, s in zip(tables, sim.tables):
        err, kept = np.full(t.freqs.size, np.inf), np.isin(t.freqs, s.freqs)
        err[kept] = np.abs(np.abs(s.response_phasor[:, 0]) / np.abs(t.response_phasor[kept, 0])
                           - 1)
        out.append(err)
    return np.concatenate(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_options(parser)
    args = parser.parse_args()
    for name, case, tables in (
            ("friction_twin", friction_twin, [held_displacement(a) for a in (1e-5, 6e-5, 2.5e-4)]),
            ("iwan_beam", iwan_beam, iwan_tables()),
            ("stiffening", stiffening, gap_tables())):
        err = held_error(case, tables)
        print(f"{name}: {err.size} held steps, {np.sum(err > 1e-5)} off by more than 1e-5, "
              f"largest relative error {err.max():.2e}")
    if not args.no_compare:
        compare([f"bench_backbone_hold:{c}" for c in ("friction_twin", "iwan_beam",
                                                      "stiffening")], args.base)


if __name__ == "__main__":
    main()
