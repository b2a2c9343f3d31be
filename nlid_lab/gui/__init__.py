"""Qt views (PySide6 + pyqtgraph, the ``gui`` extra): live campaign view, offline run browser
and offscreen snapshots.

Modules behind this API: ``_display`` (is there a display, and the Qt libraries it needs),
``_live`` (`LiveView`), ``_offline`` (`OfflineView`), ``_plots``, ``_snapshot`` (the application,
offscreen rendering, disposal). The names are loaded on first use (PEP 562): importing this
package must not load PySide6, which takes seconds and is missing without the ``gui`` extra.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "check_display": "_display", "missing_libraries": "_display", "platform": "_display",
    "LiveView": "_live", "OfflineView": "_offline",
    "application": "_snapshot", "dispose": "_snapshot", "render": "_snapshot",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    return value                    # not cached: the module's own name stays the one in use


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
