"""Keep numba's on-disk cache honest across modules.

Numba invalidates a cached function only when its own source file changes; a kernel that
inlines or calls compiled code from another file (the element laws of `elements.py`, the AFT
loop of `aft.py`) would keep running the stale compiled copy after that file is edited.
`guard` drops a module's cache files whenever one of its dependencies changed since they were
written. Numba offers no dependency tracking of its own, hence this small hand-written check.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def guard(module_file: str, *dependencies: str) -> None:
    """Delete the numba cache of ``module_file`` if any of ``dependencies`` (module names in
    this package, e.g. ``"elements"``) changed since the cache was written."""
    src = Path(module_file)
    here = src.parent
    digest = hashlib.sha256(b"".join((here / f"{d}.py").read_bytes()
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
