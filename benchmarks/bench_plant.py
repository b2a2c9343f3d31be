"""Simulated-plant speed against scipy.integrate.solve_ivp: 3-DOF chain and 50-mode modal model.

Prints output samples/s of `analysis.plant.Plant` (auto oversampling) under band-limited random
drive on DOFs 0 and 2, the per-sample rate of `solve_ivp` (DOP853, rtol 1e-9, the tests'
interval-by-interval reference with event-located stick/slip switches) timed in the same run,
their ratio, the plant's error against a rtol-1e-12 reference and the long-record spectral
agreement with a 4x finer plant run; then the default-settings accuracy at 40 N rms on that
model and on a stiffening cubic (2 s against oversample 48; target <= 1e-5), next to the error
of a run fixed at the starting substeps (`auto_oversample`, the pre-step-doubling default).

The modal case (`aircraft_model`): 50 modes 2-200 Hz (damping 0.5-3 %, seeded random shapes)
seen at 4 points, a stick-slip (Jenkins) joint between points 1 and 2 and a cubic spring
between points 2 and 3, band-limited random drive (2-200 Hz) at point 0, fs = 4096 Hz (16x
the 200 Hz top mode, a usual GVT rate); output samples/s with default settings (best of 3
whole runs by wall clock and by process CPU time, and the sum of each 1024-sample block's
fastest of 15 passes, `blockwise_time`, which holds on a shared machine), the ratio to
solve_ivp (DOP853, rtol 1e-9, on the modal coordinates) timed in the same run, and the
default-settings error against a converged run (oversample 48; target <= 1e-5).

Then this tree against a base commit (default HEAD~1, the previous commit) in the same run
(`benchmarks/_compare.py`): both cases' default-settings runs (10 s), alternately in
subprocesses, best wall clock, thread and process CPU time of each, their ratio and the output
samples per process CPU second of each tree (target >= 1,000,000 with default settings).

Case ``records`` (not in ``all``): the numba structure the kernel's records could be, one
output stage reading four matrices per call, 80 000 calls from a jitted loop: a NamedTuple, a
``jitclass`` and a ``structref``, the stage called or inlined (``inline="always"``), with and
without numba's reference counting (``_nrt``); compile and run time of each.

    python benchmarks/bench_plant.py [--case all|chain|modal|records] [--seconds 30]
                                     [--fs 8192] [--base REF | --no-compare]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _compare import add_options, compare, project_root, search_path  # noqa: E402

ROOT = project_root(__file__)
sys.path[:0] = search_path(ROOT)

from analysis.plant import random_gaussian  # noqa: E402
from analysis.models import Element, Model  # noqa: E402
from analysis.plant import Plant, auto_oversample  # noqa: E402
from test_plant import reference_response  # noqa: E402
from test_plant_modal import aircraft_model  # noqa: E402

MODAL_FS = 4096.0
#: output samples of the `compare` cases (their default arguments)
RUN_SAMPLES = {"chain_run": int(10.0 * 8192.0), "modal_run": int(10.0 * MODAL_FS)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=("all", "chain", "modal", "records"), default="all")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--fs", type=float, default=8192.0)
    parser.add_argument("--ref-seconds", type=float, default=0.25)
    add_options(parser)
    args = parser.parse_args()
    if args.case in ("all", "chain"):
        chain_case(args)
    if args.case in ("all", "modal"):
        modal_case(args.seconds)
    if args.case == "records":
        records_case()
        return
    if not args.no_compare:
        cases = {"chain": ["bench_plant:chain_run"], "modal": ["bench_plant:modal_run"]}
        results = compare(cases.get(args.case, cases["chain"] + cases["modal"]), args.base,
                          repeats=2)
        for name, (old, new) in results.items():
            n = RUN_SAMPLES[name.split(":")[1]]
            print(f"{name}: output samples per process CPU second, {args.base} "
                  f"{n / old.process:,.0f}, this tree {n / new.process:,.0f} "
                  f"{'>=' if n / new.process >= 1e6 else '<'} 1,000,000 (by thread CPU time "
                  f"{n / old.cpu:,.0f} and {n / new.cpu:,.0f}; by wall clock "
                  f"{n / old.wall:,.0f} and {n / new.wall:,.0f})")


def chain_run(seconds: float = 10.0, fs: float = 8192.0):
    """For `compare`: a default-settings run of the chain case (the drive of `chain_case`)."""
    model = Model.load(ROOT / "examples" / "models" / "three-dof-cubic-stickslip.toml")
    n = int(seconds * fs)
    force = np.column_stack([random_gaussian(n, fs, (10, 400), 1.0, 1),
                             random_gaussian(n, fs, (10, 400), 10.0, 2)])
    return lambda: Plant(model, fs, [0, 2]).run(force)


def modal_run(seconds: float = 10.0):
    """For `compare`: a default-settings run of the modal case (the drive of `modal_case`)."""
    model = aircraft_model()
    force = random_gaussian(int(seconds * MODAL_FS), MODAL_FS, (2, 200), 20.0, 1)[:, None]
    return lambda: Plant(model, MODAL_FS, [0]).run(force)


def best_of(plant: Plant, force: np.ndarray, repeats: int = 3
            ) -> tuple[float, float, float, object]:
    """Best and median wall time of ``repeats`` runs from rest (the machine may be shared),
    the best CPU time of the process (what the run costs when the machine is shared; the
    threads a library starts included: OpenBLAS's cost 30 % of a run before the plant's
    set-up held them to one, `analysis.plant._substep_rule.one_blas_thread`), and the last
    output."""
    plant.run(force[:64])                      # compile outside the timing
    times, cpu = [], []
    for _ in range(repeats):
        plant.reset()
        plant.stats[:] = 0
        t0, c0 = time.perf_counter(), time.process_time()
        out = plant.run(force)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return min(times), float(np.median(times)), min(cpu), out


def blockwise_time(plant: Plant, force: np.ndarray, passes: int = 15, block: int = 1024
                   ) -> float:
    """Run time estimated for an idle machine: the record is run ``passes`` times in
    ``block``-sample calls (with automatic substeps, the same computation as one call: the
    step-doubling chunks are 1024 samples), and each block's fastest pass is summed. Blocks
    take ~1 ms, so most passes of a block run undisturbed even on a busy machine, where
    whole-run wall and thread CPU times vary 2x with the other jobs' cache use."""
    plant.run(force[:64])
    times = np.empty((passes, -(-force.shape[0] // block)))
    for p in range(passes):
        plant.reset()
        for b, i in enumerate(range(0, force.shape[0], block)):
            t0 = time.perf_counter()
            plant.run(force[i:i + block])
            times[p, b] = time.perf_counter() - t0
    return float(times.min(axis=0).sum())


def modal_case(seconds: float, ref_seconds: float = 0.25, acc_seconds: float = 2.0) -> None:
    """The 50-mode modal model of the module docstring."""
    fs = MODAL_FS
    model = aircraft_model()
    n = int(seconds * fs)
    force = random_gaussian(n, fs, (2, 200), 20.0, 1)[:, None]
    plant = Plant(model, fs, [0])
    t_plant, t_median, t_cpu, out = best_of(plant, force)
    rate = n / t_plant
    stats = plant.describe_stats()
    t_blocks = blockwise_time(Plant(model, fs, [0]), force)
    g = out.element_forces
    fd = model.elements[0].params["fd"]
    print(f"\nmodel: {model.name} ({model.n_q} modes {model.natural_frequencies()[0]:.1f}-"
          f"{model.natural_frequencies()[-1]:.0f} Hz, {model.n_dof} points); fs = {fs:g} Hz, "
          f"drive 2-200 Hz, 20 N rms at point 0, {seconds:g} s")
    print(f"nonlinearity: slipping {100 * np.mean(np.isclose(np.abs(g[:, 0]), fd, rtol=1e-9)):.0f} "
          f"% of samples, {stats['events'] / seconds:.0f} stick/slip switches per s; cubic "
          f"force rms {np.std(g[:, 1]):.1f} N")
    print(f"plant: oversample {plant.oversample} (raised {plant.raised}x), "
          f"{stats['iterations_per_substep']:.2f} corrector iterations per substep, best of 3 "
          f"{t_plant:.3f} s -> {rate:,.0f} output samples/s (median {n / t_median:,.0f}; "
          f"process CPU time {n / t_cpu:,.0f}) {'>=' if rate >= 1e6 else '<'} 1,000,000")
    print(f"plant, per-block best (idle-machine estimate, `blockwise_time`): "
          f"{n / t_blocks:,.0f} output samples/s {'>=' if n / t_blocks >= 1e6 else '<'} "
          f"1,000,000")

    n_ref = int(ref_seconds * fs)
    shapes = model.shapes
    q_model = Model(model.mass, model.damping, model.stiffness,
                    [Element(el.kind, model.to_q(el.w), el.params) for el in model.elements],
                    "modal coordinates")
    t0 = time.perf_counter()
    ivp = reference_response(q_model, force[:n_ref], fs, [0], rtol=1e-9,
                             input_matrix=shapes[[0]].T)
    t_ivp = time.perf_counter() - t0
    rate_ivp = n_ref / t_ivp
    x_ivp = ivp["displacement"] @ shapes.T
    print(f"solve_ivp (DOP853, rtol 1e-9, modal coordinates): {ref_seconds:g} s of signal in "
          f"{t_ivp:.2f} s -> {rate_ivp:,.0f} output samples/s")
    print(f"ratio plant / solve_ivp: {rate / rate_ivp:,.0f}x (per-block best: "
          f"{n / t_blocks / rate_ivp:,.0f}x)")

    n_acc = int(acc_seconds * fs)
    ref = Plant(model, fs, [0], oversample=48).run(force[:n_acc]).displacement
    x = out.displacement[:n_acc]

    def rel(a):
        return np.linalg.norm(a - ref[:len(a)]) / np.linalg.norm(ref[:len(a)])

    err = rel(x)
    print(f"accuracy over {acc_seconds:g} s against oversample 48: default {err:.2e} "
          f"{'<=' if err <= 1e-5 else '>'} 1e-5; solve_ivp rtol 1e-9 over {ref_seconds:g} s: "
          f"{rel(x_ivp):.2e}")


def chain_case(args: argparse.Namespace) -> None:
    """The 3-DOF chain of the module docstring."""
    fs = args.fs
    model = Model.load(ROOT / "examples" / "models" / "three-dof-cubic-stickslip.toml")
    n = int(args.seconds * fs)
    force = np.column_stack([random_gaussian(n, fs, (10, 400), 1.0, 1),
                             random_gaussian(n, fs, (10, 400), 10.0, 2)])
    plant = Plant(model, fs, [0, 2])
    t_plant, t_median, t_cpu, out = best_of(plant, force)
    rate = n / t_plant
    stats = plant.describe_stats()
    g = out.element_forces
    print(f"model: {model.name}; fs = {fs:g} Hz, drive 10-400 Hz, 1 N rms at DOF 0 and "
          f"10 N rms at DOF 2, {args.seconds:g} s")
    print(f"nonlinearity: cubic force rms / grounded-spring force rms = "
          f"{np.std(g[:, 0]) / np.std(1e6 * out.displacement[:, 0]):.2f}; slipping "
          f"{100 * np.mean(np.isclose(np.abs(g[:, 1]), 20.0, rtol=1e-9)):.1f} % of samples; "
          f"{stats['events'] / args.seconds:.0f} stick/slip switches per s")
    print(f"plant: oversample {plant.oversample}, {stats['iterations_per_substep']:.2f} corrector "
          f"iterations per substep, best of 3 {t_plant:.3f} s -> {rate:,.0f} output samples/s "
          f"(median {n / t_median:,.0f}; process CPU time {n / t_cpu:,.0f}) "
          f"{'>=' if rate >= 1e6 else '<'} 1,000,000")

    n_ref = int(args.ref_seconds * fs)
    t0 = time.perf_counter()
    ivp = reference_response(model, force[:n_ref], fs, [0, 2], rtol=1e-9)
    t_ivp = time.perf_counter() - t0
    rate_ivp = n_ref / t_ivp
    print(f"solve_ivp (DOP853, rtol 1e-9): {args.ref_seconds:g} s of signal in {t_ivp:.2f} s -> "
          f"{rate_ivp:,.0f} output samples/s")
    print(f"ratio plant / solve_ivp: {rate / rate_ivp:,.0f}x")

    ref = reference_response(model, force[:n_ref], fs, [0, 2], rtol=1e-12)["displacement"]
    x = out.displacement[:n_ref]

    def rel(a):
        return np.linalg.norm(a - ref) / np.linalg.norm(ref)

    print(f"relative error vs solve_ivp rtol 1e-12 over {args.ref_seconds:g} s: plant "
          f"{rel(x):.2e}, solve_ivp rtol 1e-9 {rel(ivp['displacement']):.2e}")

    fine = Plant(model, fs, [0, 2], oversample=4 * plant.oversample).run(force).displacement
    f, p_auto = signal.welch(out.displacement, fs, nperseg=4096, axis=0)
    _, p_fine = signal.welch(fine, fs, nperseg=4096, axis=0)
    band = (f >= 10) & (f <= 400)
    dev = np.abs(p_auto[band] / p_fine[band] - 1).max()
    print(f"long record: max PSD deviation 10-400 Hz vs 4x finer plant = {100 * dev:.3f} %")

    chain = Model.load(ROOT / "examples" / "models" / "three-dof-paper.toml")
    cubic = chain.with_elements([Element("cubic_spring", [1.0, 0.0, 0.0], {"p": 4e16})])
    for name, case, rms in ((model.name, model, 40.0), ("stiffening cubic at DOF 0", cubic, 20.0)):
        default_accuracy(name, case, rms, fs)


def default_accuracy(name: str, model: Model, rms: float, fs: float, seconds: float = 2.0,
                     seed: int = 1) -> None:
    """Print the default-settings error (and the fixed starting substeps' one) of ``rms`` N
    on DOFs 0 and 2 against a converged run (oversample 48)."""
    n = int(seconds * fs)
    force = np.column_stack([random_gaussian(n, fs, (10, 400), rms, seed + i) for i in range(2)])
    ref = Plant(model, fs, [0, 2], oversample=48).run(force).displacement
    plant = Plant(model, fs, [0, 2])
    t0 = time.perf_counter()
    x = plant.run(force).displacement
    t = time.perf_counter() - t0
    start = auto_oversample(model, fs)
    fixed = Plant(model, fs, [0, 2], oversample=start).run(force).displacement

    def rel(a):
        return np.linalg.norm(a - ref) / np.linalg.norm(ref)

    print(f"accuracy, {name}, {rms:g} N rms at DOFs 0 and 2, {seconds:g} s: default "
          f"{rel(x):.2e} (substeps raised {plant.raised}x to {plant.oversample}, "
          f"{n / t:,.0f} samples/s) {'<=' if rel(x) <= 1e-5 else '>'} 1e-5; fixed at the "
          f"starting {start}: {rel(fixed):.2e}")


def _record_kinds() -> dict[str, type]:
    """The three record kinds of case ``records``, each holding ``shapes``, ``tax``, ``tav``
    (2-D) and ``out_z`` (3-D)."""
    from typing import NamedTuple

    import numba
    from numba.core import types
    from numba.experimental import jitclass, structref

    class Tuple(NamedTuple):
        shapes: np.ndarray
        tax: np.ndarray
        tav: np.ndarray
        out_z: np.ndarray

    two, three = numba.float64[:, ::1], numba.float64[:, :, ::1]

    @jitclass([("shapes", two), ("tax", two), ("tav", two), ("out_z", three)])
    class JitClass:
        def __init__(self, shapes, tax, tav, out_z):
            self.shapes, self.tax, self.tav, self.out_z = shapes, tax, tav, out_z

    @structref.register
    class StructType(types.StructRef):
        def preprocess_fields(self, fields):
            return tuple((name, types.unliteral(t)) for name, t in fields)

    class StructRef(structref.StructRefProxy):
        pass

    structref.define_proxy(StructRef, StructType, ["shapes", "tax", "tav", "out_z"])
    return {"namedtuple": Tuple, "jitclass": JitClass, "structref": StructRef}


def _record_loop(inline: str, nrt: bool):
    """A jitted loop calling an output stage that reads its record's four matrices."""
    import numba

    flags = {"fastmath": {"reassoc", "contract"}, "error_model": "numpy", "_nrt": nrt}

    @numba.njit(inline=inline, **flags)
    def stage(d, s, z, k, out):
        n = s.shape[0] // 2
        for p in range(d.shapes.shape[0]):
            x = 0.0
            for c in range(n):
                x += d.shapes[p, c] * s[c] + d.tax[p, c] * s[c] + d.tav[p, c] * s[n + c]
            for c in range(d.out_z.shape[2]):
                x += d.out_z[0, p, c] * z[c]
            out[k, p] = x

    @numba.njit(**flags)
    def loop(d, s, z, out, m):
        for k in range(out.shape[0]):
            for _ in range(m):
                s[0] += 1e-9
                stage(d, s, z, k, out)
    return loop


def records_case(n: int = 20000, m: int = 4) -> None:
    """Case ``records`` of the module docstring."""
    rng = np.random.default_rng(0)
    arrays = (rng.random((3, 3)), rng.random((3, 3)), rng.random((3, 3)),
              rng.random((3, 3, 12)))
    s, z, out = rng.random(6), rng.random(12), np.empty((n, 3))
    print(f"records: one stage reading 4 matrices, {n * m} calls; compile s, run ns per call")
    for nrt in (True, False):
        for inline in ("never", "always"):
            for name, kind in _record_kinds().items():
                loop, rec = _record_loop(inline, nrt), kind(*arrays)
                t0 = time.perf_counter()
                try:
                    loop(rec, s, z, out[:2], m)
                except Exception:     # numba.core.errors.TypingError / NumbaRuntimeError
                    print(f"  reference counts off, stage {inline:6s} {name:10s}: does not "
                          f"compile (its instances are reference-counted objects)")
                    continue
                compile_s = time.perf_counter() - t0
                runs = []
                for _ in range(7):
                    t0 = time.thread_time()
                    loop(rec, s, z, out, m)
                    runs.append(time.thread_time() - t0)
                print(f"  reference counts {'on ' if nrt else 'off'}, stage {inline:6s} "
                      f"{name:10s}: compile {compile_s:5.2f} s, run "
                      f"{1e9 * min(runs) / (n * m):5.1f} ns")


if __name__ == "__main__":
    main()
