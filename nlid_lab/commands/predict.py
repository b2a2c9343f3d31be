"""``nlid-lab predict MODEL.toml --force-dof D --amplitude A... --band LO HI [--step DF]``:
what the model predicts a sine test shows, through the folds (harmonic balance + arc-length
continuation), or as a stepped-sine test steps it (``--step``: fixed frequencies, each step
solved from the previous one).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from analysis.errors import InputError

from ..outputs import (add_force_option, add_quiet_option, atomic_path, refuse_overwrite,
                       summary_stream, write_json)

if TYPE_CHECKING:
    from analysis.hbm import Branch, HBMSystem


@dataclass(frozen=True)
class Peak:
    """The largest fundamental amplitude of one DOF on a curve, as displacement, velocity
    and acceleration at its frequency."""

    freq: float
    displacement: float
    velocity: float
    acceleration: float

    @classmethod
    def of(cls, branch: Branch, dof: int) -> Peak:
        """The peak of ``dof`` on ``branch``."""
        amp = branch.amplitude(dof)
        i = int(np.argmax(amp))
        w = 2 * np.pi * float(branch.freqs[i])
        return cls(float(branch.freqs[i]), float(amp[i]), float(amp[i] * w),
                   float(amp[i] * w**2))

    def to_json(self) -> dict[str, float]:
        """``{"freq", "displacement", "velocity", "acceleration"}``."""
        return {"freq": self.freq, "displacement": self.displacement,
                "velocity": self.velocity, "acceleration": self.acceleration}


@dataclass(frozen=True)
class Fold:
    """A fold of a curve: its frequency and the amplitude of every reported DOF there."""

    freq: float
    amplitude: Mapping[int, float]

    def to_json(self) -> dict[str, Any]:
        """``{"freq", "amplitude": {dof: value}}`` (DOFs as strings)."""
        return {"freq": self.freq, "amplitude": {str(d): a for d, a in self.amplitude.items()}}


@dataclass(frozen=True)
class Curve:
    """One predicted response curve of the reported DOFs (one force amplitude)."""

    force_amplitude: float
    branch: Branch
    dofs: tuple[int, ...]
    complete: bool                    # reached the end of the band

    @classmethod
    def of(cls, branch: Branch, amplitude: float, f_end: float, dofs: list[int]) -> Curve:
        """The curve ``branch`` traced at force ``amplitude`` towards ``f_end``."""
        reached = bool((branch.freqs[-1] - f_end) * np.sign(f_end - branch.freqs[0]) >= 0)
        return cls(amplitude, branch, tuple(dofs), reached)

    def peak(self, dof: int) -> Peak:
        """The peak of ``dof``."""
        return Peak.of(self.branch, dof)

    def folds(self) -> list[Fold]:
        """The folds, in the order traced."""
        b = self.branch
        return [Fold(float(b.freqs[i]), {d: float(b.amplitude(d)[i]) for d in self.dofs})
                for i in b.folds]

    def to_json(self) -> dict[str, Any]:
        """One entry of the command's ``curves`` (docs/hbm.md)."""
        b = self.branch
        return {
            "force_amplitude": self.force_amplitude,
            "freqs": b.freqs,
            "amplitude": {str(d): b.amplitude(d) for d in self.dofs},
            "peak": {str(d): self.peak(d).to_json() for d in self.dofs},
            "stable": b.stable,
            "folds": [f.to_json() for f in self.folds()],
            "complete": self.complete,
        }


SCHEMA_VERSION = 1
"""Version of `Prediction`'s JSON (``schema_version``)."""


@dataclass(frozen=True)
class Prediction:
    """What ``nlid-lab predict`` computed: the model's curves, one per force amplitude."""

    model: str
    force_dof: int
    harmonics: tuple[int, ...]
    band_hz: tuple[float, float]
    method: str                       # "continuation" or "stepped"
    curves: tuple[Curve, ...]

    def to_json(self) -> dict[str, Any]:
        """The command's JSON (docs/hbm.md), ``schema_version`` first."""
        return {"schema_version": SCHEMA_VERSION, "model": self.model,
                "force_dof": self.force_dof, "harmonics": list(self.harmonics),
                "band_hz": list(self.band_hz), "method": self.method,
                "curves": [c.to_json() for c in self.curves]}


def _stepped(system: HBMSystem, lo: float, hi: float, step: float,
             amplitudes: list[float]) -> list[Branch]:
    """Curves as a stepped-sine test gives them: frequencies from ``lo`` to ``hi`` every
    ``step`` Hz, each solved from the previous step's response (a fold is jumped, as the test
    jumps it); ``stable`` holds whether each step's balance converged."""
    from analysis.hbm import Branch
    n = max(int(np.ceil(abs(hi - lo) / step - 1e-9)), 1) + 1
    freqs = np.linspace(lo, hi, n)          # steps of at most ``step``, both ends included
    out = []
    for a in amplitudes:
        res = system.sweep(freqs, np.full((n, 1), a))
        out.append(Branch(freqs, res.X, np.asarray(res.converged, dtype=bool),
                          np.zeros(0, dtype=int)))
    return out


def _summary(curves: Sequence[Curve], dof: int) -> str:
    lines = []
    for c in curves:
        text = _peak_line(c, dof)
        folds = c.folds()
        if folds:
            text += "; folds at " + ", ".join(f"{f.freq:.3f}" for f in folds) + " Hz" \
                    " (jump between them in a sweep; the branch between is unstable)"
        if not c.complete:
            text += f"; stopped at {c.branch.freqs[-1]:.3f} Hz (continuation step underflow)"
        lines.append(text)
    return "\n".join(lines)


def _peak_line(curve: Curve, dof: int) -> str:
    p = curve.peak(dof)
    return (f"{curve.force_amplitude:g} N: peak {p.displacement:.4g} m, "
            f"{p.acceleration:.4g} m/s² at {p.freq:.3f} Hz (DOF {dof}, fundamental)")


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab predict`` on the parsed ``args``; returns the exit code."""
    from analysis.hbm import response_curves
    from analysis.hbm import HBMSystem
    from analysis.models import Model

    lo, hi = args.band
    if not (0 < lo and 0 < hi and lo != hi):
        raise InputError(f"--band {lo:g} {hi:g}: give two different positive frequencies (Hz)")
    if args.step is not None and not args.step > 0:
        raise InputError(f"--step {args.step:g}: give a positive frequency step (Hz)")
    if args.plot and Path(args.plot).suffix.lower() != ".png":
        raise InputError(f"--plot {args.plot}: the figure is written as PNG; name it *.png")
    refuse_overwrite(args.force, args.plot, args.json)
    model = Model.load(args.model)
    model.require_complete("a prediction")
    dofs = args.dof if args.dof is not None else list(range(model.n_dof))
    bad = [d for d in dofs + [args.force_dof] if not 0 <= d < model.n_dof]
    if bad:
        raise InputError(f"DOF {bad[0]} outside the model's DOFs 0..{model.n_dof - 1} "
                         "(0-based)")
    system = HBMSystem(model, [args.force_dof], args.harmonics)
    if args.step is None:
        branches = response_curves(system, lo, hi, args.amplitude)
    else:
        branches = _stepped(system, lo, hi, args.step, args.amplitude)
    curves = tuple(Curve.of(b, a, hi, dofs) for b, a in zip(branches, args.amplitude))
    result = Prediction(model.name, args.force_dof, tuple(int(h) for h in system.harmonics),
                        (lo, hi),
                        "continuation" if args.step is None else "stepped", curves)
    shown = dofs[0] if args.dof is not None else args.force_dof
    out = summary_stream(args.json, args.quiet)
    print(_summary(curves, shown), file=out)
    if args.plot:
        from ..reports import response_curves as figure
        with atomic_path(args.plot) as tmp:
            figure(branches, args.amplitude, shown, model.name, (lo, hi)).savefig(tmp)
        print(f"figure: {args.plot}", file=out)
    write_json(result.to_json(), args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``predict`` sub-command and its options to ``sub``."""
    p = sub.add_parser("predict", help="model's forced-response curves through folds, with "
                       "stability (harmonic balance + continuation)")
    p.add_argument("model", metavar="MODEL.toml", help="complete model (every parameter given)")
    p.add_argument("--force-dof", type=int, default=0, help="DOF of the sine force (default 0)")
    p.add_argument("--amplitude", type=float, nargs="+", required=True, metavar="N",
                   help="force amplitude(s), N: one curve each")
    p.add_argument("--band", type=float, nargs=2, required=True, metavar=("LO", "HI"),
                   help="sweep from LO to HI Hz (start off resonance, on a stable branch)")
    p.add_argument("--step", type=float, metavar="DF",
                   help="step the frequency every DF Hz from LO to HI as a stepped-sine test "
                        "does (each step from the previous one; folds jumped, not traced)")
    p.add_argument("--dof", type=int, nargs="+", help="response DOFs to report (default all)")
    p.add_argument("--harmonics", default="1,3,5,7", help="harmonic orders (default 1,3,5,7)")
    p.add_argument("--plot", metavar="FILE.png", help="draw the curves (unstable dashed)")
    p.add_argument("--json", metavar="FILE", help="write the curves as JSON ('-' for stdout)")
    add_force_option(p)
    add_quiet_option(p)
    p.set_defaults(func=run)
