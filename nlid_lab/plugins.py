"""Registries filled by their packages' modules: a new estimator, campaign kind, ... is one
new module of its package and no other edit."""

from __future__ import annotations

import importlib
import pkgutil
import sys
from typing import Sequence


def discover(package: str, path: Sequence[str]) -> list[str]:
    """Import every module of ``package`` (found on ``path``, its ``__path__``) not imported
    yet, in name order: each registers itself on import. Returns the modules imported."""
    found = []
    for info in pkgutil.iter_modules(path):
        name = f"{package}.{info.name}"
        if name not in sys.modules:
            importlib.import_module(name)
            found.append(name)
    return found
