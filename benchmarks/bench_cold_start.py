"""First-call latency of each command: from an empty numba cache, and after `nlid-lab warmup`.

Each command runs in a fresh process with ``NUMBA_CACHE_DIR`` pointing at a temporary
directory, so the developer's own cache is neither used nor wiped. "cold" gives every command
its own empty cache (what the first command after an install costs); "warm" runs each once
after ``nlid-lab warmup`` filled one cache (what ``make demo`` leaves). Target: warm <= 5 s.

    PYTHONPATH=. python benchmarks/bench_cold_start.py [--skip-cold]
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SDOF = ROOT / "examples" / "models" / "sdof-cubic-quaddamp.toml"
TARGET_S = 5.0


def _cli(args: list[str], cache: Path, cwd: Path) -> float:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "QT_QPA_PLATFORM": "offscreen",
           "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "nlid_lab.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed: {proc.stderr.strip()}")
    return elapsed


def _inputs(d: Path, cache: Path) -> None:
    """Random runs at three levels, a stepped-sine run and a candidate model."""
    from analysis.models import Element, Model

    model = Model.load(SDOF)
    model.with_elements([Element(e.kind, e.w.copy(), {}) for e in model.elements]
                        ).save(d / "candidate.toml")
    rng = np.random.default_rng(0)
    t = np.arange(2048) / 1024.0
    freqs = np.linspace(15.0, 30.0, 6)
    np.savez(d / "step.npz", fs=1024.0, force_dofs=[0], freqs=freqs, force_amplitude=5.0,
             force=np.stack([5.0 * np.sin(2 * np.pi * f * t)[:, None] for f in freqs]))
    _cli(["simulate", str(SDOF), "--drive", "step.npz", "--out", "step.h5"], cache, d)
    for level in (1.0, 10.0, 30.0):
        np.savez(d / f"r{level:g}.npz", fs=1024.0, force_dofs=[0], force_rms=level,
                 force=level * rng.normal(size=(16384, 1)))
        _cli(["simulate", str(SDOF), "--drive", f"r{level:g}.npz", "--out", f"r{level:g}.h5",
              "--noise", "1e-8", "--seed", "1"], cache, d)


def commands() -> dict[str, list[str]]:
    return {
        "simulate": ["simulate", str(SDOF), "--drive", "r1.npz", "--out", "sim.h5", "--force"],
        "analyze reverse-path": ["analyze", "reverse-path", "r1.h5", "r30.h5", "--model",
                                 "candidate.toml"],
        "analyze hbm": ["analyze", "hbm", "step.h5", "--model", "candidate.toml", "--starts",
                        "1"],
        "detect": ["detect", "r1.h5", "r30.h5"],
        "predict": ["predict", str(SDOF), "--amplitude", "1", "--band", "10", "30"],
        "diagnose": ["diagnose", str(SDOF), "r1.h5", "r10.h5", "r30.h5"],
        "report": ["report", "r30.h5", "--out", "rep", "--force"],
        "view": ["view", "r30.h5", "--snapshot", "v.png", "--force"],
    }


def main() -> None:
    skip_cold = "--skip-cold" in sys.argv
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _inputs(d, d / "cache-setup")
        cold = {}
        if not skip_cold:
            for name, args in commands().items():
                cold[name] = _cli(args, d / f"cache-cold-{len(cold)}", d)
                print(f"cold  {name:22s} {cold[name]:6.1f} s", flush=True)
        warm_cache = d / "cache-warm"
        t_warm = _cli(["warmup"], warm_cache, d)
        print(f"nlid-lab warmup (empty cache)  {t_warm:6.1f} s", flush=True)
        print(f"{'command':22s} {'cold [s]':>9s} {'after warmup [s]':>17s}")
        worst = 0.0
        for name, args in commands().items():
            warm = _cli(args, warm_cache, d)
            worst = max(worst, warm)
            c = f"{cold[name]:9.1f}" if name in cold else f"{'-':>9s}"
            print(f"{name:22s} {c} {warm:17.1f}", flush=True)
        verdict = "meets" if worst <= TARGET_S else "MISSES"
        print(f"slowest first call after warmup {worst:.1f} s: {verdict} the {TARGET_S:g} s "
              "target")


if __name__ == "__main__":
    main()
