"""``nlid-lab campaign run CAMPAIGN.toml --out RUN.h5 [--resume] [--live]`` and
``campaign check``."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading

from analysis.errors import InputError

POLL_MS = 100


def run_live(campaign, out: str, *, resume: bool = False, overwrite: bool = False,
             close_when_done: bool = False):
    """Run ``campaign`` in a worker thread while the live view shows it (GUI thread).

    The window stays open after the campaign until the user closes it, unless
    ``close_when_done``. Closing the window (or Ctrl-C) while the campaign runs stops it like
    Ctrl-C: drive to zero, run marked interrupted, `KeyboardInterrupt`. Returns the
    `CampaignResult`; re-raises the campaign's error in this thread.
    """
    try:
        from PySide6 import QtCore

        from ..gui import snapshot
        from ..gui.display import check_display
        from ..gui.live import LiveView
    except ImportError as exc:
        raise InputError(f"--live needs the gui extra ({exc.name} is missing): "
                         "pip install 'nlid-lab[gui]', or run without --live") from None
    from ..campaign import run_campaign
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
            or os.environ.get("QT_QPA_PLATFORM")):
        raise InputError("--live: no display to open the live view on; run without --live "
                         "(progress is printed) or set DISPLAY")
    check_display()
    app = snapshot.application()
    view = LiveView()
    view.setWindowTitle(f"nlid-lab live: {campaign.name} -> {out}")
    stop, outcome = threading.Event(), {}

    def work() -> None:
        try:
            outcome["result"] = run_campaign(campaign, out, resume=resume,
                                             overwrite=overwrite, observer=view.observer,
                                             stop=stop)
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
        snapshot.dispose(view)
        app.processEvents()
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]


def _run(args: argparse.Namespace) -> int:
    from ..campaign import run_campaign
    from ..campaign_config import load_campaign, load_plant_model
    from ..outputs import refuse_overwrite, write_json

    refuse_overwrite(args.force, None if args.resume else args.out, args.json)
    campaign = load_campaign(args.campaign)
    excess = campaign.plan_excess(load_plant_model(campaign) if campaign.plant else None)
    if excess and not args.yes:
        raise InputError(f"{args.campaign}: {excess} ({campaign.plan_summary()}); shorten the "
                         "plan (fewer levels, averages or steps, smaller blocks) or pass --yes "
                         "to run it")
    print(f"campaign '{campaign.name}': {campaign.plan_summary()}", file=sys.stderr)
    overwrite = args.force and not args.resume
    if args.live or args.live_close:
        result = run_live(campaign, args.out, resume=args.resume, overwrite=overwrite,
                          close_when_done=args.live_close)
    else:
        result = run_campaign(campaign, args.out, resume=args.resume, overwrite=overwrite)
    write_json(result.as_dict(), args.json)
    lost = (f", lost {result.lost_samples} samples in {result.lost_frames} frames (counted in "
            "the run)" if result.lost_samples or result.lost_frames else "")
    print(f"campaign '{campaign.name}' {result.status}: "
          f"{sum(result.segments.values())} {'blocks' if campaign.kind == 'random' else 'steps'}"
          f" in {len(result.segments)} level(s) -> {args.out}{lost}", file=sys.stderr)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    return 0


def _check(args: argparse.Namespace) -> int:
    from ..campaign_config import load_campaign, load_plant_model

    c = load_campaign(args.campaign)
    excess = c.plan_excess(load_plant_model(c) if c.plant is not None else None)
    n = c.plan.averages if c.kind == "random" else len(c.plan.freqs)
    unit = "steps" if c.kind != "random" else ("realizations" if c.plan.periodic else "blocks")
    kind = "periodic-random" if c.kind == "random" and c.plan.periodic else c.kind
    print(f"{args.campaign}: valid {kind} campaign, {len(c.levels)} level(s) x {n} {unit}, "
          f"shaker {c.shaker_url}, DAQ {c.daq_url}; {c.plan_summary()}"
          f"{f'; {excess}: campaign run needs --yes' if excess else ''}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
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
    run.set_defaults(func=_run)
    check = actions.add_parser("check", help="validate a campaign file without running it")
    check.add_argument("campaign", metavar="CAMPAIGN.toml")
    check.set_defaults(func=_check)
