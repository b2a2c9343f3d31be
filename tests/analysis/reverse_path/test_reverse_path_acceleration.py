"""Accelerometer records as exact as displacements (issue #23 item 3), through the commands a
test engineer runs: ``simulate --response-kind acceleration`` of a 2-DOF cubic (p = 2e11)
from 0-300 Hz band noise at fs 2048 Hz, ``import``, ``analyze reverse-path`` with the true
structure as the candidate.

Measured (10 N rms, 2^16 samples) at the resolving default segment (16384: the first mode's
0.7 Hz bandwidth over 5 lines): the integrated displacement alone gave acceleration +0.010 to
-0.007 % with an interval 3.04-3.73x the displacement one (drive seeds 1, 4, 7); with its
lowest band formed from the force through the estimated model
(`analysis.reverse_path._low_band`) +0.0003 to -0.0041 % and 1.05-1.46x (seeds 1, 4, 7, 10;
displacement -0.0022 to +0.0003 %).
"""

import json

import numpy as np
import pytest

from analysis.models import Element, Model
from analysis.plant import random_gaussian
from nlid_lab.cli import main

TRUTH = Model([[1.0, 0.0], [0.0, 1.5]], [[12.0, -6.0], [-6.0, 9.0]],
              [[3e4, -1.5e4], [-1.5e4, 2.5e4]],
              [Element("cubic_spring", [-1.0, 1.0], {"p": 2e11})], "2-DOF cubic")
FS, N, RMS = 2048.0, 1 << 16, 10.0


def _estimate(tmp_path, kind: str, noise: float = 0.0, nperseg: int | None = None,
              seed: int = 4) -> tuple[float, list[float]]:
    """simulate -> import -> analyze reverse-path; the cubic estimate and its interval."""
    (tmp_path / "truth.toml").write_text(TRUTH.dumps())
    (tmp_path / "cand.toml").write_text(
        TRUTH.with_elements([Element("cubic_spring", [-1.0, 1.0], {})]).dumps())
    drive = tmp_path / f"drive{seed}.npz"
    if not drive.exists():
        np.savez(drive, fs=FS, force=random_gaussian(N, FS, (0.0, 300.0), RMS, seed)[:, None],
                 force_dofs=np.array([0]), excitation="random")
    rec, run, out = (tmp_path / f"{kind}{noise:g}_{seed}.{s}" for s in ("npz", "h5", "json"))
    assert main(["simulate", str(tmp_path / "truth.toml"), "--drive", str(drive), "--out",
                 str(rec), "--response-kind", kind, "--noise", str(noise), "--seed", "3",
                 "--force"]) == 0
    assert main(["import", str(rec), "--out", str(run), "--force"]) == 0
    welch = [] if nperseg is None else ["--nperseg", str(nperseg)]
    assert main(["analyze", "reverse-path", str(run), "--model", str(tmp_path / "cand.toml"),
                 "--json", str(out), "--quiet", "--force", *welch]) == 0
    (el,) = json.loads(out.read_text())["elements"]
    return el["params"]["p"], el["ci95"]["p"]


def _as_exact(tmp_path, seed: int) -> None:
    """Within 0.2 % of the truth with the defaults, the interval at most 3x the displacement
    one (the issue's goal; it gave -1.45 % with an interval 36x wider)."""
    p_d, ci_d = _estimate(tmp_path, "displacement", seed=seed)
    p_a, ci_a = _estimate(tmp_path, "acceleration", seed=seed)
    assert p_d == pytest.approx(2e11, rel=1e-3)
    assert p_a == pytest.approx(2e11, rel=2e-3)
    assert ci_a[1] - ci_a[0] <= 3 * (ci_d[1] - ci_d[0]), (seed, ci_a, ci_d)


def test_noise_free_acceleration_is_as_exact_as_displacement(tmp_path):
    """Drive seed 4 (3.05x with the integrated displacement alone)."""
    _as_exact(tmp_path, 4)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 7, 10])
def test_noise_free_acceleration_is_as_exact_as_displacement_seeds(tmp_path, seed):
    """More drive seeds."""
    _as_exact(tmp_path, seed)


@pytest.mark.parametrize("kind, noise", [("displacement", 5e-6), ("acceleration", 0.15)])
def test_with_sensor_noise_the_interval_covers(tmp_path, kind, noise):
    """About 1 % white sensor noise (of the response rms) on either kind: the 95 % interval
    covers the truth."""
    p, ci = _estimate(tmp_path, kind, noise)
    assert ci[0] <= 2e11 <= ci[1], (kind, p, ci)
    assert ci[1] - ci[0] < 0.1 * 2e11              # informative, not a blanket interval
