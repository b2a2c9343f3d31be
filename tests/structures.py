"""FE-like test structures that look like a ground vibration test, not like the simulator.

A clamped aluminium strip ("wing") of Euler–Bernoulli beam elements (transverse displacement and
rotation per node, consistent mass) carrying a payload mass on a spring joint: more modes in band
than sensors, most DOFs unmeasured, the joint between two measurable points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from analysis.models import Model


@dataclass
class FEStructure:
    """An FE model with named measurable points (DOF indices into the model)."""

    model: Model
    points: dict[str, int]

    def natural_frequencies(self) -> np.ndarray:
        return self.model.natural_frequencies()


def beam_with_payload(n_el: int = 10, length: float = 1.0, payload: float = 0.5,
                      joint_hz: float = 30.0, zeta: float = 0.01, payload_node: int = 7
                      ) -> FEStructure:
    """Clamped beam (``n_el`` elements, ``2 n_el`` DOFs) plus a payload DOF on a joint spring.

    DOF ``2 i`` is the transverse displacement of node ``i + 1`` (node 0 is clamped), DOF
    ``2 i + 1`` its rotation; the last DOF is the payload. The joint stiffness puts the payload
    alone on its spring at ``joint_hz``; damping is modal, ``zeta`` on every mode.
    """
    e, b, h, rho = 70e9, 0.05, 0.01, 2700.0
    ei, mu, le = e * b * h ** 3 / 12, rho * b * h, length / n_el
    ke = ei / le ** 3 * np.array([[12, 6 * le, -12, 6 * le],
                                  [6 * le, 4 * le ** 2, -6 * le, 2 * le ** 2],
                                  [-12, -6 * le, 12, -6 * le],
                                  [6 * le, 2 * le ** 2, -6 * le, 4 * le ** 2]])
    me = mu * le / 420 * np.array([[156, 22 * le, 54, -13 * le],
                                   [22 * le, 4 * le ** 2, 13 * le, -3 * le ** 2],
                                   [54, 13 * le, 156, -22 * le],
                                   [-13 * le, -3 * le ** 2, -22 * le, 4 * le ** 2]])
    n = 2 * (n_el + 1)
    K, M = np.zeros((n + 1, n + 1)), np.zeros((n + 1, n + 1))
    for i in range(n_el):
        idx = np.arange(2 * i, 2 * i + 4)
        K[np.ix_(idx, idx)] += ke
        M[np.ix_(idx, idx)] += me
    beam_dof = 2 * payload_node
    kj = payload * (2 * np.pi * joint_hz) ** 2
    for a, c, s in ((beam_dof, beam_dof, kj), (n, n, kj), (beam_dof, n, -kj), (n, beam_dof, -kj)):
        K[a, c] += s
    M[n, n] = payload
    keep = np.arange(2, n + 1)                       # clamp node 0
    K, M = K[np.ix_(keep, keep)], M[np.ix_(keep, keep)]
    lam, phi = eigh(K, M)
    C = M @ phi @ np.diag(2 * zeta * np.sqrt(lam)) @ phi.T @ M
    model = Model(M, 0.5 * (C + C.T), K, [], "clamped beam with payload")
    points = {"root": 2 * 1 - 2, "drive": 2 * 3 - 2, "joint": beam_dof - 2, "tip": n - 4,
              "payload": n - 2}
    return FEStructure(model, points)


def _seen_at(model, dofs: list[int]):
    """The FE model in ``[modal]`` form at ``dofs`` and the elements' DOFs, with every mode:
    the same dynamics there (responses within ~1e-10 on the beam), simulated mode by mode
    (4x faster than the dense FE propagation); the FE model itself when its damping is not
    modal (then the modal form would not be exact). Returns the model and its FE DOFs."""
    from scipy.linalg import eigh

    _, vec = eigh(model.stiffness, model.mass)
    c = vec.T @ model.damping @ vec
    if np.abs(c - np.diag(np.diag(c))).max() > 1e-12 * np.abs(c).max():
        return model, list(range(model.n_dof))
    used = {int(i) for el in model.elements for i in np.flatnonzero(el.w)}
    points = sorted(set(dofs) | used)
    return model.modal_form(points), points


def gvt_recording(structure: FEStructure, sensors: list[str], drive: str, force_fine,
                  fs: float, up: int, *, kind: str = "acceleration", noise: float = 0.01,
                  seed: int = 2, layout=None, level: float | None = None, elements=()):
    """What a DAQ records on this structure: simulated ``up`` times faster than ``fs``, the
    force and the responses at ``sensors`` through the same anti-alias filter and decimated
    (``force_hold = "none"``), relative sensor noise on the responses.

    ``force_fine`` is the drive at ``fs * up``; ``elements`` (over the FE DOFs) are added to
    the model for the run.
    """
    from scipy.signal import decimate

    from analysis.plant import Plant, add_relative_noise
    from analysis.recordings import Recording
    model = structure.model.with_elements(list(elements)) if elements else structure.model
    model, points = _seen_at(model, [structure.points[s] for s in [drive, *sensors]])
    cols = [points.index(structure.points[s]) for s in sensors]
    f = np.asarray(force_fine, dtype=float)
    out = Plant(model, fs * up, [points.index(structure.points[drive])],
                response_kind=kind).run(f[:, None])
    resp = decimate(out.response[:, cols], up, ftype="fir", axis=0, zero_phase=True)
    force = decimate(f, up, ftype="fir", zero_phase=True)[:, None]
    resp = add_relative_noise(resp, noise, np.random.default_rng(seed))
    return Recording(fs=fs, excitation="random", force_dofs=np.array([sensors.index(drive)]),
                     force=force, response=resp, response_kind=kind, level=level,
                     force_hold="none", layout=layout)
