"""Qt views (PySide6 + pyqtgraph, the ``gui`` extra): live campaign view, offline run browser
and offscreen snapshots.

Modules behind this API: ``display`` (is there a display, and the Qt libraries it needs),
``live`` (`LiveView`), ``offline`` (`OfflineView`), ``plots``, ``snapshot`` (the application,
offscreen rendering, disposal). The names are loaded on first use (PEP 562): importing this
package must not load PySide6, which takes seconds and is missing without the ``gui`` extra.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "check_display": "display", "missing_libraries": "display", "platform": "display",
    "LiveView": "live", "OfflineView": "offline",
    "application": "snapshot", "dispose": "snapshot", "render": "snapshot",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    return value                    # not cached: the module's own name stays the one in use


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
