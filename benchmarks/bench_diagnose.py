"""Benchmark: ``nlid-lab diagnose`` on a 3-DOF, 3-level random case (issue 6: under a minute)
and on the jointed GVT-like case (``--case jointed``: fit-linear on the lowest of five
multisine levels, then the diagnosis of a friction joint between two accelerometers; issue 15:
under a minute) and on the F-16-like GVT twin (``--case f16``: the seven per-level MAT
exports of `tests/f16_twin.py` imported, fit-linear on the lowest level, diagnose; F-16 layout:
8192-sample periods, 9 periods with the first transient; ``--period 4096 --periods 4`` for the
reduced twin of the default tests).

Prints the wall time of the whole command (NPZ loading, search of the full candidate library,
reverse-path refinement, second search pass on the corrected model, held-back comparison,
short-horizon replays of every level through both models, JSON and corrected model) and its ratio to a
baseline timed in the same run: one reverse-path estimate of the true element on the same
three recordings. Run: ``.venv/bin/python benchmarks/bench_diagnose.py``.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"),
                *sorted({str(p.parent) for p in (ROOT / "tests").rglob("test_*.py")})]

from analysis.diagnose import library  # noqa: E402
from analysis.models import Element  # noqa: E402
from analysis.reverse_path import reverse_path  # noqa: E402
from diagnose_scenarios import hidden_cubic  # noqa: E402
from nlid_lab.cli import main  # noqa: E402
from nlid_lab.formats import write_npz  # noqa: E402

BUDGET_S = 60.0


def run() -> None:
    sc = hidden_cubic()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        sc.start.save(root / "start.toml")
        runs = []
        for i, rec in enumerate(sc.recordings):
            write_npz(root / f"level{i}.npz", rec)
            runs.append(str(root / f"level{i}.npz"))
        cand = sc.start.with_elements([Element("cubic_spring", [0, 0, 1.0], {})])
        reverse_path(sc.recordings[:1], cand)            # warm numba caches for both
        t0 = time.perf_counter()
        reverse_path(sc.recordings, cand)
        base = time.perf_counter() - t0
        t0 = time.perf_counter()
        rc = main(["diagnose", str(root / "start.toml"), *runs, "--json",
                   str(root / "out.json"), "--model-out", str(root / "fixed.toml")])
        total = time.perf_counter() - t0
        res = json.loads((root / "out.json").read_text())
    n = sc.recordings[0].force.shape[0]
    print(f"case: 3 DOF, 3 levels x {n} samples, library of {len(library(3))} candidates; "
          f"exit code {rc}")
    print(f"baseline  one reverse-path estimate (3 levels): {base:8.2f} s")
    print(f"diagnose  full command:                         {total:8.2f} s")
    print(f"ratio     diagnose / reverse path:              {total / base:8.1f}")
    print(f"budget    {BUDGET_S:.0f} s: {'met' if total < BUDGET_S else 'MISSED'} "
          f"({total / BUDGET_S:.2f} of it)")
    tr = res["fit"]["time_residual"]
    print(f"result    {res['verdict']}: {res['missing_physics'][0]['kind']} at "
          f"{res['location']['dofs']}, FRF error {res['fit']['before']:.3g} -> "
          f"{res['fit']['after']:.3g}, time residual {tr['before']:.3g} -> {tr['after']:.3g}, "
          f"{len(res['evidence']['passes'])} search passes")


def run_jointed() -> None:
    """fit-linear + diagnose on `gvt_scenarios.friction_joint`; baseline: fit-linear alone."""
    from analysis.modal import fit_linear
    from gvt_scenarios import BAND, NAMES, runs, fe_w, JOINT_K
    from structures import beam_with_payload
    beam = beam_with_payload()
    recs = runs(beam, [Element("stick_slip", fe_w(beam, "joint", "payload"),
                               {"kd": 0.5 * JOINT_K, "fd": 2.0})])
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        paths = []
        for i, rec in enumerate(recs):
            write_npz(root / f"level{i}.npz", rec)
            paths.append(str(root / f"level{i}.npz"))
        fit_linear(recs[0], BAND, points=NAMES)              # warm caches
        t0 = time.perf_counter()
        fit_linear(recs[0], BAND, points=NAMES)
        base = time.perf_counter() - t0
        t0 = time.perf_counter()
        rc1 = main(["fit-linear", paths[0], "--out", str(root / "gvt.toml"), "--band",
                    *map(str, BAND), "--points", ",".join(NAMES), "--quiet"])
        rc2 = main(["diagnose", str(root / "gvt.toml"), *paths, "--band", *map(str, BAND),
                    "--json", str(root / "out.json"), "--model-out", str(root / "fixed.toml"),
                    "--quiet"])
        total = time.perf_counter() - t0
        res = json.loads((root / "out.json").read_text())
    m = res["missing_physics"][0] if res["missing_physics"] else {}
    print(f"case: 21-DOF FE beam + jointed payload, 4 accelerometers, 5 multisine levels; "
          f"exit codes {rc1}, {rc2}")
    print(f"baseline  fit-linear on the lowest level:       {base:8.2f} s")
    print(f"commands  fit-linear + diagnose:                {total:8.2f} s")
    print(f"ratio     commands / fit-linear:                {total / base:8.1f}")
    print(f"budget    {BUDGET_S:.0f} s: {'met' if total < BUDGET_S else 'MISSED'} "
          f"({total / BUDGET_S:.2f} of it)")
    print(f"result    {res['verdict']}: {m.get('kind')} at {m.get('dofs')} {m.get('params')}, "
          f"held-back FRF error {res['fit']['before']:.3g} -> {res['fit']['after']:.3g}")


def run_f16(period: int, periods: int) -> None:
    """import + fit-linear + diagnose on the F-16-like twin's MAT exports, each step timed."""
    import os

    import f16_twin as T
    t0 = time.perf_counter()
    twin = T.twin(True, period, periods)
    t_sim = time.perf_counter() - t0
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        files = sorted(map(str, T.export_mat(twin, root)))
        run, lin = str(root / "run.h5"), str(root / "linear.toml")
        steps = {"import": ["import", *files, "--out", run, "--map", "force=Force",
                            "response=Acceleration[0:3]:m/s^2", "fs=Fs", "force_dofs=0",
                            'force_hold="none"'],            # the period found in the force
                 "fit-linear": ["fit-linear", run, "--out", lin, "--band", "2", "15",
                                "--points", "wing_drive,wing_joint,payload", "--json",
                                str(root / "fit.json")],
                 "diagnose": ["diagnose", lin, run, "--json", str(root / "d.json"),
                              "--model-out", str(root / "fixed.toml")]}
        took, codes = {}, {}
        for name, argv in steps.items():
            t0 = time.perf_counter()
            codes[name] = main(argv if name == "import" else [*argv, "--quiet"])
            took[name] = time.perf_counter() - t0
        res = json.loads((root / "d.json").read_text())
        fit = json.loads((root / "fit.json").read_text())
    load1 = os.getloadavg()
    total = took["fit-linear"] + took["diagnose"]
    m = res["missing_physics"][0] if res["missing_physics"] else {}
    held = [lv for lv in res["fit"]["levels"] if lv["held_back"]]
    print(f"case: F-16-like twin (11 DOF + shaker, Iwan-like joint), 7 MAT levels x "
          f"{period} x (1 + {periods}) samples, 3 accelerometers; exit codes "
          f"{', '.join(f'{k} {v}' for k, v in codes.items())}")
    print(f"simulate  the twin (not timed below):            {t_sim:8.2f} s")
    for name in steps:
        print(f"{name:<9} command:                               {took[name]:8.2f} s")
    print(f"total     fit-linear + diagnose:                 {total:8.2f} s")
    print(f"budget    {BUDGET_S:.0f} s: {'met' if total < BUDGET_S else 'MISSED'} "
          f"({total / BUDGET_S:.2f} of it); load average {load0[0]:.1f} before, "
          f"{load1[0]:.1f} after, {os.cpu_count()} cores")
    print(f"fit       {len(fit['modes'])} modes: "
          + ", ".join(f"{md['freq_hz']:.3f}" for md in fit["modes"]) + " Hz")
    print(f"result    {res['verdict']}: {m.get('kind')} between {m.get('points')}, held-back "
          f"FRF error {res['fit']['before']:.3g} -> {res['fit']['after']:.3g} ("
          + ", ".join(f"{lv['before']:.3g} -> {lv['after']:.3g}" for lv in held) + ")")


if __name__ == "__main__":
    case = sys.argv[sys.argv.index("--case") + 1] if "--case" in sys.argv else "cubic"
    if case == "jointed":
        run_jointed()
    elif case == "f16":
        def opt(name: str, default: int) -> int:
            return int(sys.argv[sys.argv.index(name) + 1]) if name in sys.argv else default
        run_f16(opt("--period", 8192), opt("--periods", 8))
    else:
        run()
