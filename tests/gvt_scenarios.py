"""Jointed-structure diagnosis cases that look like a ground vibration test.

The FE beam with a payload on a joint (`structures.beam_with_payload`, 21 DOFs, four modes in
3-200 Hz), four accelerometers (drive, joint, tip, payload) with 2 % sensor noise, the force
measured at the drive point through the DAQ's anti-alias filter (``force_hold = "none"``),
one periodic multisine realization per level at five levels (1-16 N rms, 3 transient and 4
steady periods of 4 s). The missing physics sits in the FE model (between FE DOFs), and the
diagnosis starts from `fit_linear` on the lowest level, as an engineer would.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.plant import multisine, periodic
from analysis.modal import fit_linear
from analysis.models import Element, Model
from analysis.recordings import PeriodicLayout, Recording
from structures import FEStructure, beam_with_payload, gvt_recording

NAMES = ["drive", "joint", "tip", "payload"]
BAND = (3.0, 200.0)
FS, N, UP, PERIODS, TRANSIENT = 1024.0, 4096, 8, 4, 3
LEVELS = (1.0, 2.0, 4.0, 8.0, 16.0)
NOISE = 0.02
JOINT_K = 0.5 * (2 * np.pi * 30.0) ** 2       # the payload's joint spring, N/m


@dataclass
class GVTCase:
    start: Model
    recordings: list[Recording]
    truth: dict


def fe_w(beam: FEStructure, *names: str) -> np.ndarray:
    """Position vector over the FE DOFs: a point to ground, or from the first to the second."""
    w = np.zeros(beam.model.n_dof)
    w[beam.points[names[-1]]] = 1.0
    if len(names) == 2:
        w[beam.points[names[0]]] = -1.0
    return w


def runs(beam: FEStructure, elements=()) -> list[Recording]:
    out = []
    for i, level in enumerate(LEVELS):
        fine = multisine(N * UP, FS * UP, (1.0, 220.0), level, seed=7 + i)
        out.append(gvt_recording(beam, NAMES, "drive", periodic(fine, PERIODS + TRANSIENT), FS,
                                 UP, layout=PeriodicLayout(N, TRANSIENT, PERIODS, 1),
                                 level=level, noise=NOISE, seed=3 + i, elements=elements))
    return out


def _from_lowest(beam: FEStructure, elements, truth: dict) -> GVTCase:
    recs = runs(beam, elements)
    return GVTCase(fit_linear(recs[0], BAND, points=NAMES).model, recs, truth)


def friction_joint() -> GVTCase:
    """A Jenkins slider (stick-slip) in the joint: stuck at the lowest level, slipping above."""
    beam = beam_with_payload()
    params = {"kd": 0.5 * JOINT_K, "fd": 2.0}
    el = Element("stick_slip", fe_w(beam, "joint", "payload"), params)
    return _from_lowest(beam, [el], {"kind": "stick_slip", "dofs": [1, 3], "params": params})


def clearance_joint() -> GVTCase:
    """A clearance in the joint that closes only at the peaks of the two highest levels."""
    beam = beam_with_payload()
    params = {"k": JOINT_K, "g": 7e-4}
    el = Element("gap", fe_w(beam, "joint", "payload"), params)
    return _from_lowest(beam, [el], {"kind": "gap", "dofs": [1, 3], "params": params})


def grounded_cubic() -> GVTCase:
    """A hardening support at the tip (3 p u^2 reaches ~30 % of the tip stiffness at 16 N)."""
    beam = beam_with_payload()
    params = {"p": 1e7}
    el = Element("cubic_spring", fe_w(beam, "tip"), params)
    return _from_lowest(beam, [el], {"kind": "cubic_spring", "dofs": [2], "params": params})


def no_discrepancy() -> GVTCase:
    return _from_lowest(beam_with_payload(), [], {})


def stiffness_error() -> GVTCase:
    """The nominal FE model (modal form at the sensors, all 21 modes) against a structure
    whose joint is 30 % stiffer: a linear error that no fit at any level removes."""
    nominal, stiffer = beam_with_payload(), beam_with_payload(joint_hz=30.0 * np.sqrt(1.3))
    start = nominal.model.modal_form([nominal.points[k] for k in NAMES], NAMES)
    return GVTCase(start, runs(stiffer), {"kind": "stiffness_error", "dofs": [1, 3],
                                          "params": {"delta_stiffness": 0.3 * JOINT_K}})


def loose_part() -> GVTCase:
    """Physics outside the library: a loose 50 g part rattling in the payload (an unmodelled
    DOF on a soft 2 Hz centring spring, striking the payload across a 0.3 mm clearance).
    No element between measured points can stand for an unmeasured mass that impacts."""
    beam = beam_with_payload()
    m, n, pay = beam.model, beam.model.n_dof, beam.points["payload"]
    M, C, K = (np.zeros((n + 1, n + 1)) for _ in range(3))
    M[:n, :n], C[:n, :n], K[:n, :n] = m.mass, m.damping, m.stiffness
    ml = 0.05
    k0 = ml * (2 * np.pi * 2.0) ** 2
    c0 = 2 * 0.05 * np.sqrt(k0 * ml)
    M[n, n] = ml
    for a, b, s in ((pay, pay, 1), (n, n, 1), (pay, n, -1), (n, pay, -1)):
        K[a, b] += s * k0
        C[a, b] += s * c0
    w = np.zeros(n + 1)
    w[n], w[pay] = 1.0, -1.0
    loose = FEStructure(Model(M, C, K, [], "beam + loose part"), dict(beam.points))
    return _from_lowest(loose, [Element("gap", w, {"k": 2 * JOINT_K, "g": 3e-4})], {})
