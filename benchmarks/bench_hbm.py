"""Harmonic-balance speed and the paper's Table 4.1 fit, in one run.

1. One analytical FRF: SDOF Jenkins (examples/models/sdof-stick-slip.toml), harmonics 1,3,5,7,
   200 frequencies, by `analysis.hbm._hbm` (target <= 50 ms).
2. The same FRF by time-domain stepped-sine simulation on `analysis.plant.Plant` (phase-
   continuous up-sweep, settle and measure cycles, sine fit), timed in the same run: the ratio
   (target >= 100x; the simulation alone is timed, not its sine fits). Fairness: both are
   compared with a finely resolved balance (odd orders to 31, 2048 samples per period) at the
   same frequencies; the time-domain FRF is repeated with twice the settle cycles (it has
   settled) and timed once more at twice the sample rate with half the settle cycles, which
   reaches the accuracy of the HBM (at 16384 Hz the stick-slip transition is 0.6 % off).
3. The full Table 4.1 fit: six levels 1 N .. 1 kN x 27 steps, 10 % noise on every response
   block, eq 34 hysteresis (kd, fd, n) by the default least squares with multi-start
   (target <= 10 s), errors against the reference kd, fd, the n reached and every start.
4. Continuation of the 1 N Duffing curve through its folds (`duffing_system`: m 1 kg, c 2 N s/m,
   k 1e4 N/m, cubic 1e8 N/m^3, harmonics 1,3,5, 12 -> 22 Hz, ~630 points, two folds; target
   <= 254 ms, its time before the ``[modal]`` form made `linear_frf` slower).
5. This tree against a base commit (default HEAD~1) in the same run (`benchmarks/_compare.py`):
   the continuation and the FRF of 1., alternately in subprocesses, best of each.
6. With ``--pyharm PYTHON`` (an interpreter that has pyHarm, ``pip install pyHarm-os``; not a
   dependency): the curve of 4. by pyHarm's arc length (`pyharm_duffing.py`, in a subprocess)
   and by `continue_frf` at several step limits, alternately, with each one's fold error
   against a finely stepped `continue_frf` (``max_step`` 0.01): time at equal accuracy.

    python benchmarks/bench_hbm.py [--level 100] [--settle-cycles 150] [--fs 16384] [--starts 4]
                                   [--base REF | --no-compare] [--pyharm PYTHON [--only-pyharm]]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _compare import add_options, compare, project_root, search_path  # noqa: E402

ROOT = project_root(__file__)
sys.path[:0] = search_path(ROOT)

from analysis.hbm import HBMSystem  # noqa: E402
from analysis.hbm import continue_frf, fit_hbm  # noqa: E402
from analysis.models import Element, Model  # noqa: E402
from analysis.spectral import stepped_sine_frf  # noqa: E402
from test_hbm_fit import FD, KD, candidate, simulate_levels  # noqa: E402


def best_of(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def _thread_time(fn) -> float:
    """CPU seconds of this thread in one call of ``fn`` (what it costs on a shared machine)."""
    c0 = time.thread_time()
    fn()
    return time.thread_time() - c0


def duffing_system() -> HBMSystem:
    """The Duffing oscillator of case 4 at harmonics 1, 3, 5."""
    model = Model([[1.0]], [[2.0]], [[1e4]], [Element("cubic_spring", [1.0], {"p": 1e8})])
    return HBMSystem(model, [0], (1, 3, 5))


def continuation():
    """Case 4 for `compare`: the 1 N curve from 12 to 22 Hz through its two folds."""
    system = duffing_system()
    return lambda: continue_frf(system, 12.0, 22.0, 1.0)


def receptance():
    """For `compare`: the linear receptance of the modal example, one call per frequency at
    200 frequencies (how a continuation calls it); numpy only, nothing to compile."""
    model = Model.load(ROOT / "examples" / "models" / "beam-payload-modal.toml")
    freqs = np.linspace(1.0, 100.0, 200)
    return lambda: [model.linear_frf([f]) for f in freqs]


def frf_sweep():
    """Case 1 for `compare`: the SDOF Jenkins FRF, 200 frequencies at 100 N."""
    model = Model.load(ROOT / "examples" / "models" / "sdof-stick-slip.toml")
    system = HBMSystem(model, [0], (1, 3, 5, 7))
    freqs = np.linspace(50.0, 350.0, 200)
    return lambda: system.sweep(freqs, 100.0)


def time_domain_case(args: argparse.Namespace, model: Model, freqs: np.ndarray, t_hbm: float,
                     h_hbm: np.ndarray) -> None:
    """Case 2: the FRF of case 1 by time-domain stepped sine, timed and compared."""
    def simulate(settle, fs):
        """Time-domain FRF (simulation timed, not its sine fits: a conservative ratio)."""
        t0 = time.perf_counter()
        [rec] = simulate_levels(model, [args.level], freqs, noise=0.0, settle_cycles=settle,
                                measure_cycles=30, fs=fs)
        seconds = time.perf_counter() - t0
        hold = 1 - (np.pi * freqs / fs) ** 2 / 3          # first-order hold of the drive
        return stepped_sine_frf(rec, (1, 3, 5, 7)).frf[:, 0] / hold, seconds

    def spread(h, ref):
        d = np.abs(h / ref - 1)
        return (f"max {100 * d.max():.3f} % at {freqs[d.argmax()]:.1f} Hz, 95th percentile "
                f"{100 * np.percentile(d, 95):.3f} %, median {100 * np.median(d):.4f} %")

    for fs in (args.fs, 2 * args.fs):                         # JIT warm-up
        simulate_levels(model, [args.level], freqs[:2], noise=0.0, settle_cycles=2,
                        measure_cycles=2, fs=fs)
    h_ref = HBMSystem(model, [0], range(1, 32, 2), n_time=2048).sweep(
        freqs, args.level).frf(0, args.level)
    h_td, t_sim = simulate(args.settle_cycles, args.fs)
    h_long, _ = simulate(2 * args.settle_cycles, args.fs)
    h_eq, t_eq = simulate(args.settle_cycles / 2, 2 * args.fs)
    print("2. the same FRF by time-domain stepped sine (Plant, phase-continuous up-sweep, "
          "30 measured cycles per step), ratios timed in this run (target >= 100x):")
    print(f"   a. fs {args.fs:g} Hz, {args.settle_cycles:g} settle cycles: {t_sim:.2f} s, "
          f"ratio {t_sim / t_hbm:.0f}x")
    print(f"   b. fs {2 * args.fs:g} Hz, {args.settle_cycles / 2:g} settle cycles (the HBM's "
          f"accuracy): {t_eq:.2f} s, ratio {t_eq / t_hbm:.0f}x")
    print("   accuracy against H_ref, a balance with odd orders to 31 and 2048 samples per "
          "period (worst at the stick-to-slip transition):")
    print(f"   HBM [1 3 5 7]: {spread(h_hbm, h_ref)}")
    print(f"   time domain a: {spread(h_td, h_ref)}")
    print(f"   time domain b: {spread(h_eq, h_ref)}")
    print(f"   settling of a: {2 * args.settle_cycles:g} vs {args.settle_cycles:g} cycles differ "
          f"by {spread(h_long, h_td)}")


def continuation_case() -> None:
    """Case 4: the 1 N Duffing curve, best wall clock and thread CPU time of 5 calls."""
    run = continuation()
    run()                                                     # compile outside the timing
    t_cont, branch = best_of(run, 5)
    c_cont = min(_thread_time(run) for _ in range(5))
    print(f"4. continuation, 1 N Duffing (harmonics 1,3,5), 12 -> 22 Hz: {1e3 * t_cont:.0f} ms "
          f"(thread CPU {1e3 * c_cont:.0f} ms; target <= 254 ms), {branch.freqs.size} points, "
          f"folds at "
          + ", ".join(f"{f:.3f} Hz" for f in branch.freqs[branch.folds]))


def _fold_error(folds: np.ndarray, ref: np.ndarray) -> float:
    """Largest distance of the reference folds to the nearest fold found, Hz (inf if none)."""
    folds = np.asarray(folds, dtype=float)
    return float(max(np.abs(folds - r).min() for r in ref)) if folds.size else np.inf


def pyharm_case(python: str, rounds: int = 2) -> None:
    """Case 6: pyHarm's arc length against `continue_frf` on the curve of case 4."""
    system = duffing_system()
    fine = continue_frf(system, 12.0, 22.0, 1.0, max_step=0.01, max_points=20000)
    ref = fine.fold_freqs
    ours = {step: [] for step in (0.1, 0.3, 1.0)}
    theirs = {ds: [] for ds in (0.5, 2.0)}
    script = str(Path(__file__).resolve().parent / "pyharm_duffing.py")
    for _ in range(rounds):
        for step, times in ours.items():
            continue_frf(system, 12.0, 22.0, 1.0, max_step=step)      # compiled, warm
            c0 = time.thread_time()
            branch = continue_frf(system, 12.0, 22.0, 1.0, max_step=step)
            times.append((time.thread_time() - c0, branch.freqs.size,
                          _fold_error(branch.fold_freqs, ref),
                          _fold_error(branch.freqs[branch.folds], ref)))
        for ds, runs in theirs.items():
            with tempfile.TemporaryDirectory() as scratch:     # pyHarm writes a log folder
                out = subprocess.run([python, script, "--ds-max", str(ds), "--repeats", "2"],
                                     capture_output=True, text=True, check=True, cwd=scratch)
            res = json.loads(out.stdout.strip().splitlines()[-1])
            runs.append((res["cpu"], res["points"], _fold_error(res["folds"], ref)))
    print(f"6. the curve of 4. against pyHarm's arc length (same run, {rounds} rounds, best "
          f"thread CPU, set-up included; fold error: largest distance to the folds of "
          f"max_step 0.01, " + ", ".join(f"{f:.8f}" for f in ref) + " Hz; ours: "
          f"`Branch.fold_freqs`, in brackets its fold points; pyHarm: its turning points):")
    for step, table in ours.items():
        cpu, points, err, err_points = min(table)
        print(f"   continue_frf max_step {step:<6g} {points:4d} points, {1e3 * cpu:6.1f} ms, "
              f"fold error {err:.1e} Hz ({err_points:.1e})")
    for ds, table in theirs.items():
        cpu, points, err = min(table)
        print(f"   pyHarm ds_max {ds:<14g} {points:4d} points, {1e3 * cpu:6.1f} ms, "
              f"fold error {err:.1e} Hz")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", type=float, default=100.0, help="force amplitude, N")
    parser.add_argument("--settle-cycles", type=float, default=150.0)
    parser.add_argument("--fs", type=float, default=16384.0, help="time-domain sample rate")
    parser.add_argument("--starts", type=int, default=4)
    parser.add_argument("--pyharm", metavar="PYTHON",
                        help="interpreter with pyHarm installed: also run case 6")
    parser.add_argument("--only-pyharm", action="store_true", help="run case 6 alone")
    add_options(parser)
    args = parser.parse_args()
    if args.pyharm and args.only_pyharm:
        pyharm_case(args.pyharm)
        return
    model = Model.load(ROOT / "examples" / "models" / "sdof-stick-slip.toml")
    freqs = np.linspace(50.0, 350.0, 200)

    system = HBMSystem(model, [0], (1, 3, 5, 7))
    system.sweep(freqs[:3], args.level)                       # JIT warm-up
    t_hbm, res = best_of(lambda: system.sweep(freqs, args.level), 5)
    h_hbm = res.frf(0, args.level)
    print(f"1. analytical FRF, SDOF Jenkins, harmonics 1,3,5,7, {freqs.size} frequencies, "
          f"{args.level:g} N: {1e3 * t_hbm:.2f} ms (target <= 50 ms); "
          f"{res.iterations.mean():.2f} Newton evaluations per point, "
          f"{system.n_time} AFT samples per period, all converged: {res.converged.all()}")

    time_domain_case(args, model, freqs, t_hbm, h_hbm)

    levels_n = [1.0, 10.0, 30.0, 100.0, 300.0, 1000.0]
    recs = simulate_levels(model, levels_n, np.linspace(60.0, 320.0, 27), seed=1)
    levels = [stepped_sine_frf(r, (1, 3, 5, 7)) for r in recs]
    t0 = time.perf_counter()
    fit = fit_hbm(candidate(), levels, (1, 3, 5, 7), n_starts=args.starts)
    t_fit = time.perf_counter() - t0
    kd, fd, n = (fit.params[(0, k)] for k in ("kd", "fd", "n"))
    print(f"3. Table 4.1 fit, {len(levels)} levels x 27 steps, 10 % noise: {t_fit:.2f} s "
          f"(target <= 10 s), {fit.n_evaluations} HBM sweeps of all levels")
    print(f"   kd {kd:.5g} ({100 * (kd / KD - 1):+.3f} %), fd {fd:.5g} "
          f"({100 * (fd / FD - 1):+.3f} %), n {n:.4g}; cost (eq 33) {fit.cost:.4g}")
    for (e, name), (lo, hi) in fit.ci95.items():
        print(f"   95 % interval {name}: [{lo:.5g}, {hi:.5g}]")
    for w in fit.warnings:
        print(f"   warning: {w}")
    print("   starts -> ends (kd, fd, n):")
    for s in fit.starts:
        end = s.get("end")
        print("   " + ", ".join(f"{v:.4g}" for v in s["start"]) + " -> "
              + (", ".join(f"{v:.5g}" for v in end) + f"  cost {s['cost']:.4g}"
                 if end else s.get("error", "")))

    continuation_case()
    if args.pyharm:
        pyharm_case(args.pyharm)
    if not args.no_compare:
        compare(["bench_hbm:continuation", "bench_hbm:frf_sweep", "bench_hbm:receptance"],
                args.base)


if __name__ == "__main__":
    main()
