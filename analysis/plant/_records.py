"""The numba records the plant kernel (`analysis.plant._plant_kernels`) takes and works in:
what `Plant._discretise` builds for ``m`` substeps (`Discretisation`), the integrator state
(`PlantState`), the per-sample outputs (`Outputs`) and the kernel's scratch (`Work`).

NamedTuples of arrays: measured against a ``numba.experimental.jitclass`` and a
``structref`` holding the same arrays (`benchmarks/bench_plant.py --case records`), they
compile and run as fast when the helpers reading them are inlined, and unlike a jitclass
they are cached on disk and need no boxing code.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np


class Discretisation(NamedTuple):
    """What `integrate` takes from `analysis.plant._plant.Plant._discretise`: the exact
    discretisation of the linear part for ``m`` substeps per sample, the element tables and
    the output matrices."""

    phi: np.ndarray        # (2n, 2n) state transition; (0, 0) for a decoupled model
    phi_d: np.ndarray      # (4, n) the 2 x 2 blocks' diagonals of a decoupled model, else (4, 0)
    inj_f: np.ndarray      # (1 or 2, n_in, 2n) drive at the substep end (and start)
    inj_g: np.ndarray      # (q or 0, n_e, 2n) element history injected each substep (direct form)
    u_g: np.ndarray        # (n_e, 2n) end-node element force into the state
    we: np.ndarray         # (n_e, 2n) its hold weight (force jumps)
    r_g: np.ndarray        # (q, n_e, 2n) pending part of each history age
    r_v: np.ndarray        # (n_e, n_z) pending part of the deformation rates
    wq: np.ndarray         # (n_e, n) element directions in internal coordinates
    corr: np.ndarray       # (2 n_e, n_z) pending part of the deformations and rates
    pwe: np.ndarray        # (2 n_e, n_e) end-node forces into deformations and rates
    ab: np.ndarray         # (n_e, n_taylor, 2n) A^i b of each element
    pab: np.ndarray        # (n_e, n_taylor, 2 n_e) the same at the elements
    vinv: np.ndarray       # (q + 1, q + 1) hold nodes -> monomials
    xpred: np.ndarray      # (q,) predictor weights of the history
    inv_fact: np.ndarray   # 1 / k!
    codes: np.ndarray      # (n_e,) int64 kind codes
    smooth: np.ndarray     # (n_e,) bool: memoryless kinds
    prm: np.ndarray        # (n_e, N_PARAM) packed parameters
    h: float               # substep, s
    shapes: np.ndarray     # (n_pt, n) T
    identity: bool         # T = I
    tax: np.ndarray        # (n_pt, n) acceleration per displacement at the points
    tav: np.ndarray        # (n_pt, n) acceleration per velocity at the points
    out_z: np.ndarray      # (3, n_pt, n_z) pending part of x, v, a at the points


class PlantState(NamedTuple):
    """The integrator state, updated in place: accumulated state ``s`` (`analysis.plant._plant`,
    Method), element forces ``gh`` and deformations ``uh`` at the hold nodes, element memory
    ``es`` and the last force sample ``fprev``."""

    s: np.ndarray
    gh: np.ndarray
    uh: np.ndarray
    es: np.ndarray
    fprev: np.ndarray


class Outputs(NamedTuple):
    """Per output sample: displacement, velocity and acceleration at the points, element
    forces, element deformations then rates."""

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    g: np.ndarray
    uv: np.ndarray


class Work(NamedTuple):
    """Scratch of one `integrate` call (allocated once per call: an allocation per substep
    costs more than its arithmetic). ``ne`` elements, ``q`` history nodes."""

    kn: np.ndarray         # (2n,) known part of the end state
    pk: np.ndarray         # (2 ne,) known part of the deformations and rates
    uv: np.ndarray         # (2 ne,) deformations and rates at the end node
    acc: np.ndarray        # (2 ne,) their next iterate
    delta: np.ndarray      # (2 ne,) last corrector change of the deformations and rates
    g: np.ndarray          # (ne,) force at the end node (the branch the element ends on)
    gc: np.ndarray         # (ne,) force the hold polynomial uses at the end node (old branch)
    sigma0: np.ndarray     # (ne,) slip direction at the substep start (stick_slip)
    vh: np.ndarray         # (ne,) deformation rates at the last node
    st: np.ndarray         # (ne, n_state) element memory at the end node
    pscr: np.ndarray       # (n_param,) one element's parameters
    sin: np.ndarray        # (n_state,) one element's memory in
    sout: np.ndarray       # (n_state,) and out
    event: np.ndarray      # (ne,) int: 0 none, 1 stick->slip, 2 slip->stick
    ev_prev: np.ndarray    # (ne,) int: the events of the previous iterate
    ev_theta: np.ndarray   # (ne,) event time fraction in the substep
    ev_ut: np.ndarray      # (ne,) deformation at a slip->stick event
    ev_c: np.ndarray       # (ne, n_taylor) jump weights of each event
    dnodes: np.ndarray     # (q + 1,) force jump at the hold nodes
    dmono: np.ndarray      # (q + 1,) scratch of `jump_coeffs`
    dsh: np.ndarray        # (q + 1,) scratch of `jump_coeffs`
    gold: np.ndarray       # (q,) history before an event rewrites it
    fa: np.ndarray         # (n_in,) drive at the substep start
    fb: np.ndarray         # (n_in,) and end
    z: np.ndarray          # (n_z,) drive and hold history the pending terms act on
    lin: np.ndarray        # (4, ne) closing: force change, its error bound, end tangents


@numba.njit(cache=True)
def work(d: Discretisation, state: PlantState, n_in: int) -> Work:
    """Scratch arrays for `integrate` on ``d`` and ``state`` with ``n_in`` drive inputs."""
    ny = state.s.shape[0]
    ne, q = state.gh.shape
    nt, nst = d.ab.shape[1], state.es.shape[1]
    return Work(np.empty(ny), np.empty(2 * ne), np.empty(2 * ne), np.empty(2 * ne),
                np.empty(2 * ne), np.zeros(ne), np.zeros(ne), np.zeros(ne), np.empty(ne),
                state.es.copy(), np.empty(d.prm.shape[1]), np.empty(nst), np.empty(nst),
                np.zeros(ne, dtype=np.int64), np.zeros(ne, dtype=np.int64), np.zeros(ne),
                np.zeros(ne), np.zeros((ne, nt)), np.empty(q + 1), np.empty(q + 1),
                np.empty(q + 1), np.empty(q), np.empty(n_in), np.empty(n_in),
                np.empty(n_in + q * ne), np.empty((4, ne)))
