"""Regenerate the pictures in docs/img/ (``make screenshots``): report, viewer and live view.

Runs everything on the built-in simulated rig, in a work directory (default
``build/screenshots``; runs already there are reused):

1. ``nlid-lab demo`` (random, four levels, reverse path stored), a diagnosis of its run
   against the model without the nonlinear elements (stored), and the stepped-sine example
   campaign with ``analyze hbm --store``; ``nlid-lab report`` of both runs.
2. Report pages rendered by headless Chromium (``chromium --headless --screenshot``) and a
   few report figures copied as they are.
3. The viewer and the live view (the stepped, random and periodic-random example campaigns
   fed to it as they run) on a real X server: Xvfb on ``--display`` (default :99) when no
   DISPLAY is set, grabbed with ``QWidget.grab()``.

Every PNG is reduced to an adaptive 256-colour palette when that keeps it under
`MAX_BYTES`. Existing pictures are replaced only with ``--force``.

    python tools/screenshots.py [--work DIR] [--out docs/img] [--force]
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_BYTES = 300_000
EXAMPLES = ROOT / "examples"


def cli(*args: str) -> None:
    """Run one ``nlid-lab`` command (this checkout first on the path); fail loudly."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-m", "nlid_lab.cli", *args], check=True, env=env,
                   cwd=ROOT)


def save_png(data: bytes, dest: Path) -> None:
    """Write ``data`` (a PNG) to ``dest``, palette-reduced when that brings it under
    `MAX_BYTES`; says when it stays larger."""
    from PIL import Image
    img = Image.open(io.BytesIO(data)).convert("RGB")
    for colours in (256, 128, 64):
        buf = io.BytesIO()
        img.quantize(colours, method=Image.Quantize.MEDIANCUT).save(buf, "PNG", optimize=True)
        if buf.tell() <= MAX_BYTES:
            break
    dest.write_bytes(buf.getvalue())
    size = dest.stat().st_size
    print(f"{dest.relative_to(ROOT) if dest.is_relative_to(ROOT) else dest}: "
          f"{img.width}x{img.height}, {size / 1000:.0f} kB"
          + ("  (over the 300 kB budget)" if size > MAX_BYTES else ""))


# --- data ------------------------------------------------------------------------------------
def make_runs(work: Path) -> dict[str, Path]:
    """Demo run (random, four levels) with reverse path and a diagnosis stored; stepped run
    with the harmonic-balance fit stored. Reused when present."""
    from analysis.models import Model

    demo = work / "demo" / "sdof-random.h5"
    if not demo.exists():
        cli("demo", "--out", str(work / "demo"), "--force")
        model = Model.load(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")
        linear = work / "sdof-linear.toml"
        model.with_elements([]).save(linear)
        cli("diagnose", str(linear), str(demo), "--store", str(demo), "--json",
            str(work / "diagnosis.json"), "--force")
    stepped = work / "stepped.h5"
    if not stepped.exists():
        cli("campaign", "run", str(EXAMPLES / "campaign-sim-stepped.toml"), "--out",
            str(stepped), "--yes")
        model = Model.load(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")
        cand = work / "sdof-candidate.toml"
        model.with_elements([type(e)(e.kind, e.w, {}) for e in model.elements]).save(cand)
        cli("analyze", "hbm", str(stepped), "--model", str(cand), "--store", str(stepped))
    return {"demo": demo, "stepped": stepped}


# --- report ----------------------------------------------------------------------------------
def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    sys.exit("tools/screenshots.py: no chromium found (Debian: apt install chromium)")


def report_shots(runs: dict[str, Path], work: Path, out: Path) -> None:
    for name, run in runs.items():
        rep = work / f"report-{name}"
        cli("report", str(run), "--out", str(rep), "--force")
        png = work / f"report-{name}-page.png"
        subprocess.run([chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                        "--hide-scrollbars", f"--screenshot={png}", "--window-size=1000,1500",
                        (rep / "index.html").as_uri()], check=True, capture_output=True)
        save_png(png.read_bytes(), out / f"report-{name}-page.png")
    figures = {"report-frf-levels.png": work / "report-demo" / "frf_levels_out0_in0.png",
               "report-coefficients.png": work / "report-demo"
               / "reverse_path_linear_coefficients_in0.png",
               "report-diagnosis.png": work / "report-demo" / "diagnosis_fit.png",
               "report-hbm-fit.png": work / "report-stepped" / "hbm_fit_out0.png"}
    for dest, src in figures.items():
        if src.exists():
            save_png(src.read_bytes(), out / dest)
        else:
            print(f"{src} not written by the report; {dest} left as it was")


# --- Qt views --------------------------------------------------------------------------------
def start_display(display: str) -> subprocess.Popen | None:
    """Xvfb on ``display`` unless a display is already set (returns the server to stop)."""
    if os.environ.get("DISPLAY"):
        return None
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        sys.exit("tools/screenshots.py: no DISPLAY and no Xvfb (Debian: apt install xvfb)")
    server = subprocess.Popen([xvfb, display, "-screen", "0", "1600x1000x24", "-nolisten",
                               "tcp"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    if server.poll() is not None:
        sys.exit(f"tools/screenshots.py: Xvfb {display} did not start (display in use?)")
    os.environ["DISPLAY"] = display
    os.environ.pop("QT_QPA_PLATFORM", None)
    return server


def grab(app, widget, dest: Path, size: tuple[int, int]) -> None:
    from PySide6 import QtCore
    widget.resize(*size)
    widget.show()
    end = time.monotonic() + 1.0
    while time.monotonic() < end:          # layout, pyqtgraph's deferred ranges, paint
        app.processEvents()
        time.sleep(0.02)
    buf = QtCore.QBuffer()
    buf.open(QtCore.QIODevice.OpenModeFlag.WriteOnly)
    widget.grab().save(buf, "PNG")
    save_png(bytes(buf.data()), dest)


def view_shots(app, runs: dict[str, Path], out: Path) -> None:
    from nlid_lab.gui import OfflineView
    from nlid_lab.gui import dispose
    from nlid_lab.reports import all_level_frfs, load_run

    for dest, paths in (("view-demo.png", [runs["demo"]]),
                        ("view-stepped.png", [runs["stepped"]])):
        loaded = [load_run(p) for p in paths]
        view = OfflineView(loaded, [all_level_frfs(r) for r in loaded])
        grab(app, view, out / dest, (1400, 900))
        dispose(view)


def live_shots(app, work: Path, out: Path) -> None:
    from nlid_lab.campaign import run_campaign
    from nlid_lab.campaign import load_campaign
    from nlid_lab.gui import LiveView
    from nlid_lab.gui import dispose

    for name in ("stepped", "random", "periodic"):
        camp = load_campaign(EXAMPLES / f"campaign-sim-{name}.toml")
        if name == "periodic":                     # a short campaign shows the same panels
            camp.plan.averages, camp.plan.periods = 4, 2
        run = work / f"live-{name}.h5"
        run.unlink(missing_ok=True)
        view = LiveView()
        view.resize(1400, 900)
        view.show()
        th = threading.Thread(target=run_campaign, args=(camp, run),
                              kwargs={"observer": view.observer})
        th.start()
        while th.is_alive() or view.status == "running":
            app.processEvents()
            time.sleep(0.02)
        th.join()
        grab(app, view, out / f"live-{name}.png", (1400, 900))
        dispose(view)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--work", type=Path, default=ROOT / "build" / "screenshots")
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    p.add_argument("--display", default=":99", help="Xvfb display when none is set")
    p.add_argument("--force", action="store_true", help="replace existing pictures")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.force and any(args.out.glob("*.png")):
        sys.exit(f"tools/screenshots.py: {args.out} holds pictures; pass --force to "
                 "replace them")
    args.work.mkdir(parents=True, exist_ok=True)
    sys.path.insert(0, str(ROOT))
    runs = make_runs(args.work)
    report_shots(runs, args.work, args.out)
    server = start_display(args.display)
    try:
        from nlid_lab.gui import application
        app = application()
        view_shots(app, runs, args.out)
        live_shots(app, args.work, args.out)
    finally:
        if server is not None:
            server.terminate()
            server.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
