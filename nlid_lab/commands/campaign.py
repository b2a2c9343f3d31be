"""``nlid-lab campaign run CAMPAIGN.toml --out RUN.h5 [--resume] [--live]`` and
``campaign check``."""

from __future__ import annotations

import argparse
import contextlib
import os
import shlex
import signal
import sys
import threading
from typing import Sequence

from analysis.errors import InputError

from ..outputs import add_quiet_option, refuse_overwrite, summary_stream, write_json
POLL_MS = 100


def run_live(campaign, out: str, *, resume: bool = False, overwrite: bool = False,
             close_when_done: bool = False, observers: Sequence = ()):
    """Run ``campaign`` in a worker thread while the live view shows it (GUI thread).

    The window stays open after the campaign until the user closes it, unless
    ``close_when_done``. Closing the window (or Ctrl-C) while the campaign runs stops it like
    Ctrl-C: drive to zero, run marked interrupted, `KeyboardInterrupt`. Returns the
    `CampaignResult`; re-raises the campaign's error in this thread. ``observers`` are told
    of the campaign besides the view.
    """
    try:
        from PySide6 import QtCore

        from ..gui import LiveView, application, check_display, dispose
    except ImportError as exc:
        raise InputError(f"--live needs the gui extra ({exc.name} is missing): "
                         "pip install 'nlid-lab[gui]', or run without --live") from None
    from ..campaign import run_campaign
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
            or os.environ.get("QT_QPA_PLATFORM")):
        raise InputError("--live: no display to open the live view on; run without --live "
                         "(progress is printed) or set DISPLAY")
    check_display()
    app = application()
    view = LiveView()
    view.setWindowTitle(f"nlid-lab live: {campaign.name} -> {out}")
    stop, outcome = threading.Event(), {}

    def work() -> None:
        try:
            outcome["result"] = run_campaign(campaign, out, resume=resume,
                                             overwrite=overwrite,
                                             observer=[view.observer, *observers], stop=stop)
        except BaseException as exc:  # noqa: BLE001 - handed to the GUI thread below
            outcome["error"] = exc

    worker = threading.Thread(target=work, name="campaign", daemon=True)
    loop = QtCore.QEventLoop()

    def poll() -> None:
        if not worker.is_alive() and close_when_done and view.isVisible():
            view.drain()
            view.close()
        if not view.isVisible():
            stop.set()  # window closed: end the campaign (no-op once it has finished)
            if not worker.is_alive():
                loop.quit()

    timer = QtCore.QTimer()
    timer.timeout.connect(poll)
    main_thread = threading.current_thread() is threading.main_thread()
    old_handler = signal.signal(signal.SIGINT, lambda *_: view.close()) if main_thread \
        else None
    try:
        view.resize(1400, 900)
        view.show()
        worker.start()
        timer.start(POLL_MS)  # also lets Python run the SIGINT handler while Qt waits
        loop.exec()
    finally:
        timer.stop()
        stop.set()
        worker.join()
        if main_thread:
            signal.signal(signal.SIGINT, old_handler)
        dispose(view)
        app.processEvents()
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]


@contextlib.contextmanager
def _ctrl_c_stops():
    """An event that Ctrl-C sets, for `run_campaign`'s ``stop``.

    A plain `KeyboardInterrupt` is raised wherever Python happens to be, and Python swallows
    one raised inside a finaliser or weakref callback ("Exception ignored in ..."): the
    campaign would then run to its end. The event is checked at every DAQ chunk instead, so
    Ctrl-C always ends the campaign there; a second Ctrl-C interrupts at once.
    """
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(signum, frame) -> None:
        if stop.is_set():
            raise KeyboardInterrupt
        stop.set()

    old = signal.signal(signal.SIGINT, handler)
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, old)


class _Started:
    """Observer noting that the campaign got as far as its run file."""

    started = False

    def campaign_started(self, info) -> None:
        self.started = True


def resume_command(args: argparse.Namespace) -> str:
    """The command line that continues this campaign run (same files and confirmations)."""
    argv = ["nlid-lab", "campaign", "run", args.campaign, "--out", args.out, "--resume"]
    argv += ["--live"] * args.live + ["--live-close"] * args.live_close + ["--yes"] * args.yes
    argv += ["--json", args.json, *["--force"] * args.force] if args.json else []
    return shlex.join(argv + ["--quiet"] * args.quiet)


def _kept(args: argparse.Namespace, unit: str, planned: int) -> str:
    """What a stopped campaign kept in its run file, in a few words."""
    from ..store import open_run

    try:
        run = open_run(args.out)
    except Exception as exc:  # noqa: BLE001 - the interruption is the news, not this
        return (f"{args.out} could not be read ({exc}); `nlid-lab repair "
                f"{shlex.quote(args.out)}` may recover it")
    done = sum(lv.complete for lv in run.levels)
    levels = ", ".join(f"level {lv.index + 1}: {lv.n_segments}/{planned}"
                       f"{' (complete)' if lv.complete else ''}" for lv in run.levels)
    return (f"kept {sum(lv.n_segments for lv in run.levels)} {unit}s ({levels}; {done} of "
            f"{len(run.levels)} level(s) complete) in {args.out}, marked {run.status}")


def _say_interrupted(args: argparse.Namespace, unit: str, planned: int,
                     started: bool) -> None:
    """What an interrupted campaign kept, and how to continue it (stderr, even --quiet)."""
    if not started:
        print(f"campaign interrupted before {args.out} was opened: nothing recorded; run the "
              "same command again", file=sys.stderr)
        return
    print(f"campaign interrupted: {_kept(args, unit, planned)}", file=sys.stderr)
    print(f"continue it with: {resume_command(args)}", file=sys.stderr)


def _run(args: argparse.Namespace) -> int:
    from ..campaign import run_campaign
    from ..campaign import load_campaign, load_plant_model
    from ..progress import CampaignProgress
    from ..store import DiskFullError

    refuse_overwrite(args.force, None if args.resume else args.out, args.json)
    campaign = load_campaign(args.campaign)
    excess = campaign.plan_excess(load_plant_model(campaign) if campaign.plant else None)
    if excess and not args.yes:
        raise InputError(f"{args.campaign}: {excess} ({campaign.plan_summary()}); shorten the "
                         "plan (fewer levels, averages or steps, smaller blocks) or pass --yes "
                         "to run it")
    say = summary_stream("-", args.quiet)      # stdout is for --json -
    print(f"campaign '{campaign.name}': {campaign.plan_summary()}", file=say)
    overwrite = args.force and not args.resume
    started = _Started()
    observers = [started] + ([] if args.quiet else [CampaignProgress(sys.stderr)])
    unit, planned = campaign.plan.unit, campaign.plan.per_level
    try:
        if args.live or args.live_close:
            result = run_live(campaign, args.out, resume=args.resume, overwrite=overwrite,
                              close_when_done=args.live_close, observers=observers)
        else:
            with _ctrl_c_stops() as stop:
                result = run_campaign(campaign, args.out, resume=args.resume,
                                      overwrite=overwrite, observer=observers, stop=stop)
    except KeyboardInterrupt:
        _say_interrupted(args, unit, planned, started.started)
        raise
    except DiskFullError as exc:
        if not started.started:
            raise
        raise DiskFullError(f"{exc}; campaign stopped, drive at zero: "
                            f"{_kept(args, unit, planned)}; free space, then continue with: "
                            f"{resume_command(args)}") from None
    write_json(result.to_json(), args.json)
    lost = (f", lost {result.lost_samples} samples in {result.lost_frames} frames (counted in "
            "the run)" if result.lost_samples or result.lost_frames else "")
    print(f"campaign '{campaign.name}' {result.status}: {sum(result.segments.values())} "
          f"{unit}s in {len(result.segments)} level(s) -> {args.out}{lost}", file=say)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    return 0


def _check(args: argparse.Namespace) -> int:
    from ..campaign import load_campaign, load_plant_model

    c = load_campaign(args.campaign)
    excess = c.plan_excess(load_plant_model(c) if c.plant is not None else None)
    print(f"{args.campaign}: valid {c.plan.title} campaign, {len(c.levels)} level(s) x "
          f"{c.plan.per_level} {c.plan.unit}s, "
          f"shaker {c.shaker_url}, DAQ {c.daq_url}; {c.plan_summary()}"
          f"{f'; {excess}: campaign run needs --yes' if excess else ''}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``campaign`` sub-command and its options to ``sub``."""

    p = sub.add_parser("campaign", help="run a test campaign (shaker + DAQ -> HDF5 run)")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    run = actions.add_parser("run", help="run a campaign file")
    run.add_argument("campaign", metavar="CAMPAIGN.toml")
    run.add_argument("--out", required=True, metavar="RUN.h5", help="run file to write")
    run.add_argument("--resume", action="store_true",
                     help="continue an interrupted run at its first incomplete block/step")
    run.add_argument("--live", action="store_true",
                     help="show the live view while the campaign runs; the window stays "
                          "open at the end until closed (closing it early stops the "
                          "campaign, resumable)")
    run.add_argument("--live-close", action="store_true",
                     help="with --live (implies it): close the window when the campaign ends")
    run.add_argument("--json", metavar="FILE", help="write the summary as JSON ('-': stdout)")
    run.add_argument("--force", action="store_true",
                     help="replace an existing run file / JSON file (default: refuse)")
    run.add_argument("--yes", action="store_true",
                     help="run a plan longer than 1 h of measurement or larger than 2 GB of "
                          "data (refused without it; `campaign check` shows the plan)")
    add_quiet_option(run)
    run.set_defaults(func=_run)
    check = actions.add_parser("check", help="validate a campaign file without running it")
    check.add_argument("campaign", metavar="CAMPAIGN.toml")
    check.set_defaults(func=_check)
