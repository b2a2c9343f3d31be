"""Keep numba's on-disk cache honest across modules.

Numba invalidates a cached function only when its own source file changes; a kernel that
inlines or calls compiled code from another file (the element laws of `elements.py`, the AFT
loop of `aft.py`) would keep running the stale compiled copy after that file is edited.
`guard` drops a module's cache files whenever one of its dependencies changed since they were
written. Numba offers no dependency tracking of its own, hence this small hand-written check.

`recompile_law_kernels` serves `analysis.models.register_kind`: the kernels of
`LAW_KERNELS` bind the element law when they compile, so a kind added at run time needs them
compiled afresh in this process, and off the disk cache.
"""

from __future__ import annotations

import hashlib
import importlib
from pathlib import Path

from numba.core.caching import NullCache
from numba.core.registry import CPUDispatcher

LAW_KERNELS = ("models._elements", "models._memory_series", "hbm._aft", "hbm._hbm", "hbm._held",
               "plant._plant_kernels", "plant._substep")
"""Modules of this package whose numba functions contain the element law."""

_disk_caches: dict[int, object] = {}


def guard(module_file: str, *dependencies: str) -> None:
    """Delete the numba cache of ``module_file`` if any of ``dependencies`` (module names in
    this package, e.g. ``"elements"``) changed since the cache was written."""
    src = Path(module_file)
    here = src.parent
    digest = hashlib.sha256(b"".join(_dependency(here, d).read_bytes()
                                     for d in dependencies)).hexdigest()
    cache = here / "__pycache__"
    stamp = cache / f"{src.stem}.deps-sha256"
    try:
        if stamp.read_text() == digest:
            return
    except OSError:
        pass
    for stale in [*cache.glob(f"{src.stem}.*.nbi"), *cache.glob(f"{src.stem}.*.nbc")]:
        stale.unlink(missing_ok=True)
    try:
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        pass    # read-only install: numba then caches elsewhere or not at all


def _dependency(here: Path, name: str) -> Path:
    """File of a dependency named like a relative import from the folder ``here``: a plain
    name is a sibling, each leading dot past the first goes one package up
    (``"..models._elements"``)."""
    dots = len(name) - len(name.lstrip("."))
    base = here
    for _ in range(max(dots - 1, 0)):
        base = base.parent
    return base.joinpath(*name.lstrip(".").split(".")).with_suffix(".py")


def recompile_law_kernels(disk_cache: bool) -> None:
    """Drop the compiled code of every numba function in `LAW_KERNELS`, so that each call
    compiles it again against the element law as it is now; with ``disk_cache`` False they
    neither read nor write the on-disk cache (True restores it)."""
    for name in LAW_KERNELS:
        module = importlib.import_module(f"{__package__}.{name}")
        for obj in vars(module).values():
            if not isinstance(obj, CPUDispatcher) or obj.py_func.__module__ != module.__name__:
                continue
            original = _disk_caches.setdefault(id(obj), obj._cache)
            # numba has no public call for this: `recompile` would compile at once, in an
            # order that links callers to stale callees.
            obj._cache = original if disk_cache else NullCache()
            obj._reset_overloads()
