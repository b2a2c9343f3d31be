"""Offscreen rendering of a view to PNG (docs, tests, ``nlid-lab view --snapshot``)."""

from __future__ import annotations

import os
from pathlib import Path

from PySide6 import QtCore, QtWidgets

from ..outputs import atomic_path


def application() -> QtWidgets.QApplication:
    """The running QApplication, or a new one (offscreen when no display is available)."""
    app = QtWidgets.QApplication.instance()
    if app is None:
        if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
            os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
        app = QtWidgets.QApplication([])
    return app


def render(widget: QtWidgets.QWidget, path: str | Path, size: tuple[int, int] = (1400, 900)
           ) -> Path:
    """Lay ``widget`` out at ``size`` pixels and save what it shows as a PNG."""
    app = application()
    widget.resize(*size)
    widget.show()
    for _ in range(3):  # layout, then pyqtgraph's deferred range updates
        app.processEvents()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        if not widget.grab().save(str(tmp), "PNG"):
            raise OSError(f"could not write {path}")
    return path


def dispose(widget: QtWidgets.QWidget) -> None:
    """Close and delete ``widget`` now: PySide6 6.x segfaults at interpreter exit when
    pyqtgraph widgets are left for the garbage collector (pyqtgraph issue 2520)."""
    widget.close()
    widget.deleteLater()
    QtCore.QCoreApplication.sendPostedEvents(None, QtCore.QEvent.Type.DeferredDelete)
