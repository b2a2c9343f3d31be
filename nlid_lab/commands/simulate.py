"""``nlid-lab simulate MODEL.toml --drive DRIVE.npz --out OUT.npz|OUT.h5``: replay a drive."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from analysis.errors import InputError
from analysis.recordings import (ARTIFACTS, RESPONSE_KINDS, DaqArtifacts, Excitation, Recording,
                                 SensorMap, apply_daq_artifacts, shaker_force)

from ..formats import Drive, read_drive, read_sensors, write_npz
from .. import sim_budget
from ..outputs import add_force_option, atomic_path, refuse_overwrite, write_json
from ..progress import progress

if TYPE_CHECKING:
    from analysis.models import Model

OUT_SUFFIXES = (".npz", ".h5", ".hdf5")


@dataclass(frozen=True)
class Simulated:
    """A drive run through the simulated plant (`simulate`).

    Attributes
    ----------
    recording : Recording
        What the sensors recorded.
    oversample : int
        Plant substeps per sample at the end of the drive.
    oversample_raised : int
        Times the plant's step doubling raised them to hold its accuracy.
    """

    recording: Recording
    oversample: int
    oversample_raised: int


def simulate_drive(model: Model, drive: Drive, *, response_kind: str = "displacement",
                   noise_std: float = 0.0, seed: int | None = None,
                   oversample: int | None = None) -> Recording:
    """The recording of `simulate` (its arguments the same)."""
    return simulate(model, drive, response_kind=response_kind, noise_std=noise_std,
                    seed=seed, oversample=oversample).recording


def simulate(model: Model, drive: Drive, *, response_kind: str = "displacement",
             noise_std: float = 0.0, seed: int | None = None,
             oversample: int | None = None) -> Simulated:
    """Run a drive (see `nlid_lab.formats.read_drive`) through the simulated plant.

    Stepped-sine steps are run one after the other with the plant state carried over, as on
    a real shaker; each step's response is recorded in full. A drive with sensor-map keys
    (``drive.sensors``) is simulated at its forces' points and recorded at its response
    points, each channel in its own kind. The drive's periodic layout
    and other keys are carried to the recording. The response is anti-aliased
    (`analysis.plant.remove_hold_images`) like a DAQ's.
    """
    from analysis.plant import Plant, remove_hold_images

    model.require_complete("simulation")
    smap = _sensor_map(model, drive, response_kind)
    dofs = drive.force_dofs if smap is None else np.array(
        [model.point_index(p) for p in smap.force_points])
    if dofs.min() < 0 or dofs.max() >= model.n_dof:
        raise InputError(f"drive force_dofs {dofs.tolist()} outside the model's DOFs "
                         f"0..{model.n_dof - 1} (0-based)")
    too_much = sim_budget.excess(model, drive.fs, drive.force[..., 0].size, oversample)
    if too_much:
        raise InputError(f"{too_much}; shorten the drive, raise its fs, or check the model's "
                         "stiffness and units")
    plant = Plant(model, drive.fs, dofs, oversample=oversample,
                  noise_std=noise_std if smap is None else 0.0,
                  response_kind=response_kind, seed=seed)
    force = drive.force
    whole = force.reshape(-1, force.shape[-1])      # stepped sine: the steps back to back
    step = max(1, int(drive.fs))  # one-second pieces for the progress bar
    outs = [plant.run(whole[i:i + step]) for i in progress(range(0, len(whole), step),
                                                         desc="simulate", unit="s")]
    if smap is None:
        # the sensors' anti-alias filter (analysis.plant, Sensor sampling), whole record
        response = remove_hold_images(np.concatenate([o.response for o in outs]), whole,
                                      drive.fs, response_kind, plant.image_gains)
    else:
        response = _at_sensors(model, smap, outs, whole, drive.fs, plant.image_gains)
        response += np.random.default_rng(seed).standard_normal(response.shape) * noise_std
    response = response.reshape(force.shape[:-1] + (-1,))
    if smap is not None:
        dofs = np.asarray(smap.force_channels)
    rec = Recording(fs=drive.fs, excitation=drive.excitation, force_dofs=dofs,
                    force=force, response=response, response_kind=response_kind,
                    freqs=drive.freqs, level=drive.level,
                    force_hold="linear",  # the plant's drive definition
                    layout=drive.layout, sweep=drive.sweep, extra=drive.extra,
                    meta={"model": model.name, "noise_std": noise_std, "seed": seed},
                    sensors=smap)
    return Simulated(rec, int(plant.oversample), int(plant.raised))


def _sensor_map(model: Model, drive: Drive, response_kind: str) -> SensorMap | None:
    """The drive's sensor map over ``model``'s points (None: every point, one kind)."""
    keys = drive.sensors
    if not keys:
        return None
    points = keys.get("response_points", list(model.points))
    kinds = keys.get("response_kinds", [response_kind] * len(points))
    forces = keys.get("force_points", [model.points[d] for d in drive.force_dofs])
    smap = SensorMap(tuple(points), tuple(kinds), tuple(forces))
    smap.validate(len(points), drive.force.shape[-1])
    for p in smap.response_points + smap.force_points:
        model.point_index(p)        # a point the model does not have: exit 2 naming it
    return smap


def _at_sensors(model: Model, smap: SensorMap, outs: list, force: np.ndarray, fs: float,
                gains: tuple) -> np.ndarray:
    """Each channel's kind at its point, anti-aliased like a DAQ's (`remove_hold_images`)."""
    from analysis.plant import remove_hold_images

    idx = np.array([model.point_index(p) for p in smap.response_points])
    kinds = np.array(smap.response_kinds)
    response = np.empty((len(force), idx.size))
    for kind in RESPONSE_KINDS:
        cols = np.flatnonzero(kinds == kind)
        if cols.size:
            samples = np.concatenate([getattr(o, kind)[:, idx[cols]] for o in outs])
            response[:, cols] = remove_hold_images(samples, force, fs, kind,
                                                   [g[idx[cols]] for g in gains])
    return response


def _artifact_names(text: str | None) -> list[str]:
    """``--daq-artifacts`` names, checked against the catalogue (exit 2 naming a wrong one)."""
    names = [n.strip() for n in (text or "").split(",") if n.strip()]
    DaqArtifacts.of(names)
    return names


def _with_force_dips(model: Model, drive: Drive) -> Drive:
    """The drive as a force cell behind a shaker measures it (`shaker_force`): each input
    through its own drive point's receptance (cross terms between shakers left out)."""
    force = drive.force
    if force.ndim != 2:
        raise InputError("--daq-artifacts force-dips applies to random and swept-sine drives; "
                         "leave it out for a stepped sine")
    f = np.fft.rfftfreq(force.shape[0], 1 / drive.fs)
    h = model.linear_frf(f, list(drive.force_dofs))
    cols = [shaker_force(force[:, i], drive.fs, h[:, d, i])
            for i, d in enumerate(drive.force_dofs)]
    return dataclasses.replace(drive, force=np.column_stack(cols))


def run(args: argparse.Namespace) -> int:
    """Run ``nlid-lab simulate`` on the parsed ``args``; returns the exit code."""
    from analysis.models import Model

    from .. import store

    out = Path(args.out)
    if out.suffix.lower() not in OUT_SUFFIXES:
        raise InputError(f"--out {out}: use a .npz or .h5 file name")
    refuse_overwrite(args.force, out, args.json)
    if args.noise < 0:
        raise InputError("--noise must be >= 0 (standard deviation in response units)")
    model_path = Path(args.model)
    model = Model.load(model_path)
    drive = read_drive(args.drive)
    if args.sensors:
        drive = dataclasses.replace(drive, sensors=read_sensors(args.sensors))
    artifacts = _artifact_names(args.daq_artifacts)
    if "force-dips" in artifacts:
        drive = _with_force_dips(model, drive)
    sim = simulate(model, drive, response_kind=args.response_kind, noise_std=args.noise,
                   seed=args.seed, oversample=args.oversample)
    rec = sim.recording
    if artifacts:
        rec = apply_daq_artifacts(rec, DaqArtifacts.of(artifacts, rec.fs),
                                  np.random.default_rng(args.seed))
    with atomic_path(out) as tmp:         # no half file on a full disk
        if out.suffix.lower() == ".npz":
            write_npz(tmp, rec)
        else:
            store.save_recording(tmp, rec, source="sim", model_toml=model_path.read_text(),
                                 settings={"drive": str(args.drive), "noise_std": args.noise,
                                           "seed": args.seed,
                                           "oversample": sim.oversample})
    result = {"out": str(out), "model": model.name, "excitation": rec.excitation,
              "fs": rec.fs, "n_samples": int(rec.force.shape[-2]),
              "n_steps": int(rec.force.shape[0]) if rec.excitation != Excitation.RANDOM else None,
              "response_kind": rec.response_kind,
              "oversample": sim.oversample,
              "oversample_raised": sim.oversample_raised,
              "response_rms": np.sqrt(np.mean(rec.response.reshape(-1, rec.n_dof) ** 2,
                                              axis=0))}
    if sim.oversample_raised:
        print(f"note: the drive stiffened the model's elements; the plant raised its substeps "
              f"to {sim.oversample} per sample to hold its accuracy", file=sys.stderr)
    if args.json != "-":
        print(f"simulated {model.name} ({rec.excitation}, {result['n_samples']} samples"
              f"{'' if rec.excitation == 'random' else ' per step'}) -> {out}")
    write_json(result, args.json)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command and its options to ``sub``."""
    p = sub.add_parser("simulate", help="replay a drive through a model on the simulated plant")
    p.add_argument("model", metavar="MODEL.toml", help="model file (every parameter known)")
    p.add_argument("--drive", required=True, metavar="DRIVE.npz",
                   help="NPZ with fs, force, force_dofs (and freqs for stepped sine)")
    p.add_argument("--out", required=True, metavar="OUT", help="output .npz recording or .h5 run")
    p.add_argument("--noise", type=float, default=0.0, metavar="STD",
                   help="sensor noise standard deviation, response units (default 0)")
    p.add_argument("--seed", type=int, help="noise seed (for reproducible noise)")
    p.add_argument("--response-kind", choices=RESPONSE_KINDS, default="displacement")
    p.add_argument("--oversample", type=int, help="plant integration steps per sample")
    p.add_argument("--sensors", metavar="SENSORS.toml", help="sensor map: response_points, "
                   "response_kinds, force_points (model point names; docs/model-format.md"
                   "#sensor-maps); overrides the drive's keys")
    p.add_argument("--daq-artifacts", metavar="NAME[,NAME]",
                   help="add what a real DAQ export carries (docs/daq-artifacts.md): "
                   + ", ".join(ARTIFACTS))
    p.add_argument("--json", metavar="FILE", help="write the result as JSON ('-' for stdout)")
    add_force_option(p)
    p.set_defaults(func=run)
