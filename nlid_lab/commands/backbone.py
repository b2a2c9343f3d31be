"""``nlid-lab backbone RUN... [--model MODEL.toml] [--json FILE] [--plot FILE.png]``: natural
frequency and damping ratio of the mode in the run's band against its amplitude, one point per
stepped-sine level; with a model, the model's backbone through the same test beside it
(docs/backbone.md)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from analysis.errors import InputError

from ..outputs import (add_force_option, add_quiet_option, refuse_overwrite, summary_stream,
                       write_json)
from .repair import check_runs, repair_option

if TYPE_CHECKING:
    from analysis.backbone import Backbone
    from analysis.models import Model
    from analysis.recordings import StepTable


def levels(paths: list[str]) -> list[StepTable]:
    """The stepped-sine levels of the runs as tables (time blocks sine-fitted), run order."""
    from analysis.recordings import Excitation, StepTable, one_kind
    from analysis.spectral import recording_table

    from ..formats import load_recordings
    out = []
    for path in paths:
        for rec in load_recordings(path):
            if rec.excitation != Excitation.STEPPED_SINE:
                raise InputError(f"{path}: a backbone needs stepped-sine levels (tables or "
                                 f"time blocks), not {rec.excitation}; fit a model to a "
                                 "sweep with `nlid-lab analyze hbm RUN --model M`")
            rec = one_kind(rec)
            out.append(rec if isinstance(rec, StepTable) else recording_table(rec))
    return out


def format_summary(bb: Backbone) -> str:
    """One line per level: amplitude, frequency and damping with their intervals, fit error."""
    from analysis.spectral import HELD_UNITS

    unit = HELD_UNITS.get(bb.points[0].amplitude_kind, "")
    lines = [f"backbone of the mode at {bb.linear.frequency_hz:.3f} Hz (channel {bb.channel}, "
             f"{bb.control}-controlled; {bb.points[0].method}); 95 % intervals",
             f"  amplitude [{unit}]   f [Hz]                  zeta [%]               "
             "fit error"]
    for p in bb.points:
        df = (p.frequency_ci95[1] - p.frequency_ci95[0]) / 2
        dz = 100 * (p.damping_ci95[1] - p.damping_ci95[0]) / 2
        lines.append(f"  {p.amplitude:12.4g}   {p.frequency_hz:9.4f} +- {df:<9.2g} "
                     f"{100 * p.damping_ratio:8.4f} +- {dz:<9.2g} {100 * p.fit_error:6.2f} %")
    return "\n".join(lines)


def load_model(path: str, tables: list[StepTable]) -> Model:
    """The complete model in ``path``, one DOF per response channel of the levels."""
    from analysis.models import Model

    model = Model.load(path)
    model.require_complete("a backbone of the model")
    if model.n_dof != tables[0].n_dof:
        raise InputError(f"--model {path}: the model has {model.n_dof} DOFs but the levels "
                         f"{tables[0].n_dof} response channels; give the model of these "
                         "channels (fit-linear or diagnose of this run)")
    return model


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab backbone`` on the parsed ``args``; returns the exit code."""
    from analysis.backbone import backbone, model_tables

    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise InputError(f"--plot {args.plot}: the figure is written as PNG; name it *.png")
    refuse_overwrite(args.force, args.plot, args.json)
    check_runs(args.runs, args.repair)
    tables = levels(args.runs)
    model = load_model(args.model, tables) if args.model else None
    bb = backbone(tables, args.channel)
    out = summary_stream(args.json, args.quiet)
    print(format_summary(bb), file=out)
    result = bb.to_json()
    simulated = None
    if model is not None:
        # the model through the same steps, holding what each level held, read alike
        sim = model_tables(model, tables)
        simulated = backbone(sim.tables, bb.channel)
        print(f"the model {args.model} through the same steps (harmonic balance, holding "
              "what each level held):\n" + format_summary(simulated), file=out)
        result["model"] = {"path": str(args.model), **simulated.to_json()}
        if sim.unconverged:      # the key only then: the JSON of a clean run is unchanged
            print(sim.summary(), file=out)
            result["model"]["unconverged_steps"] = [{"level": lv, "frequency_hz": f}
                                                    for lv, f in sim.unconverged]
    if args.plot:
        from ..reports import backbone_figure
        backbone_figure(bb, tables, title=", ".join(Path(r).name for r in args.runs),
                        model=simulated).savefig(args.plot)
    write_json(result, args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``backbone`` sub-command and its options to ``sub``."""
    p = sub.add_parser("backbone", help="natural frequency and damping against amplitude "
                       "from stepped-sine levels")
    p.add_argument("runs", nargs="+", metavar="RUN", help="HDF5 runs or NPZ/CSV recordings of "
                   "stepped-sine levels (tables or time blocks)")
    p.add_argument("--channel", type=int, metavar="J", help="response channel to read "
                   "(default: the held one, else the driving point)")
    p.add_argument("--model", metavar="MODEL.toml", help="also the backbone of this model "
                   "through the same steps (harmonic balance, holding what each level held)")
    p.add_argument("--plot", metavar="PNG", help="write frequency and damping against "
                   "amplitude, with the levels' FRFs and fits")
    p.add_argument("--json", metavar="FILE", help="write the backbone as JSON ('-' for stdout)")
    add_quiet_option(p)
    add_force_option(p)
    repair_option(p)
    p.set_defaults(func=run)
