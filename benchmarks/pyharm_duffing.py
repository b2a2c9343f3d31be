"""pyHarm's arc length on case 4 of `bench_hbm.py` (run by ``bench_hbm.py --pyharm PYTHON``).

Runs in an environment that has pyHarm (``pip install pyHarm-os``; not a dependency of this
project, which is why it is a script of its own): the 1 N Duffing oscillator (m 1 kg, c 2 N s/m,
k 1e4 N/m, cubic 1e8 N/m^3) from 12 to 22 Hz by `pyHarm.Maestro` (``frf`` study, tangent
predictor, arc-length corrector, acceptance step sizer). Prints one JSON line: points, the best
wall-clock, thread and process CPU seconds of ``--repeats`` whole runs (set-up included, as
`continue_frf` includes its own) and the frequencies where the branch turns (its folds).

    PYTHON benchmarks/pyharm_duffing.py [--nh 5] [--nti 64] [--ds0 0.5] [--ds-max 2.0]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from pyHarm.Maestro import Maestro


def problem(nh: int, nti: int, ds0: float, ds_max: float) -> dict:
    """pyHarm's input dictionary of the Duffing curve (frequencies in rad/s)."""
    study = {"study": "frf", "puls_inf": 2 * np.pi * 12.0, "puls_sup": 2 * np.pi * 22.0,
             "ds0": ds0, "ds_min": 1e-8, "ds_max": ds_max, "sign_ds": 1, "verbose": False,
             "stepsizer": "acceptance", "predictor": "tangent", "corrector": "arc_length",
             "stopper": "bounds"}
    linear = {"M": np.array([1.0]), "C": np.array([2.0]), "K": np.array([1e4]),
              "G": np.array([0.0])}
    return {"analysis": {"frf": study},
            "system": {"type": "Base", "nh": nh, "nti": nti,
                       "adim": {"status": False, "lc": 1.0, "wc": 1.0}},
            "substructures": {"duffing": {"matrix": linear, "ndofs": 1}},
            "connectors": {
                "loading": {"type": "CosinusForcing", "connect": {"duffing": [0]},
                            "dirs": [0], "amp": 1.0},
                "cubic": {"type": "CubicSpring", "connect": {"duffing": [0]}, "dirs": [0],
                          "k": 1e8}}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nh", type=int, default=5, help="harmonics 0..nh")
    parser.add_argument("--nti", type=int, default=64, help="AFT samples per period")
    parser.add_argument("--ds0", type=float, default=0.5)
    parser.add_argument("--ds-max", type=float, default=2.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    wall, cpu, process = [], [], []
    for _ in range(args.repeats):
        t0, c0, p0 = time.perf_counter(), time.thread_time(), time.process_time()
        run = Maestro(problem(args.nh, args.nti, args.ds0, args.ds_max))
        run.operate()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
        process.append(time.process_time() - p0)
    accepted = [s for s in run.nls["frf"].SolList if s.flag_accepted]
    f = np.array([s.x[-1] for s in accepted]) / (2 * np.pi)
    turn = np.flatnonzero(np.diff(np.sign(np.diff(f))) != 0) + 1
    print(json.dumps({"points": int(f.size), "wall": min(wall), "cpu": min(cpu),
                      "process": min(process), "folds": f[turn].tolist()}))


if __name__ == "__main__":
    main()
