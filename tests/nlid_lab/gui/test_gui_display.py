"""`view` on a desktop without Qt's xcb libraries: one line naming them, exit 2 (no abort)."""

from __future__ import annotations

import ctypes
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from analysis.recordings import Recording
from nlid_lab import store
from nlid_lab.cli import main
from nlid_lab.gui import _display as display

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def run(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "run.h5"
    store.save_recording(path, Recording(fs=256.0, excitation="random", force_dofs=[0],
                                         force=rng.normal(size=(1024, 1)),
                                         response=rng.normal(size=(1024, 1)), level=1.0))
    return path


def _loads(soname: str) -> bool:
    try:
        ctypes.CDLL(soname)
        return True
    except OSError:
        return False


def test_missing_libraries_are_the_ones_that_do_not_load():
    missing = display.missing_libraries()
    for soname in display.XCB_LIBRARIES:
        assert (soname in missing) == (not _loads(soname))


def test_view_names_missing_packages(run, monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(display, "missing_libraries",
                        lambda: ["libxcb-cursor.so.0", "libxcb-keysyms.so.1"])
    assert main(["view", str(run)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "apt install libxcb-cursor0 libxcb-keysyms1" in err


def test_offscreen_and_snapshot_need_no_xcb(run, tmp_path, monkeypatch):
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    monkeypatch.setattr(display, "missing_libraries", lambda: ["libxcb-cursor.so.0"])
    assert main(["view", str(run), "--snapshot", str(tmp_path / "v.png")]) == 0
    assert os.environ["QT_QPA_PLATFORM"] == "offscreen" and display.platform() == "offscreen"


@pytest.mark.skipif(not display.missing_libraries(), reason="every xcb library is installed")
def test_real_missing_library_exits_2_instead_of_aborting(run):
    env = {k: v for k, v in os.environ.items() if k not in ("QT_QPA_PLATFORM",
                                                            "WAYLAND_DISPLAY")}
    env.update(DISPLAY=":99", PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "nlid_lab.cli", "view", str(run)], env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if "compiling numeric kernels" not in ln]
    assert len(lines) == 1 and "apt install" in lines[0]
