"""A mapped GVT recording: some of an FE model's points measured, each channel in its own kind.

What a DAQ records: the structure simulated ``up`` times faster than ``fs``, the force and every
response channel through the same *causal* anti-alias FIR filter and decimated
(``force_hold = "none"``), relative sensor noise on the responses. The filter is causal as a
real DAQ's is: its delay is the same on every channel (it cancels in every FRF), and a change
of drive (a new realization) shows up after the change, in the transient periods that are
dropped, never before it. A zero-phase filter would leak each realization's start into the
last samples of the one before, where no transient period hides it.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import firwin, lfilter

from analysis.plant import Plant, add_relative_noise, multisine, periodic
from analysis.models import Model
from analysis.recordings import PeriodicLayout, Recording, SensorMap


def named_points(model: Model, points: dict[str, int]) -> Model:
    """``model`` with the DOFs of ``points`` named (the others ``n<i>``)."""
    names = [f"n{i}" for i in range(model.n_dof)]
    for k, i in points.items():
        names[i] = k
    return Model(model.mass, model.damping, model.stiffness, list(model.elements), model.name,
                 names)


def multisine_drive(n: int, fs: float, band: tuple[float, float], rms: float,
                    realizations: int, periods: int, transient: int, up: int,
                    seed: int = 7) -> tuple[np.ndarray, PeriodicLayout]:
    """Force at ``fs * up``: ``realizations`` multisines (own phases) of ``n`` samples at
    ``fs``, each repeated ``transient + periods`` times, and the layout at ``fs``."""
    blocks = [periodic(multisine(n * up, fs * up, band, rms, seed=seed + r), transient + periods)
              for r in range(realizations)]
    return np.concatenate(blocks), PeriodicLayout(n, transient, periods, realizations)


def mapped_recording(model: Model, points: list[str], kinds: list[str], drive: str,
                     force_fine: np.ndarray, fs: float, up: int, *, noise: float = 0.01,
                     seed: int = 2, layout: PeriodicLayout | None = None,
                     level: float | None = None) -> Recording:
    """The DAQ record of ``model`` (with its elements) driven at point ``drive`` by
    ``force_fine`` (at ``fs * up``), channels at ``points`` in ``kinds``, with its sensor
    map."""
    f = np.asarray(force_fine, dtype=float)
    out = Plant(model, fs * up, [model.point_index(drive)]).run(f[:, None])
    taps = firwin(20 * up + 1, 1.0 / up, window="hamming")     # scipy.signal.decimate's FIR

    def daq(x: np.ndarray) -> np.ndarray:
        return lfilter(taps, 1.0, x, axis=0)[::up]

    resp = np.column_stack([daq(getattr(out, k)[:, model.point_index(p)])
                            for p, k in zip(points, kinds)])
    resp = add_relative_noise(resp, noise, np.random.default_rng(seed))
    smap = SensorMap(tuple(points), tuple(kinds), (drive,))
    return Recording(fs=fs, excitation="random", force_dofs=np.array([points.index(drive)]),
                     force=daq(f)[:, None], response=resp, response_kind=smap.kind,
                     level=level, force_hold="none", layout=layout, sensors=smap)
