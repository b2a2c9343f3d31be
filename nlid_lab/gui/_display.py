"""Can a window be opened? Checked before the QApplication exists, because Qt aborts the
process (SIGABRT) when its xcb platform plugin cannot load, which no ``except`` catches."""

from __future__ import annotations

import ctypes
import os
from pathlib import Path

from analysis.errors import InputError

#: Libraries Qt's xcb plugin needs beyond what PySide6 ships, and their Debian packages
#: (libxcb-cursor is loaded at run time, the others are link dependencies).
XCB_LIBRARIES = {"libxcb-cursor.so.0": "libxcb-cursor0", "libxcb-icccm.so.4": "libxcb-icccm4",
                 "libxcb-keysyms.so.1": "libxcb-keysyms1"}


def platform() -> str:
    """The Qt platform plugin a new QApplication will use (as `snapshot.application`)."""
    chosen = os.environ.get("QT_QPA_PLATFORM")
    if chosen:
        return chosen.split(":")[0]
    if os.environ.get("WAYLAND_DISPLAY"):
        return "wayland"
    return "xcb" if os.environ.get("DISPLAY") else "offscreen"


def missing_libraries() -> list[str]:
    """System libraries the xcb plugin cannot find (empty if it loads)."""
    missing = []
    for soname in XCB_LIBRARIES:
        try:
            ctypes.CDLL(soname)
        except OSError:
            missing.append(soname)
    if not missing:
        from PySide6 import QtCore   # Qt loads only once its libraries are known present
        qpa = Path(QtCore.QLibraryInfo.path(QtCore.QLibraryInfo.LibraryPath.LibrariesPath))
        try:
            ctypes.CDLL(str(qpa / "libQt6XcbQpa.so.6"))
        except OSError as exc:       # "libfoo.so.1: cannot open shared object file: ..."
            missing.append(str(exc).split(":")[0])
    return missing


def check_display() -> None:
    """Raise `InputError` (one line naming the packages) if the window cannot be opened."""
    if platform() != "xcb" or not Path("/proc/self/maps").exists():
        return    # offscreen, wayland etc. need none of the xcb libraries; Linux only
    missing = missing_libraries()
    if missing:
        packages = " ".join(XCB_LIBRARIES.get(m, m) for m in missing)
        raise InputError(f"the Qt window cannot open: {', '.join(missing)} missing; install "
                         f"them (Debian/Ubuntu: apt install {packages}), or use --snapshot "
                         "FILE.png / QT_QPA_PLATFORM=offscreen")
