"""``nlid-lab detect RUN... [--nperseg N] [--json FILE]``: is the structure nonlinear?"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ..outputs import (add_force_option, add_quiet_option, level_text, refuse_overwrite,
                       summary_stream, with_checks, write_json)
from .repair import check_runs, repair_option

if TYPE_CHECKING:
    from analysis.detection import Detection, DetectionTest


def _names(t: DetectionTest) -> tuple[str, str]:
    """The compared levels as people read them (their measured force where no nominal)."""
    names = list(t.labels) or [level_text(v) for v in t.levels]
    return (names + [""])[0], (names + ["", ""])[1]


def format_tests(result: Detection) -> str:
    """One line per test plus the verdict and the notes."""
    from analysis.detection import TestMethod
    lines = []
    for t in result.tests:
        lo, hi = _names(t)
        if t.method == TestMethod.BLA:
            what = (f"BLA distortion (periodic random, {t.realizations} x {t.periods} "
                    f"periods, {lo})")
        elif t.method == TestMethod.LEVEL_DEPENDENCE:
            what = (f"level dependence (random, {lo} vs {hi}, "
                    f"{t.resolution_hz:.3g} Hz lines)")
        elif t.method == TestMethod.SWEEP_HARMONICS:
            what = f"harmonic distortion (swept sine {t.direction}, {lo})"
        elif t.method == TestMethod.SWEEP_HYSTERESIS:
            up, down = t.jumps.up, t.jumps.down
            lines.append(f"sweep-direction hysteresis ({lo} up, {hi} down): jumps at "
                         f"{up.freq_hz:.3f} Hz up{'' if up.jump else ' (none)'}"
                         f" and {down.freq_hz:.3f} Hz down"
                         f"{'' if down.jump else ' (none)'}, {t.separation_hz:+.3f} Hz "
                         f"apart (sweep delay and resolution explain {t.allowed_hz:.3f} Hz): "
                         f"{'NONLINEAR' if t.nonlinear else 'no evidence'}")
            continue
        elif t.method == TestMethod.SWEEP_LEVEL_DEPENDENCE:
            what = f"level dependence (swept sine {t.direction}, {lo} vs {hi}, fundamental)"
        else:
            what = f"level dependence (stepped sine, {lo} vs {hi}, fundamental)"
        band = (f", {t.band_hz[0]:.1f}-{t.band_hz[1]:.1f} Hz" if t.nonlinear else "")
        lines.append(f"{what}: {'NONLINEAR' if t.nonlinear else 'no evidence'} - "
                     f"{100 * t.share_flagged:.1f} % of the lines beyond the noise "
                     f"(chance: up to {100 * t.share_limit:.1f} %){band}")
    lines.append(f"verdict: {result.verdict}")
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab detect`` on the parsed ``args``; returns the exit code."""
    from analysis.detection import detect
    from analysis.recordings import one_kind

    from ..formats import load_recordings
    refuse_overwrite(args.force, args.json)
    checks = check_runs(args.runs, args.repair)
    recs = [one_kind(rec) for path in args.runs for rec in load_recordings(path)]
    result = detect(recs, nperseg=args.nperseg)
    print(format_tests(result), file=summary_stream(args.json, args.quiet))
    write_json(with_checks(result.to_json(), checks), args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``detect`` sub-command and its options to ``sub``."""
    p = sub.add_parser("detect", help="test stored runs for nonlinearity (no model needed)")
    p.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs or NPZ recordings")
    p.add_argument("--nperseg", type=int, help="Welch segment length for random levels")
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    add_force_option(p)
    add_quiet_option(p)
    repair_option(p)
    p.set_defaults(func=run)
