"""Time benchmark cases on this tree and on a base commit in the same run.

A case is a function of a benchmark module that sets its work up and returns the callable to
time (``def case() -> Callable[[], object]``), written against the public API so that it runs
on both trees. The base ref (default ``HEAD~1``) is checked out into a temporary
``git worktree``; each case then runs in fresh subprocesses, alternately on the base tree
and on this one (``rounds`` each, ``repeats`` timed calls per subprocess after one untimed
call that compiles the kernels), and the best wall-clock, thread CPU and process CPU times of
each tree are compared (process CPU includes the threads a library starts, e.g. OpenBLAS's). Alternating in one run is what makes the ratio hold on a shared machine:
both trees see the same load. The base tree compiles its numba kernels once (its own cache).

    python benchmarks/_compare.py [--base REF] [--rounds 3] [--repeats 5] MODULE:CASE ...

``MODULE`` is a benchmark file name in ``benchmarks/`` (``bench_hbm``); the benchmark
modules call `compare` themselves at the end (``--base``, ``--no-compare``).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

HERE = Path(__file__).resolve().parent
ROOT_ENV = "NLID_BENCH_ROOT"     # the tree a benchmark module imports the project from


def project_root(bench_file: str) -> Path:
    """The tree a benchmark module runs against: ``NLID_BENCH_ROOT`` when `compare` runs it
    on the base tree, its own checkout otherwise."""
    return Path(os.environ.get(ROOT_ENV) or Path(bench_file).resolve().parents[1])


def search_path(root: Path) -> list[str]:
    """What a benchmark puts first on ``sys.path``: the project, its tests and their folders
    (shared scenarios and reference integrators live there)."""
    tests = root / "tests"
    return [str(root), str(tests), *sorted({str(p.parent) for p in tests.rglob("test_*.py")})]


@dataclass(frozen=True)
class Timing:
    """Best wall-clock, thread CPU and process CPU seconds of one case on one tree."""

    wall: float
    cpu: float
    process: float = float("nan")


def _worker(root: str, module: str, case: str, repeats: int) -> None:
    """Subprocess side: import the case from this tree's benchmark file with ``root``'s
    packages, run it once untimed, then time ``repeats`` calls; print the times as JSON."""
    os.environ[ROOT_ENV] = root
    sys.path[:0] = search_path(Path(root))
    spec = importlib.util.spec_from_file_location(f"_bench_{module}", HERE / f"{module}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    run = getattr(mod, case)()
    run()
    wall, cpu, process = [], [], []
    for _ in range(repeats):
        t0, c0, p0 = time.perf_counter(), time.thread_time(), time.process_time()
        run()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
        process.append(time.process_time() - p0)
    origin = sys.modules["analysis"].__file__
    print(json.dumps({"wall": wall, "cpu": cpu, "process": process, "analysis": origin}))


def _time_once(root: Path, module: str, case: str, repeats: int) -> tuple[list, list, list]:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", str(root), module, case,
           str(repeats)]
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    out = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"{module}:{case} failed on {root}:\n{out.stderr[-2000:]}")
    data = json.loads(out.stdout.strip().splitlines()[-1])
    if not data["analysis"].startswith(str(root)):
        raise RuntimeError(f"{module}:{case} imported {data['analysis']}, not {root}")
    return data["wall"], data["cpu"], data["process"]


class _BaseTree:
    """The base ref checked out into a temporary worktree, removed on exit."""

    def __init__(self, repo: Path, ref: str) -> None:
        self.repo, self.ref = repo, ref
        self.path = Path(tempfile.mkdtemp(prefix="nlid-bench-base-"))

    def __enter__(self) -> Path:
        subprocess.run(["git", "-C", str(self.repo), "worktree", "add", "--detach", "--quiet",
                        str(self.path), self.ref], check=True)
        return self.path

    def __exit__(self, *exc: object) -> None:
        subprocess.run(["git", "-C", str(self.repo), "worktree", "remove", "--force",
                        str(self.path)], check=False)


def compare(cases: Sequence[str], base: str = "HEAD~1", rounds: int = 3, repeats: int = 5,
            root: Path | None = None) -> dict[str, tuple[Timing, Timing]]:
    """Time each ``MODULE:CASE`` on ``base`` and on this tree, alternately, and print the
    best times and their ratio; returns ``{case: (base timing, this tree's timing)}``."""
    here = root or project_root(__file__)
    sha = subprocess.run(["git", "-C", str(here), "rev-parse", "--short", base],
                         capture_output=True, text=True, check=True).stdout.strip()
    print(f"\n== this tree against {base} ({sha}), same run: {rounds} alternating rounds x "
          f"{repeats} calls per tree, best of each")
    results = {}
    with _BaseTree(here, base) as tree:
        for name in cases:
            module, case = name.split(":")
            runs = {tree: ([], [], []), here: ([], [], [])}
            for _ in range(rounds):
                for root_ in (tree, here):
                    for kept, times in zip(runs[root_], _time_once(root_, module, case,
                                                                   repeats)):
                        kept.extend(times)
            old, new = (Timing(*(min(t) for t in runs[r])) for r in (tree, here))
            results[name] = (old, new)
            print(f"{name}: {base} {1e3 * old.wall:.1f} ms (thread CPU {1e3 * old.cpu:.1f}, "
                  f"process CPU {1e3 * old.process:.1f}), this tree {1e3 * new.wall:.1f} ms "
                  f"(thread CPU {1e3 * new.cpu:.1f}, process CPU {1e3 * new.process:.1f}); "
                  f"time ratio this / base {new.wall / old.wall:.2f} (CPU "
                  f"{new.cpu / old.cpu:.2f}, process CPU {new.process / old.process:.2f})")
    return results


def add_options(parser: argparse.ArgumentParser) -> None:
    """``--base REF`` and ``--no-compare`` for the benchmark modules."""
    parser.add_argument("--base", default="HEAD~1",
                        help="git ref timed against this tree in the same run (HEAD~1)")
    parser.add_argument("--no-compare", action="store_true",
                        help="skip the timing against --base")


def main(argv: Sequence[str] | None = None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["--worker"]:
        _worker(argv[1], argv[2], argv[3], int(argv[4]))
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="+", help="MODULE:CASE, e.g. bench_hbm:continuation")
    parser.add_argument("--base", default="HEAD~1")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    compare(args.cases, args.base, args.rounds, args.repeats)


if __name__ == "__main__":
    main()
