"""``nlid-lab import-modes FE.uff --out MODEL.toml``: FE modes (UFF dataset 55) as a
``[modal]`` model at named points (node and direction)."""

from __future__ import annotations

import argparse
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from analysis.models import Model

from ..formats import FEModes, parse_point, read_modes, to_model
from ..outputs import (add_force_option, add_quiet_option, atomic_path, refuse_overwrite,
                       summary_stream, write_json)

_NORMALISATION = {
    "modal mass": "shapes divided by the square root of the file's modal mass",
    "modal A": "complex shapes scaled by sqrt(2 i w_d / modal A) and made real",
    "assumed": "the file gives no modal mass: shapes taken as mass-normalised (unit modal "
               "mass) as written",
}


SCHEMA_VERSION = 1
"""Version of the ``import-modes --json`` layout (`ModesImport.to_json`)."""


@dataclass(frozen=True)
class ImportedMode:
    """One mode of the imported model, with where its damping came from."""

    freq_hz: float
    damping_ratio: float
    damping_from: str             # the file's damping record, or "--damping Z"
    complexity: float


@dataclass(frozen=True)
class ModesImport:
    """What an import made of a UFF file's modes (the ``import-modes`` result)."""

    analysis_type: str            # "normal modes" or "complex modes"
    normalisation: str            # a key of `_NORMALISATION`
    points: tuple[str, ...]
    modes: tuple[ImportedMode, ...]
    skipped_zero_hz: int

    def to_json(self) -> dict[str, Any]:
        """The command's JSON: ``schema_version``, then the fields (modes as objects)."""
        return {"schema_version": SCHEMA_VERSION, "analysis_type": self.analysis_type,
                "normalisation": self.normalisation, "points": list(self.points),
                "modes": [asdict(m) for m in self.modes],
                "skipped_zero_hz": self.skipped_zero_hz}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> ModesImport:
        """The import `to_json` wrote (a later ``schema_version`` refused)."""
        if data.get("schema_version", SCHEMA_VERSION) != SCHEMA_VERSION:
            raise ValueError(f"import-modes JSON schema_version {data['schema_version']}: "
                             f"this nlid-lab reads {SCHEMA_VERSION}; update nlid-lab")
        return cls(data["analysis_type"], data["normalisation"], tuple(data["points"]),
                   tuple(ImportedMode(**m) for m in data["modes"]), data["skipped_zero_hz"])


def summary(modes: FEModes, model: Model, index: np.ndarray, damping: float | None
            ) -> ModesImport:
    """What an import made: modes with the source of their damping, points, normalisation."""
    zeta = np.diag(model.damping) / (2 * np.sqrt(np.diag(model.stiffness)))
    return ModesImport(
        "normal modes" if modes.analysis_type == 2 else "complex modes", modes.normalised_by,
        tuple(model.points),
        tuple(ImportedMode(float(modes.freqs_hz[i]), float(z),
                           modes.damping_source[i] if modes.damping_source[i] != "none"
                           else f"--damping {damping:g}", float(modes.complexity[i]))
              for i, z in zip(index, zeta)),
        len(modes.skipped_hz))


def format_summary(s: ModesImport) -> str:
    """The import's summary for people: points, normalisation, modes with the source of their
    damping."""
    complex_modes = s.analysis_type != "normal modes"
    lines = [f"{len(s.modes)} {s.analysis_type} at {len(s.points)} point(s): "
             + ", ".join(s.points),
             "normalisation: " + _NORMALISATION[s.normalisation],
             "  mode    f [Hz]   zeta [%]  damping from" + ("   complexity" if complex_modes
                                                         else "")]
    for i, m in enumerate(s.modes):
        line = (f"  {i + 1:4d} {m.freq_hz:9.3f} {100 * m.damping_ratio:9.3f}  "
                f"{m.damping_from:<13s}")
        if complex_modes:
            line += f" {100 * m.complexity:8.2f} %"
        lines.append(line.rstrip())
    if s.skipped_zero_hz:
        lines.append(f"skipped {s.skipped_zero_hz} mode(s) at 0 Hz (rigid-body modes have "
                     "no place in [modal])")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab import-modes`` on the parsed ``args``; returns the exit code."""
    refuse_overwrite(args.force, args.out, args.json)
    points = None if args.points is None else [parse_point(p) for p in args.points]
    modes = read_modes(args.file, args.load_case)
    model, index = to_model(modes, points, None if args.band is None else tuple(args.band),
                     args.damping, name=f"FE modes of {Path(args.file).name}")
    with atomic_path(args.out) as tmp:
        model.save(tmp)
    result = summary(modes, model, index, args.damping)
    print(format_summary(result) + f"\nwrote {args.out}", file=summary_stream(args.json,
                                                                             args.quiet))
    write_json(result.to_json(), args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``import-modes`` sub-command and its options to ``sub``."""
    p = sub.add_parser("import-modes",
                       help="FE modes from a universal file (dataset 55) as a [modal] model")
    p.add_argument("file", metavar="FE.uff", help="universal file holding dataset 55 modes")
    p.add_argument("--out", required=True, metavar="MODEL.toml", help="model file to write")
    p.add_argument("--points", nargs="+", metavar="[NAME=]NODE:DIR",
                   help="the model's points: node and direction x, y or z (a sign flips it), "
                   "e.g. tip=12:z (default: every node translation the modes move, named "
                   "NODE:DIR)")
    p.add_argument("--band", nargs=2, type=float, metavar=("LO", "HI"),
                   help="keep the modes in this band, Hz (default: every mode)")
    p.add_argument("--damping", type=float, metavar="Z",
                   help="viscous damping ratio for the modes the file gives no damping")
    p.add_argument("--load-case", type=int, metavar="N",
                   help="load case to read when the file holds several")
    p.add_argument("--json", metavar="FILE", help="write the modes as JSON ('-' for stdout)")
    add_quiet_option(p)
    add_force_option(p)
    p.set_defaults(func=run)
