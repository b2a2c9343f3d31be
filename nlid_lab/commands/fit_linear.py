"""``nlid-lab fit-linear RUN... --out MODEL.toml``: a test-derived ``[modal]`` model from the
lowest level of a run (stabilisation diagram, mode shapes at every channel, residuals, MAC)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from analysis.errors import InputError

from ..outputs import (add_force_option, add_quiet_option, atomic_path, refuse_overwrite,
                       summary_stream, with_checks, write_json)
from .repair import check_runs, repair_option

if TYPE_CHECKING:
    from analysis.modal import DelayReading, LinearFitSummary


def format_summary(s: LinearFitSummary, kind: str) -> str:
    """The fit's summary for people: modes table, residual pseudo-modes, in-band FRF error in
    the measured response ``kind``, interference left out."""
    lines = [f"{len(s.modes)} mode(s) in {s.band_hz[0]:.4g}-{s.band_hz[1]:.4g} Hz from "
             f"the {s.method}; shapes mass-normalised at the driving point "
             f"'{s.driving_point}'",
             "  mode   f [Hz]   zeta [%]  stable  max MAC to another mode"]
    for i, m in enumerate(s.modes):
        lines.append(f"  {i + 1:4d} {m.freq_hz:8.3f} {100 * m.damping_ratio:9.3f} "
                     f"{100 * m.support:6.0f} % {m.max_mac_other:8.3f}")
    if s.residual_pseudo_modes_hz:
        lines.append("residual pseudo-modes at " + ", ".join(
            f"{f:.4g} Hz" for f in s.residual_pseudo_modes_hz) + " (the modes outside the band)")
    lines.append(f"in-band FRF error of the model ({kind}): " + ", ".join(
        f"{p} {100 * e:.1f} %" for p, e in zip(s.points, s.frf_error)))
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab fit-linear`` on the parsed ``args``; returns the exit code."""
    from analysis.modal import LinearFitSummary, fit_linear
    from analysis.recordings import one_kind, record_level
    from analysis.spectral import level_name

    from ..formats import load_recordings
    refuse_overwrite(args.force, args.out, args.json, args.plot)
    checks = check_runs(args.runs, args.repair)
    recs = [one_kind(rec) for path in args.runs for rec in load_recordings(path)]
    if args.level is None:
        rec = min(recs, key=record_level)
    elif 0 <= args.level < len(recs):
        rec = recs[args.level]
    else:
        raise InputError(f"--level {args.level}: the runs hold levels 0..{len(recs) - 1} "
                         "(stored order)")
    points = None if args.points is None else [p.strip() for p in args.points.split(",")]
    if points is None and rec.sensors is not None:      # the sensor map names the points
        points = list(rec.sensors.response_points)
    n_modes = None if args.modes == "auto" else _modes(args.modes)
    fit = fit_linear(rec, None if args.band is None else tuple(args.band), n_modes=n_modes,
                     points=points, name=f"fit-linear of {Path(args.runs[0]).name}")
    with atomic_path(args.out) as tmp:
        fit.model.save(tmp)
    if args.plot:
        from ..reports import stabilisation
        with atomic_path(args.plot) as tmp:
            stabilisation(fit).savefig(tmp)
    result = LinearFitSummary.of(fit, rec.level)
    said = "".join(f"; {', '.join(i.text() for i in result.interference)}, left out"
                   for _ in result.interference[:1])
    said += _delay_said(result.delay)
    text = (f"fitted on {level_name(rec)}{said}\n"
            + format_summary(result, rec.response_kind)
            + f"\nwrote {args.out}" + (f" and {args.plot}" if args.plot else ""))
    print(text, file=summary_stream(args.json, args.quiet))
    caveat = () if result.caveat is None else (result.caveat.text(),)
    for warning in result.warnings + caveat:
        print(f"warning: {warning}", file=sys.stderr)
    write_json(with_checks(result.to_json(), checks), args.json)
    return 0


def _delay_said(delay: DelayReading) -> str:
    """The summary line's words on the responses' delay taken out (none: ""): stated to the
    resolution its 95 % interval gives, with the interval, and the importer's
    ``response_delay=`` that stores the run aligned when the interval excludes 0."""
    if not delay.samples:
        return ""
    said = f"; {delay.text()}: taken out of the FRF before the fit"
    if delay.resolved:
        said += ("; diagnose and analyze read the run as recorded: import it again with "
                 f"response_delay={delay.stated:g} in the --map first")
    return said


def _modes(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise InputError(f"--modes {text}: give a number of modes >= 1 or 'auto'")
    return n


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``fit-linear`` sub-command and its options to ``sub``."""
    p = sub.add_parser("fit-linear", help="fit a modal model ([modal] form) to a low level")
    p.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs, NPZ or CSV recordings")
    p.add_argument("--out", required=True, metavar="MODEL.toml", help="model file to write")
    p.add_argument("--band", nargs=2, type=float, metavar=("LO", "HI"),
                   help="fit band, Hz (default: the excited lines)")
    p.add_argument("--modes", default="auto", metavar="N|auto",
                   help="number of modes (default auto: the stabilisation diagram)")
    p.add_argument("--level", type=int, metavar="INDEX",
                   help="level to fit, 0-based in stored order (default: the lowest)")
    p.add_argument("--points", metavar="NAME,...",
                   help="names of the response channels (the model's points; default: "
                   "the run's sensor map, else 0,1,...)")
    p.add_argument("--plot", metavar="PNG", help="write the stabilisation diagram")
    p.add_argument("--json", metavar="FILE", help="write the modes as JSON ('-' for stdout)")
    add_quiet_option(p)
    add_force_option(p)
    repair_option(p)
    p.set_defaults(func=run)
