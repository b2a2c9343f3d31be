"""``nlid-lab view RUN.h5... [--snapshot FILE.png]``: browse runs, or render them to PNG."""

from __future__ import annotations

import argparse
import os

from analysis.errors import InputError

from ..outputs import add_force_option, refuse_overwrite
from ..progress import progress
from .repair import check_runs, repair_option


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab view`` on the parsed ``args``; returns the exit code."""
    refuse_overwrite(args.force, args.snapshot)
    try:
        from ..gui import OfflineView, application, check_display, dispose, render
    except ImportError as exc:
        raise InputError(f"the viewer needs the gui extra ({exc.name} is missing): "
                         "pip install 'nlid-lab[gui]'") from None
    from ..reports import all_level_frfs, load_run
    if not args.snapshot and not (os.environ.get("DISPLAY") or os.environ.get(
            "WAYLAND_DISPLAY") or os.environ.get("QT_QPA_PLATFORM")):
        raise InputError("no display to open the viewer on; use --snapshot FILE.png to "
                         "render offscreen")
    if args.snapshot and not os.environ.get("QT_QPA_PLATFORM"):
        os.environ["QT_QPA_PLATFORM"] = "offscreen"     # a snapshot needs no display
    check_display()
    check_runs(args.runs, args.repair)
    runs = [load_run(path) for path in args.runs]
    with progress(total=sum(len(r.recordings) for r in runs), desc="view: FRFs",
                  unit="level") as bar:
        frfs = [all_level_frfs(r, bar.update) for r in runs]
    app = application()
    view = OfflineView(runs, frfs, kind=args.frf_as)
    try:
        if args.snapshot:
            print(render(view, args.snapshot, tuple(args.size)))
        else:
            view.resize(*args.size)
            view.show()
            app.exec()
    finally:
        dispose(view)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``view`` sub-command and its options to ``sub``."""
    p = sub.add_parser("view", help="browse runs: FRFs across levels, coherence, estimates")
    p.add_argument("runs", nargs="+", metavar="RUN", help="run files (.h5) or recordings")
    p.add_argument("--snapshot", metavar="FILE.png", help="render offscreen to a PNG and exit")
    p.add_argument("--frf-as", choices=("displacement", "velocity", "acceleration"),
                   help="draw every FRF as this response kind: receptance, mobility or "
                   "accelerance (default: the first run's kind; other kinds are converted)")
    p.add_argument("--size", type=int, nargs=2, default=(1400, 900), metavar=("W", "H"),
                   help="window / snapshot size in pixels (default 1400 900)")
    add_force_option(p)
    repair_option(p)
    p.set_defaults(func=run)
