"""Reanalysis speed-up on Dask: 200 generated runs, 1 against 2 local process workers.

Generates the runs into a temporary directory (SDOF cubic + quadratic damping plant, random
excitation, one level each), then for each worker count starts a `LocalCluster`, warms every
worker up (imports, numba kernels) and times `reanalyze` over all runs. A plain loop in this
process (BLAS pinned to one thread like the Dask workers) is the baseline for the per-task
overhead. Target: 2 workers >= 1.8x faster than 1 worker on an otherwise idle 2-core machine.

    python benchmarks/bench_reanalyze.py [--runs 200] [--samples 65536] [--repeat 2]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # same BLAS threading as Dask's worker processes

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from analysis.plant import random_gaussian  # noqa: E402
from analysis.models import Element, Model  # noqa: E402
from analysis.plant import simulate  # noqa: E402
from analysis.recordings import Recording  # noqa: E402
from nlid_lab.methods import BatchOptions  # noqa: E402
from nlid_lab.reanalyze import analyse_run, dask_client, reanalyze  # noqa: E402
from nlid_lab.store import save_recording  # noqa: E402

MODEL = Path(__file__).resolve().parents[1] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
FS = 2000.0


def generate(root: Path, n_runs: int, n_samples: int) -> list[str]:
    true = Model.load(MODEL)
    paths = []
    for i in range(n_runs):
        rms = 20.0 + 30.0 * i / max(n_runs - 1, 1)
        force = random_gaussian(n_samples, FS, (5.0, 300.0), rms, seed=i)[:, None]
        x = simulate(true, force, FS, [0], noise_std=1e-7, seed=i)
        path = root / f"run{i:04d}.h5"
        save_recording(path, Recording(FS, "random", [0], force, x, level=rms), source="sim")
        paths.append(str(path))
    return paths


def timed_cluster(paths: list[str], candidate: Model, workers: int) -> tuple[float, float, int]:
    """(start-up + warm-up s, reanalysis s, failed rows) on a fresh local cluster."""
    t0 = time.perf_counter()
    with dask_client(workers=workers) as client:
        client.run(analyse_run, paths[0], candidate, "reverse-path", BatchOptions())  # warm all
        startup = time.perf_counter() - t0
        result = reanalyze(paths, candidate, client, progress=False)
    return startup, result.elapsed_s, result.n_failed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--samples", type=int, default=65536, help="samples per run")
    parser.add_argument("--repeat", type=int, default=2,
                        help="passes per configuration, alternating 1 and 2 workers; best kept")
    args = parser.parse_args()
    true = Model.load(MODEL)
    candidate = true.with_elements([Element(el.kind, el.w, {}) for el in true.elements])
    best: dict[int, float] = {}
    with tempfile.TemporaryDirectory(prefix="bench-reanalyze-") as tmp:
        t = time.perf_counter()
        paths = generate(Path(tmp), args.runs, args.samples)
        print(f"generated {len(paths)} runs of {args.samples} samples in "
              f"{time.perf_counter() - t:.1f} s")
        analyse_run(paths[0], candidate, "reverse-path", BatchOptions())  # warm-up (numba)
        t = time.perf_counter()
        for path in paths:
            analyse_run(path, candidate, "reverse-path", BatchOptions())
        serial = time.perf_counter() - t
        print(f"baseline: plain loop in this process  {serial:7.2f} s")
        for _ in range(args.repeat):   # alternate, so that changing load hits both alike
            for workers in (1, 2):
                startup, elapsed, failed = timed_cluster(paths, candidate, workers)
                best[workers] = min(best.get(workers, float("inf")), elapsed)
                print(f"dask, {workers} worker(s): reanalysis {elapsed:7.2f} s  (cluster "
                      f"start + warm-up {startup:.1f} s, failed rows {failed})")
    print(f"1 Dask worker vs plain loop: {best[1] / serial:.2f}x the time")
    print(f"speed-up 2 workers vs 1 (best of {args.repeat}): {best[1] / best[2]:.2f}x "
          f"(target >= 1.8x; {os.cpu_count()} cores, load average now "
          f"{os.getloadavg()[0]:.1f}: other work on the machine lowers it)")


if __name__ == "__main__":
    main()
