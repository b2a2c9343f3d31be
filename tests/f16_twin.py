"""An F-16-like ground vibration test, synthetic: what the public F-16 GVT benchmark's exports
look like (Noël & Schoukens), made on a structure we know.

Structure: a lumped aircraft of 11 DOFs (fuselage on its landing gear, right wing root, mid
and tip, a wing point at the payload interface, the payload and its pitch, left wing root and
tip, tail, nose): 11 modes, 7 of them in 2-15 Hz (2.1, 2.9, 3.5, 7.3, 11.4, 12.2, 14.8 Hz),
1.5 % modal damping. The 7.3 Hz mode is the "wing torsion": 80 % of its strain energy sits in
the wing-payload interface spring (the others hold under 5 %).

Interface: an Iwan-like joint between the wing point and the payload, outside the library: a
linear spring (85 % of the interface stiffness) in parallel with five Jenkins sliders
(stick-slip elements, 3 % of it each) of slip displacements spread geometrically; the first
slides at the lowest level already. Over the seven levels the torsion mode softens by
~1-1.5 % and its damping rises, as on the F-16.

Shaker: an electrodynamic exciter (armature mass on its suspension, back-EMF damping
``(Bl)^2 / R``, driven by ``Bl/R * Voltage``) on a stiff stinger whose force cell measures the
force into the structure: the measured force dips at the resonances, the voltage is flat.

Recording: simulated ``UP`` times faster than 400 Hz, force, voltage and the accelerations at
the drive point (channel 1), the wing side (2) and the payload side (3) of the interface
through the same anti-alias FIR and decimation, 2 % noise on the accelerations, 1 % on the
force. Periodic multisine 2-15 Hz, one realization per level, the first period transient.
`export_mat` writes each level as the F-16 export does (``Force`` 1xN, ``Voltage`` 1xN,
``Acceleration`` 3xN, ``Fs``), with the F-16 file names.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.linalg import eigh

from analysis.models import Element, Model

FS, UP = 400.0, 8
BAND = (2.0, 15.0)
FORCE_RMS = (12.4, 24.6, 36.8, 61.4, 73.6, 85.7, 97.8)     # N, levels 1..7
VALIDATION = (2, 4, 6)                                       # held-back levels (1-based)
MASS = np.array([600, 80, 60, 40, 25, 50, 15, 80, 50, 60, 40.0])   # kg
#: (a, b, k): springs between DOFs a and b (b = -1: to ground), N/m
SPRINGS = ((0, -1, 305819.0), (0, 1, 129505.0), (1, 2, 36855.0), (2, 3, 5279.28),
           (2, 4, 5659.22), (3, 4, 466281.0), (4, 5, 49577.3), (5, 6, 30490.3),
           (6, 4, 20478.8), (0, 7, 427142.0), (7, 8, 452455.0), (0, 9, 181008.0),
           (0, 10, 15402.2), (1, 7, 15799.1), (2, 9, 49756.0))
DRIVE, WING, PAYLOAD = 2, 4, 5            # structural DOFs of channels 1, 2, 3
JOINT = 6                                 # index of the interface spring in SPRINGS
ZETA = 0.015
#: Iwan-like interface: share of the interface stiffness per Jenkins slider, their slip
#: displacements (m)
SLIDER_SHARE = 0.012
SLIP_M = tuple(8e-5 * 1.6 ** i for i in range(5))
#: shaker: armature mass, suspension, back-EMF damping, Bl/R (N/V), stinger stiffness
ARMATURE_KG, SUSPENSION, BACK_EMF, GAIN, STINGER = 3.0, 3.0e3, 1500.0, 10.0, 2.0e6
ACC_NOISE, FORCE_NOISE = 0.02, 0.01


@dataclass
class Twin:
    """The levels of one twin test: per level the MAT variables as the F-16 export has them."""

    levels: list[dict[str, np.ndarray]]
    period: int
    periods: int                 # steady periods (the first period is transient on top)
    joint: bool


def structure(joint: bool = True) -> Model:
    """Structure plus shaker armature (last DOF) as an M/C/K model with the joint's sliders.

    The interface spring holds ``1 - 5 SLIDER_SHARE`` of its stiffness when ``joint``; the
    sliders' stuck stiffness makes up the rest, so that the stuck structure is the linear one
    (``joint=False``: the whole spring, no sliders).
    """
    n = MASS.size + 1
    arm = n - 1
    K = np.zeros((n, n))
    sliders = []
    for i, (a, b, k) in enumerate(SPRINGS):
        if i == JOINT and joint:
            kd = SLIDER_SHARE * k
            w = np.zeros(n)
            w[b], w[a] = 1.0, -1.0
            sliders = [Element("stick_slip", w, {"kd": kd, "fd": kd * s}) for s in SLIP_M]
            k = k - kd * len(SLIP_M)
        _spring(K, a, b, k)
    M = np.diag(np.r_[MASS, 0.0])
    # modal damping of the structure alone (shaker off), then the shaker
    Ks, Ms = K[:-1, :-1].copy(), M[:-1, :-1]
    if joint:
        _spring(Ks, SPRINGS[JOINT][0], SPRINGS[JOINT][1], len(SLIP_M) * SLIDER_SHARE
                * SPRINGS[JOINT][2])
    lam, phi = eigh(Ks, Ms)
    C = np.zeros((n, n))
    C[:-1, :-1] = Ms @ phi @ np.diag(2 * ZETA * np.sqrt(lam)) @ phi.T @ Ms
    M[arm, arm] = ARMATURE_KG
    _spring(K, arm, -1, SUSPENSION)
    _spring(K, arm, DRIVE, STINGER)
    C[arm, arm] += BACK_EMF
    return Model(M, 0.5 * (C + C.T), K, sliders, "F-16-like twin with shaker")


def _spring(K: np.ndarray, a: int, b: int, k: float) -> None:
    K[a, a] += k
    if b >= 0:
        K[b, b] += k
        K[a, b] -= k
        K[b, a] -= k


def linear_structure() -> Model:
    """The structure alone (no shaker), interface stuck: the exact low-level linear model."""
    m = structure(joint=False)
    n = MASS.size
    return Model(m.mass[:n, :n], m.damping[:n, :n], _without_shaker(m.stiffness), [],
                 "F-16-like twin, linear")


def _without_shaker(K: np.ndarray) -> np.ndarray:
    Ks = K[:-1, :-1].copy()
    Ks[DRIVE, DRIVE] -= STINGER
    return Ks


def _force_per_volt(model: Model, f: np.ndarray) -> np.ndarray:
    """Measured (stinger) force per volt of the linear system at frequencies ``f``."""
    arm = model.n_dof - 1
    out = np.empty(f.size, dtype=complex)
    for i, fi in enumerate(f):
        s = 2j * np.pi * fi
        H = np.linalg.inv(model.mass * s ** 2 + model.damping * s + model.stiffness)
        x = H[:, arm] * GAIN
        out[i] = STINGER * (x[arm] - x[DRIVE])
    return out


def _thin(period: np.ndarray, lines: str, seed: int) -> np.ndarray:
    """One multisine period with lines left out: ``"all"`` none, ``"every-2nd"`` every
    second excited line, ``"random"`` 30 % of them at random."""
    if lines == "all":
        return period
    spec = np.fft.rfft(period)
    on = np.flatnonzero(np.abs(spec) > 1e-9 * np.abs(spec).max())
    drop = on[1::2] if lines == "every-2nd" else np.random.default_rng(seed).choice(
        on, 3 * on.size // 10, replace=False)
    spec[drop] = 0.0
    return np.fft.irfft(spec, period.size)


@lru_cache(maxsize=8)
def twin(joint: bool = True, period: int = 8192, periods: int = 8,
         levels: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7), seed: int = 1,
         lines: str = "all") -> Twin:
    """Simulate the test: ``periods`` steady periods plus one transient per level (cached);
    ``lines`` thins the multisine (`_thin`)."""
    from scipy.signal import decimate

    from analysis.plant import multisine, periodic
    from analysis.plant import Plant

    model = structure(joint)
    lin = structure(False)
    arm = model.n_dof - 1
    rng = np.random.default_rng(seed)
    fine_fs = FS * UP
    out = []
    for lv in levels:
        v1 = _thin(multisine(period * UP, fine_fs, BAND, 1.0, seed=seed + 10 * lv), lines,
                   seed + 10 * lv)
        spec = np.fft.rfft(v1)
        f = np.fft.rfftfreq(v1.size, 1 / fine_fs)
        on = np.abs(spec) > 1e-9 * np.abs(spec).max()
        force_rms = np.sqrt(2 * np.sum(np.abs(spec[on] * _force_per_volt(lin, f[on])) ** 2)) \
            / v1.size
        volt = periodic(v1 * FORCE_RMS[lv - 1] / force_rms, periods + 1)
        res = Plant(model, fine_fs, [arm], response_kind="acceleration").run(
            (GAIN * volt)[:, None])
        force = STINGER * (res.displacement[:, arm] - res.displacement[:, DRIVE])
        fine = np.column_stack([force, volt, res.acceleration[:, [DRIVE, WING, PAYLOAD]]])
        rec = decimate(fine, UP, ftype="fir", axis=0, zero_phase=True)
        acc = rec[:, 2:]
        acc = acc + ACC_NOISE * acc.std(axis=0) * rng.standard_normal(acc.shape)
        frc = rec[:, 0] + FORCE_NOISE * rec[:, 0].std() * rng.standard_normal(rec.shape[0])
        out.append({"Force": frc[None, :], "Voltage": rec[:, 1][None, :],
                    "Acceleration": acc.T.copy(), "Fs": np.array([[FS]])})
    return Twin(out, period, periods, joint)


def file_name(level: int, kind: str = "FullMSine") -> str:
    """The F-16 export's name of a level (``..._Validation`` for levels 2, 4, 6)."""
    tail = "_Validation" if level in VALIDATION else ""
    return f"F16Data_{kind}_Level{level}{tail}.mat"


def export_mat(t: Twin, folder: Path, levels: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7)
               ) -> list[Path]:
    """Write each level as its own MAT file, F-16 names and variables; returns the paths."""
    from scipy.io import savemat
    paths = []
    for lv, data in zip(levels, t.levels):
        p = Path(folder) / file_name(lv)
        savemat(p, data)
        paths.append(p)
    return paths


def export_csv(t: Twin, folder: Path, levels: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7)
               ) -> list[Path]:
    """The CSV twins: header ``Force,Voltage,Acceleration1,Acceleration2,Acceleration3``, no
    time column, no units, no sample rate."""
    paths = []
    for lv, data in zip(levels, t.levels):
        p = Path(folder) / file_name(lv).replace(".mat", ".csv")
        cols = np.vstack([data["Force"], data["Voltage"], data["Acceleration"]]).T
        np.savetxt(p, cols, delimiter=",", fmt="%.10g",
                   header="Force,Voltage,Acceleration1,Acceleration2,Acceleration3",
                   comments="")
        paths.append(p)
    return paths


def recordings(t: Twin) -> list:
    """The levels as the importer makes them (``--map force=Force
    response=Acceleration[0:3]:m/s^2 force_dofs=0 force_hold='"none"' period=...
    transient_periods=1``), for tests of the analysis alone."""
    from analysis.recordings import PeriodicLayout, Recording
    out = []
    for data in t.levels:
        out.append(Recording(fs=FS, excitation="random", force_dofs=np.array([0]),
                             force=data["Force"].T.copy(), response=data["Acceleration"].T.copy(),
                             response_kind="acceleration", force_hold="none",
                             layout=PeriodicLayout(t.period, 1, t.periods, 1)))
    return out
