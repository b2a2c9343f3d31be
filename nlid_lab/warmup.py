"""Compile every cached numba kernel ahead of use (``nlid-lab warmup``, run by ``make demo``).

A fresh install compiles the plant, harmonic-balance and spectral kernels on first use, which
costs tens of seconds on the first command. Numba caches compiled code per argument types, so
tiny problems of the types the commands use fill the cache for every later call.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numba
import numpy as np

import analysis

MODELS = Path(__file__).resolve().parents[1] / "examples" / "models"


def kernels_cached() -> bool:
    """True if every kernel module of `analysis` has compiled code in numba's cache."""
    here = Path(analysis.__file__).parent
    modules = ("_plant_kernels", "_aft", "_hbm", "_spectral", "_elements")
    root = Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else None
    for stem in modules:
        places = [here] if root is None else [root]
        if not any(next(p.rglob(f"{stem}.*.nbi"), None) for p in places if p.is_dir()):
            return False
    return True


def warm_up() -> float:
    """Run tiny problems through every numba kernel; returns the seconds it took."""
    # imported here: importing them is the start of the work this function times
    from analysis.hbm import continue_frf, sweep_held
    from analysis.models import KINDS, Refs, memory_force_series, restoring_force
    from analysis.hbm import HBMSystem
    from analysis.models import Model
    from analysis.plant import simulate
    from analysis.spectral import spectral_matrix

    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    force = rng.normal(size=(256, 1))
    # the force series of every kind, on writable and on read-only motion (the diagnosis's
    # recordings are read-only: numba compiles each flag apart)
    frozen = 1e-3 * force[:, 0]
    frozen.flags.writeable = False
    refs = Refs(k=2e4, f=50.0, u=1e-3, c=4.0, v=0.4)
    for kind, spec in KINDS.items():
        params = {p.name: p.scale(refs) for p in spec.parameters}
        for u in (frozen.copy(), frozen):
            restoring_force(kind, params, u, u)
            if spec.memory:
                memory_force_series(kind, params, u, u)
    for path in sorted(MODELS.glob("*.toml")):
        model = Model.load(path)
        x = simulate(model, force, 1024.0, [0])
        spectral_matrix(np.hstack([force, x]), 1024.0, nperseg=64)
        if model.elements:
            system = HBMSystem(model, [0], "1,3")
            fn = float(model.natural_frequencies()[0])
            system.sweep([0.8 * fn, fn], 1.0, sensitivities=[(0, 0)])
            continue_frf(system, 0.8 * fn, 0.85 * fn, 1.0, max_points=5)
            sweep_held(system, [0.8 * fn, fn], [1.0], 0, 1e-6)  # response-held steps
    return time.perf_counter() - t0


def main() -> int:
    """Compile the kernels, saying so on stderr."""
    print("compiling numeric kernels (first run only)...", file=sys.stderr, flush=True)
    print(f"kernels compiled and cached in {warm_up():.0f} s", file=sys.stderr)
    return 0
