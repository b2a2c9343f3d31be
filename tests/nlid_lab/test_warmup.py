"""`nlid-lab warmup` (run by `make`) leaves no kernel for the first command or the suite to
compile: each one missed costs every fresh clone's `make test` its compile time (the held
steps' kernels cost a worker 27 CPU s before the warm-up ran them)."""

import importlib
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest
from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher

import analysis

ROOT = Path(__file__).resolve().parents[2]


def cached_kernels() -> list[tuple[str, str]]:
    """(module file stem, function name) of every numba function of `analysis` that keeps
    an on-disk cache and is called, not inlined, by its callers."""
    out = []
    for info in pkgutil.walk_packages(analysis.__path__, "analysis."):
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if (isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module.__name__
                    and not isinstance(obj._cache, NullCache)
                    and obj.targetoptions.get("inline", "never") == "never"):
                out.append((Path(module.__file__).stem, obj.py_func.__qualname__))
    return out


@pytest.mark.slow   # compiles every kernel into an empty cache: minutes
def test_warmup_caches_every_kernel(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "nlid_lab.cli", "warmup"], env=env,
                          cwd=ROOT, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr
    kernels = cached_kernels()
    assert ("_held", "_held_sweep") in kernels and ("_memory_series", "_masing_series") in kernels
    missing = [f"{stem}.{name}" for stem, name in kernels
               if next(tmp_path.rglob(f"{stem}.{name}-*.nbi"), None) is None]
    assert missing == []
