"""A small GVT twin that carries the real-DAQ artifacts of `analysis.recordings.DaqArtifacts`.

Structure: 2-DOF chain (modes near 15 and 36 Hz, 2.4 and 4.7 % damping) with a cubic spring
between the masses, driven at DOF 0 through a force cell, accelerometers at both DOFs.
Periodic multisine 5-100 Hz, fs 512 Hz, 1024-sample periods, 3 realizations of 1 transient +
3 steady periods, two levels (2 and 20 N rms; `export` takes other levels and periods). Each
level is exported as the F-16 export is (``Force`` 1xN, ``Acceleration`` 2xN, ``Fs``; no
period), with 0.5 % sensor noise and 0.5 % force noise. ``force-dips`` drives the structure
through `shaker_force` instead of the flat force; `GVT_ARTIFACTS` is every artifact a
working channel set shows together."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from analysis.models import Element, Model
from analysis.plant import multisine, periodic, simulate
from analysis.recordings import (DaqArtifacts, PeriodicLayout, Recording, apply_daq_artifacts,
                                 shaker_force)

FS, PERIOD, PERIODS, REALIZATIONS = 512.0, 1024, 3, 3
BAND = (5.0, 100.0)
LEVELS = (2.0, 20.0)
P_TRUE = 4e9
NOISE = 0.005
MAP = ["--map", "force=Force", "response=Acceleration[0:2]:m/s^2", "fs=Fs", "force_dofs=0",
       'force_hold="none"']


def truth() -> Model:
    """The structure (cubic spring between the two masses)."""
    k = np.array([[3.0e4, -1.5e4], [-1.5e4, 1.5e4]])
    m = np.diag([1.0, 0.5])
    return Model(m, 4e-4 * k + 1.0 * m, k,
                 [Element("cubic_spring", [-1.0, 1.0], {"p": P_TRUE})], "2-DOF twin")


@lru_cache(maxsize=4)
def clean_levels(dips: bool = False, levels: tuple[float, ...] = LEVELS,
                 periods: int = PERIODS, realizations: int = REALIZATIONS
                 ) -> tuple[Recording, ...]:
    """The clean recordings (noise included), one per level (force rms, N), ``realizations``
    realizations of 1 + ``periods`` periods each, as the DAQ would see them."""
    model = truth()
    out = []
    for i, rms in enumerate(levels):
        blocks = []
        for r in range(realizations):
            one = multisine(PERIOD, FS, BAND, rms, seed=3 + 10 * i + r)
            if dips:
                f = np.fft.rfftfreq(PERIOD, 1 / FS)
                one = shaker_force(one, FS, model.linear_frf(f, [0])[:, 0, 0])
            blocks.append(periodic(one, periods + 1))
        force = np.concatenate(blocks)
        acc = simulate(model, force[:, None], FS, [0], response_kind="acceleration")
        rng = np.random.default_rng(7 + i)
        acc = acc + NOISE * acc.std(axis=0) * rng.standard_normal(acc.shape)
        force = force + NOISE * force.std() * rng.standard_normal(force.shape)
        out.append(Recording(FS, "random", np.array([0]), force[:, None], acc, "acceleration",
                             layout=PeriodicLayout(PERIOD, 1, periods, realizations)))
    return tuple(out)


#: every artifact of the catalogue a working channel set shows together (docs/gvt-workflow.md,
#: "Every artifact at once"): all but the dead and the noisy channel
GVT_ARTIFACTS = ("mains", "dc", "drift", "quantization", "clipping", "delay", "force-dips",
                 "zeros", "partial-period")


#: the stepped-sine twin: drive frequencies through the first mode (14.9 Hz), amplitude (N),
#: samples per step
STEPS, STEP_AMPLITUDE, STEP_SAMPLES = np.linspace(11.0, 19.0, 9), 5.0, 2048


def stepped_drive(path: Path) -> Path:
    """A stepped-sine drive NPZ for ``simulate`` (`STEPS` at `STEP_AMPLITUDE`, each step
    `STEP_SAMPLES` long, settling included)."""
    from analysis.plant import sine_block

    force = np.stack([sine_block(f, STEP_AMPLITUDE, STEP_SAMPLES, FS)[:, None] for f in STEPS])
    np.savez(path, fs=FS, force=force, force_dofs=np.array([0]), freqs=STEPS,
             level=STEP_AMPLITUDE)
    return path


def export(folder: Path, artifact: str | tuple[str, ...] | None,
           levels: tuple[float, ...] = LEVELS, periods: int = PERIODS,
           realizations: int = REALIZATIONS) -> list[Path]:
    """One MAT file per level carrying ``artifact`` (several: a tuple; None: clean); the
    paths."""
    from scipy.io import savemat

    names = (artifact,) if isinstance(artifact, str) else tuple(artifact or ())
    spec = DaqArtifacts.of(list(names), FS)
    paths = []
    for i, rec in enumerate(clean_levels("force-dips" in names, tuple(levels), periods,
                                         realizations)):
        rec = apply_daq_artifacts(rec, spec, np.random.default_rng(11 + i))
        p = Path(folder) / f"Level{i + 1}.mat"
        savemat(p, {"Force": rec.force.T, "Acceleration": rec.response.T,
                    "Fs": np.array([[FS]])})
        paths.append(p)
    return paths
