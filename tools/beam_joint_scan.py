"""A joint model for the Brake-Reuss beam's backbone (docs/backbone.md, "Toward a joint
model"): a hysteresis element (paper eq 34, Masing) at the measured point on the lowest
level's mode, its underlying (slipped) frequency scanned, kd, fd and n fitted by harmonic
balance (`nlid-lab analyze hbm`) to the 8 response-controlled levels; each model's
resonance peaks at the forces that held the levels are compared with the held amplitudes.

    python tools/beam_joint_scan.py [--freqs 76 77 78 78.5 79 80] [--out DIR]

Needs ../shared/real/brake-reuss-beam/ (exits 2 when absent). Prints one line per scanned
frequency: the fit's cost (eq 33) and the peak error at each level, and the linear model's.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MAT = ROOT / ".." / "shared" / "real" / "brake-reuss-beam" / "ResponseControl.mat"
MAP = ["table=FRdata.ResponseControl", "freqs=frequency", "force_amplitude=force:N",
       "response_amplitude=amplitude:m/s^2", "response_phase=phase:receptance",
       "control=response"]


def peak_errors(model, tables) -> list[float]:
    """Relative error of the model's resonance peak (acceleration at the point) at the force
    of each level's peak step, against the amplitude the level held there."""
    from analysis.hbm import HBMSystem, response_curves

    system = HBMSystem(model, [0], (1, 3))
    out = []
    for t in tables:
        i = int(np.argmax(np.abs(t.frf()[:, 0, 0])))
        branch = response_curves(system, 78.5, 82.0, [abs(t.force_phasor[i, 0])])[0]
        a = branch.amplitude(0)
        j = int(np.argmax(a))
        out.append(a[j] * (2 * np.pi * branch.freqs[j]) ** 2 / abs(t.response_phasor[i, 0]) - 1)
    return out


def main() -> int:
    """Run the scan (module docstring); returns the exit code."""
    from analysis.models import Model
    from nlid_lab.cli import main as cli
    from nlid_lab.store import open_run

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--freqs", type=float, nargs="+", default=[76.0, 77.0, 78.0, 78.5, 79.0])
    p.add_argument("--out", default="beam-joint-scan", help="working directory")
    args = p.parse_args()
    if not MAT.is_file():
        print(f"beam_joint_scan: {MAT} not found; the real data are needed", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(exist_ok=True)
    run, linear = out / "brb.h5", out / "linear.toml"
    cli(["import", str(MAT), "--out", str(run), "--map", *MAP, "--force", "--json", "-"])
    cli(["fit-linear", str(run), "--out", str(linear), "--force", "-q"])
    tables = open_run(run).recordings()
    text = linear.read_text()
    print("linear model: peaks " + " ".join(f"{100 * e:+.1f}%" for e in
                                            peak_errors(Model.load(linear), tables)))
    for f in args.freqs:
        cand = out / f"hysteresis-{f:g}.toml"
        cand.write_text(re.sub(r"^frequencies_hz = \[[^\]]*\]", f"frequencies_hz = [{f}]", text,
                                flags=re.MULTILINE)
                        + '\n[[element]]\nkind = "hysteresis"\nat = "0"\n')
        res = out / f"hysteresis-{f:g}.json"
        cli(["analyze", "hbm", str(run), "--model", str(cand), "--harmonics", "1,3",
             "--json", str(res), "--force", "-q"])
        fit = json.loads(res.read_text())
        params = fit["elements"][0]["params"]
        model = Model.loads(cand.read_text() + "".join(f"{k} = {v}\n"
                                                       for k, v in params.items()))
        errors = peak_errors(model, tables)
        print(f"{f:g} Hz: cost {fit['cost']:.5g}, kd {params['kd']:.4g}, fd {params['fd']:.4g}, "
              f"n {params['n']:.3g}; peaks " + " ".join(f"{100 * e:+.1f}%" for e in errors))
    return 0


if __name__ == "__main__":
    sys.exit(main())
