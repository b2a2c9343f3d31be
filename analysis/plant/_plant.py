"""Simulated plant: time integration of ``M x'' + C x' + K x + sum w g = B f``.

Drive definition
----------------
The drive force between samples is the **first-order hold** (linear interpolation) of its
samples. Sample ``k`` of a block sits at the sample instant the response sample ``k`` is reported
for; the plant starts at rest with zero force one sample period before the first sample after
construction or `Plant.reset`. Blocks passed to successive `Plant.run` calls continue the same
record: the force is interpolated from the previous block's last sample.

Method
------
Each output interval ``1/fs`` is split into ``oversample`` substeps of length ``h``.

* The linear part is discretised exactly (matrix exponential and phi functions of
  ``A = [[0, I], [-M^-1 K, -M^-1 C]]``); the first-order-hold drive is integrated exactly too.
* The element forces ``g(t)`` are held by the degree-5 polynomial through their values at the
  substep end and the five previous substep nodes (an exponential Adams-Moulton scheme, sixth
  order local, fifth order global; measured convergence on the benchmark model is ~h^5); the
  end value is implicit and found by fixed-point iteration on the element
  deformations (predictor = extrapolated history, corrector to a relative 1e-12, closed by
  the laws' tangents when what remains is below that: `_plant_kernels`). Element memory
  state is committed only when a substep is accepted (`element_force` ``s_in``/``s_out``).
* The state advanced by the loop is the *accumulated* state ``s = y + R z``: ``z`` holds the
  drive and element forces at the last hold nodes, ``R z`` what they will still add to the
  coming substeps (their hold weights carried back by ``Phi^-1``), so that each node's whole
  influence enters ``s`` once, when it is known, instead of at every substep of its stencil;
  the element deformations and the outputs subtract the pending part in element and point
  space. This needs ``Phi^-HOLD_DEGREE`` to stay moderate; a linear system decaying faster
  than ``e^MAX_LOG_GROWTH`` over the stencil uses the direct form (history injected every
  substep). ``Phi^-1`` is a matrix exponential of its own (as accurate as ``Phi``).
* A modal model (diagonal ``M, C, K``) propagates per mode (2 x 2 blocks of ``Phi``); the
  matrix exponentials are computed block by block (connected components of ``A``), so their
  zero pattern is exact. Displacement, velocity and acceleration are computed at the points
  only (``T``-premultiplied output matrices), and a sticking ``stick_slip`` element's
  predictor solves its linear law exactly.
* ``stick_slip`` transitions are located inside the substep: stick -> slip where the stick
  branch reaches ``+-fd``, slip -> stick where the deformation rate reverses (cubic Hermite
  interpolation). The force jump relative to the hold polynomial is integrated exactly with the
  phi-function series, and the slider position is taken at the located reversal, so the
  nonsmooth element keeps the scheme's accuracy. The other kinds use `element_force` as is
  (hysteresis reversals are taken at substep resolution).

Sensor sampling
---------------
`Plant.run` returns the *instantaneous* values at the sample instants. The first-order-hold
drive has spectral images at ``f + m fs``; the structure passes them to its response through
its mass line ``M^-1 B`` and sampling folds them back onto ``f``: in the sampled acceleration
they make the drive sample itself appear instead of its baseband part (``12 %`` error of the
force term at ``f = 0.2 fs``), in velocity and displacement they are smaller (~1 % and ~0.4 %
there). A real DAQ's anti-alias filter removes them. `remove_hold_images` does the same for a
whole record (and `drivers.rig.SimRig` while streaming, with a lookahead of
``HOLD_IMAGE_LOOKAHEAD`` samples): it subtracts the folded images of the linear structure's
high-frequency expansion ``M^-1 B - M^-1 C M^-1 B / (i w) + ...`` (three terms,
`Plant.image_gains`, `analysis.recordings.hold_image_gain`), after which every response kind
follows the first-order-hold convention ``Y(f) = H_kind(f) sinc^2(f/fs) F(f)`` of the
estimators (``force_hold = "linear"``): to 2e-6 on a linear SDOF at ``0.2 fs``, what remains
being of relative order ``(f_n / fs)^3`` of the removed term (``f_n`` the highest natural
frequency). `simulate` returns records treated this way. Not removed: the harmonics an
element generates above ``fs/2`` (genuine response content a real anti-alias filter would
also cut), which still fold into instantaneous samples, most in acceleration.

Substeps (``oversample=None``, the default)
-------------------------------------------
The run starts from `auto_oversample`: ``h * omega <= 0.25`` with ``omega`` the largest of the
highest natural frequency (rad/s) of ``K`` stiffened by every element at its stiffest known
slope (`_substep_rule._element_stiffness`: stick_slip ``kd``, hysteresis initial slope ``kd``, gap ``k``) and
the decay rate of the viscous slopes (Coulomb ``fc / v_reg``). Amplitude-dependent tangents
(cubic and quadratic springs and dampers) are only known while running, and the error of the
hold grows with them, so the run is checked by step doubling: a chunk of at most
``CHUNK`` samples whose running tangent frequency (the same rule with each element's largest
slope over the chunk) exceeds the largest already checked is integrated again from its start
with twice the substeps (the eigenvalue problem of the rule is skipped while every element
slope stays below a bound proven to keep it checked, `_bound`); if the two differ by more
than ``accuracy`` (relative, displacement and velocity at the points), the substeps are
raised for good (by the ``ORDER``-th root of the excess, at most doubled; the hold history
is resampled), the chunk is run again and checked in turn.
The check is local: where the dynamics amplify small differences strongly (measured: x300
within 0.1 s on the 3-DOF chain with a 4e16 cubic at 40 N rms on two DOFs, against
solve_ivp too), the global error can exceed ``accuracy`` by that factor.
`PlantOutput.oversample` and `Plant.describe_stats` report the substeps used and how often
they were raised. An explicit ``oversample`` fixes the substeps (no checks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NotRequired, Sequence, TypedDict

import numpy as np

from . import _plant_kernels as _k
from ._records import Discretisation, Outputs as _Outputs, PlantState
from ._substep_rule import (_blocks, _element_slopes, _phi_functions, _tangent_omega,
                            auto_oversample, one_blas_thread)
from ..models import KINDS, N_BUILTIN, N_PARAM, N_STATE, Model, pack_params
from ..errors import InputError
from ..recordings import RESPONSE_KINDS, hold_image_response, remove_hold_images

__all__ = ["Plant", "PlantError", "PlantOutput", "SavedState", "add_relative_noise",
           "auto_oversample", "hold_image_response", "remove_hold_images", "simulate"]

HOLD_DEGREE = 5
ACCURACY = 3e-7        # default step-doubling bound per chunk (relative)
CHUNK = 1024           # samples per step-doubling check
CHECK_MARGIN = 1.2     # re-check when the running tangent frequency grows by this factor
MAX_OVERSAMPLE = 4096
MAX_LOG_GROWTH = 7.0   # accumulated form while Phi^-HOLD_DEGREE grows by at most e^this
ORDER = 5              # measured convergence order of the scheme (global)
RAISE_SAFETY = 1.2     # raise the substeps this much beyond the order estimate
_N_TAYLOR = 24


class PlantError(InputError):
    """Bad plant settings or drive."""


@dataclass
class PlantOutput:
    """Result of one `Plant.run` block; arrays are (n, n_dof) unless noted."""

    displacement: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    response: np.ndarray          # response_kind with the sensor noise added
    element_forces: np.ndarray    # (n, n_elements): g of each element at the samples
    oversample: int = 1           # substeps per sample at the end of the block


class SavedState(TypedDict):
    """A plant's full state (`Plant.state`, `Plant.set_state`): ``x``, ``v`` in internal
    coordinates, element memory, hold history and the substeps per sample it is spaced for,
    the last force sample, the noise generator's state and the integrator's accumulated
    state. A dict, so a caller may start from one with some entries replaced
    (``dict(saved, x=..., v=...)``); ``oversample`` and ``accumulated`` may be left out."""

    x: np.ndarray
    v: np.ndarray
    oversample: NotRequired[int]
    element_state: np.ndarray
    force_history: np.ndarray
    deformation_history: np.ndarray
    force_prev: np.ndarray
    rng: dict[str, Any]          # `numpy.random.BitGenerator.state`, numpy's own dict
    accumulated: NotRequired[np.ndarray]


@dataclass(frozen=True)
class _Kernel:
    """What `Plant._discretise` builds for ``m`` substeps per sample: ``disc``, the
    `Discretisation` `analysis.plant._plant_kernels.integrate` takes, and ``r_z``: the
    pending history in the accumulated state is ``r_z z`` (`Plant._pending`)."""

    disc: Discretisation
    r_z: np.ndarray


class Plant:
    """Simulated structure driven by forces, with optional sensor noise.

    Parameters
    ----------
    model : Model
        Complete model (every element parameter known); the plant integrates its internal
        coordinates and reports the points.
    fs : float
        Output sample rate, Hz.
    force_dofs : sequence of int
        Point (0-based) each drive channel acts on.
    oversample : int, optional
        Internal substeps per output sample, fixed; None (default) starts from
        `auto_oversample` and raises it where step doubling finds the run less accurate than
        ``accuracy`` (module docstring).
    noise_std : float or array_like of shape (n_dof,)
        Absolute sensor-noise standard deviation per point, in the units of `response_kind`.
    response_kind : {"displacement", "velocity", "acceleration"}
        Quantity reported in `PlantOutput.response`.
    seed : int, optional
        Seed of the noise generator (re-seeded by `reset`).
    accuracy : float
        Relative bound of the step-doubling check with automatic substeps.
    """

    def __init__(self, model: Model, fs: float, force_dofs: Sequence[int], *,
                 oversample: int | None = None, noise_std: float | np.ndarray = 0.0,
                 response_kind: str = "displacement", seed: int | None = None,
                 accuracy: float = ACCURACY) -> None:
        model.require_complete("the simulated plant")
        self.model = model
        n = model.n_dof
        if not (isinstance(fs, (int, float, np.number)) and math.isfinite(fs) and fs > 0):
            raise PlantError(f"sample rate fs must be a positive number, got {fs!r}")
        self.fs = float(fs)
        dofs = np.atleast_1d(np.asarray(force_dofs))
        if dofs.size == 0 or dofs.ndim != 1 or not np.issubdtype(dofs.dtype, np.integer) \
                or dofs.min() < 0 or dofs.max() >= n:
            raise PlantError(f"force_dofs {np.asarray(force_dofs).tolist()} must be a list of "
                             f"DOF indices in 0..{n - 1} (0-based)")
        self.force_dofs = dofs.astype(int)
        if response_kind not in RESPONSE_KINDS:
            raise PlantError(f"response_kind '{response_kind}' is not one of "
                             f"{', '.join(RESPONSE_KINDS)}")
        self.response_kind = response_kind
        std = np.broadcast_to(np.asarray(noise_std, dtype=float), (n,)) \
            if np.ndim(noise_std) in (0, 1) and np.size(noise_std) in (1, n) else None
        if std is None or not np.all(np.isfinite(std)) or np.any(std < 0):
            raise PlantError(f"noise_std must be a number >= 0 or {n} of them (one per DOF)")
        self.noise_std = std.copy()
        if not (isinstance(accuracy, (int, float)) and 0 < accuracy < 1):
            raise PlantError(f"accuracy must be a number in (0, 1), got {accuracy!r}")
        self.accuracy = float(accuracy)
        self.adaptive = oversample is None and bool(model.elements)
        if oversample is None:
            oversample = auto_oversample(model, self.fs)
        if isinstance(oversample, bool) or not isinstance(oversample, (int, np.integer)) \
                or oversample < 1:
            raise PlantError(f"oversample must be an integer >= 1 (or None for auto), "
                             f"got {oversample!r}")
        self.oversample = self._initial_oversample = int(oversample)
        self.seed = seed
        mc, mk = np.linalg.solve(model.mass, model.damping), np.linalg.solve(model.mass,
                                                                           model.stiffness)
        d = np.linalg.solve(model.mass, self._input_q())
        #: ``(G_0, G_1, G_2)``, each (n_dof, n_in): the acceleration per force at high
        #: frequency is ``sum_j G_j (i w)^-j`` (``G_0 = T M^-1 T'B``; `remove_hold_images`)
        self.image_gains = tuple(model.shapes @ g for g in (d, -mc @ d, (mc @ mc - mk) @ d))
        n_q = model.n_q
        self._a = np.block([[np.zeros((n_q, n_q)), np.eye(n_q)], [-mk, -mc]])
        #: fastest decay rate of the linear system, 1/s (`_discretise`: accumulated form)
        self._decay = max(0.0, float(-np.linalg.eigvals(self._a).real.min()))
        self._blocks = _blocks(self._a)     # those of ``A h`` and ``-A h`` for every step
        self._wq = np.array([model.to_q(el.w) for el in model.elements]).reshape(-1, n_q)
        self._kernels: dict[int, _Kernel] = {}
        self.stats = np.zeros(4, dtype=np.int64)
        self.reset()

    # --- set-up -----------------------------------------------------------------------
    def _input_q(self) -> np.ndarray:
        """The force directions in internal coordinates, (n_q, n_in)."""
        return self.model.shapes[self.force_dofs].T

    def _kernel(self, m: int) -> _Kernel:
        """Integrator arrays for ``m`` substeps per sample (cached; BLAS on one thread:
        small matrices, `one_blas_thread`)."""
        if m not in self._kernels:
            with one_blas_thread():
                self._kernels[m] = self._discretise(m)
        return self._kernels[m]

    def _discretise(self, m: int) -> _Kernel:
        """Arrays for ``m`` substeps per sample (`_Kernel`)."""
        model, n, q, wq = self.model, self.model.n_q, HOLD_DEGREE, self._wq
        h = 1.0 / (self.fs * m)
        minv = np.linalg.inv(model.mass)
        a = self._a
        sel = self._input_q()
        ne = wq.shape[0]
        bf = np.vstack([np.zeros_like(sel), minv @ sel])
        bg = np.vstack([np.zeros((n, ne)), -minv @ wq.T])
        phis = _phi_functions(a * h, q + 1, self._blocks)
        nodes = np.arange(1 - q, 2, dtype=float)
        vinv = np.linalg.inv(np.vander(nodes, increasing=True))
        mono = [h * math.factorial(j) * phis[j + 1] @ bg for j in range(q + 1)]
        # weights of the element force at the node ``d`` substeps before the end node
        wd = [sum(vinv[j, q - d] * mono[j] for j in range(q + 1)) for d in range(q + 1)]
        wf0, wf1 = h * (phis[1] - phis[2]) @ bf, h * phis[2] @ bf    # drive: start, end
        u_g, r_g, inj_f, r_f, inj_g = self._hold_weights(h, wd, wf0, wf1)
        proj = np.zeros((2 * ne, 2 * n))
        proj[:ne, :n] = wq
        proj[ne:, n:] = wq
        ab = np.zeros((ne, _N_TAYLOR, 2 * n))
        for e in range(ne):
            col = bg[:, e]
            for i in range(_N_TAYLOR):
                ab[e, i] = col
                col = a @ col
        hist = nodes[:q]
        xpred = np.array([np.prod([(1.0 - hist[k]) / (hist[i] - hist[k])
                                   for k in range(q) if k != i]) for i in range(q)])
        # outputs at the points: y -> (x, v, a), less the pending history
        t = model.shapes
        tax, tav = -t @ minv @ model.stiffness, -t @ minv @ model.damping
        zero = np.zeros_like(t)
        cy = np.block([[t, zero], [zero, t], [tax, tav]])
        npt = t.shape[0]
        # their weights on [drive, hold history by age] (`integrate`: ``z``)
        out_g = -cy @ r_g
        out_g[0, 2 * npt:] += -t @ minv @ wq.T
        out_z = np.hstack([np.vstack([np.zeros((2 * npt, sel.shape[1])), t @ minv @ sel])
                           - cy @ r_f, *out_g])
        corr = -np.hstack([proj @ r_f, *(proj @ r for r in r_g[1:])])
        diagonal = model.decoupled
        phi_d = np.array([np.diag(phis[0][:n, :n]), np.diag(phis[0][:n, n:]),
                          np.diag(phis[0][n:, :n]), np.diag(phis[0][n:, n:])])
        args = dict(
            phi=np.zeros((0, 0)) if diagonal else phis[0],
            phi_d=phi_d if diagonal else np.zeros((4, 0)),
            inj_f=np.transpose(inj_f, (0, 2, 1)), inj_g=np.transpose(inj_g, (0, 2, 1)),
            u_g=u_g.T, we=wd[0].T, r_g=np.transpose(r_g, (0, 2, 1)), wq=wq,
            corr=corr, pwe=proj @ wd[0],
            ab=ab, pab=np.ascontiguousarray(ab @ proj.T), vinv=vinv, xpred=xpred,
            inv_fact=np.array([1.0 / math.factorial(k) for k in range(_N_TAYLOR + q + 3)]),
            prm=np.array([pack_params(el.kind, el.params)
                          for el in model.elements]).reshape(ne, N_PARAM),
            shapes=t, tax=tax, tav=tav, out_z=out_z.reshape(3, npt, -1))
        args = {k: np.ascontiguousarray(v, dtype=float) for k, v in args.items()}
        args.update(codes=np.array([KINDS[el.kind].code for el in model.elements],
                                   dtype=np.int64), h=h, identity=not model.is_modal,
                    smooth=np.array([not KINDS[el.kind].memory for el in model.elements],
                                    dtype=np.bool_))
        r_z = np.hstack([r_f, *r_g])
        args["r_v"] = np.ascontiguousarray(wq @ r_z[n:])
        return _Kernel(Discretisation(**{name: args[name] for name in Discretisation._fields}),
                       r_z)

    def _hold_weights(self, h: float, wd: list[np.ndarray], wf0: np.ndarray,
                      wf1: np.ndarray) -> tuple[np.ndarray, ...]:
        """The hold weights of ``_discretise`` in the accumulated form where ``Phi^-q`` stays
        moderate, else the direct form (Method): ``u_g`` (end-node force into the state),
        ``r_g`` (pending part of each history age), ``inj_f`` (drive injected each substep),
        ``r_f`` (its pending part) and ``inj_g`` (history injected each substep)."""
        n, q, ne = self.model.n_q, HOLD_DEGREE, self._wq.shape[0]
        if q * h * self._decay <= MAX_LOG_GROWTH:
            # accumulated form: each node's whole influence enters the state once
            back = [np.eye(2 * n)]
            inv = _phi_functions(-self._a * h, 0, self._blocks)[0]   # Phi^-1, as accurate
            for _ in range(q):
                back.append(inv @ back[-1])
            u_g = sum(back[d] @ wd[d] for d in range(q + 1))
            r_g = np.array([sum(back[d - b] @ wd[d] for d in range(b + 1, q + 1))
                            for b in range(q)])
            return u_g, r_g, np.array([wf1 + inv @ wf0]), inv @ wf0, np.zeros((0, 2 * n, ne))
        return (wd[0], np.zeros((q, 2 * n, ne)), np.array([wf1, wf0]), np.zeros_like(wf0),
                np.array(wd[1:]))

    # --- state ------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to rest with virgin elements and zero force; the noise RNG is re-seeded."""
        n, ne = self.model.n_q, len(self.model.elements)
        self._s = np.zeros(2 * n)      # accumulated state (Method), at self.oversample
        self._gh = np.zeros((ne, HOLD_DEGREE))
        self._uh = np.zeros((ne, HOLD_DEGREE))
        self._es = np.zeros((ne, N_STATE))
        self._fprev = np.zeros(self.force_dofs.size)
        self._rng = np.random.default_rng(self.seed)
        self.oversample = self._initial_oversample
        self._checked_omega = 0.0
        self._bound_slopes = np.full((2, ne), -1.0)   # slopes known to keep omega checked
        self._peak_ok = np.full(2 * ne, -1.0)          # element peaks within those slopes
        self._no_peaks, self._any_peaks = np.full(2 * ne, -1.0), np.full(2 * ne, np.inf)
        self._start = PlantState(*(np.zeros_like(a) for a in (self._s, self._gh, self._uh,
                                                              self._es, self._fprev)))
        self.raised = 0         # times step doubling raised the substeps since the reset

    @property
    def state(self) -> SavedState:
        """Copy of the full state: ``x``, ``v`` (internal coordinates), element memory and
        hold history (with the substeps per sample it is spaced for), last force sample and
        noise-generator state. Pass it to `set_state` to resume from here (bit for bit: it
        also holds the integrator's ``accumulated`` state, used while ``x, v`` and the
        history are left as they are)."""
        n = self.model.n_q
        y = self._s - self._pending(self.oversample, self._fprev, self._gh)
        return SavedState(x=y[:n], v=y[n:], oversample=self.oversample,
                          element_state=self._es.copy(), force_history=self._gh.copy(),
                          deformation_history=self._uh.copy(), force_prev=self._fprev.copy(),
                          rng=self._rng.bit_generator.state, accumulated=self._s.copy())

    def set_state(self, state: SavedState) -> None:
        """Restore a state returned by `state` (of a plant with the same model and settings)."""
        n = self.model.n_q
        current = {"x": self._s[:n], "v": self._s[n:], "element_state": self._es,
                   "force_history": self._gh, "deformation_history": self._uh,
                   "force_prev": self._fprev}
        new = {}
        for key, old in current.items():
            new[key] = np.array(state[key], dtype=float)
            if new[key].shape != old.shape:
                raise PlantError(f"state entry {key} has shape {new[key].shape}, this plant "
                                 f"needs {old.shape}")
        self._es, self._gh, self._uh, self._fprev = (new[k] for k in list(current)[2:])
        self._rng = np.random.default_rng()
        self._rng.bit_generator.state = state["rng"]
        self.oversample = int(state.get("oversample", self.oversample))
        y = np.concatenate([new["x"], new["v"]])
        pending = self._pending(self.oversample, self._fprev, self._gh)
        acc = np.asarray(state.get("accumulated", np.zeros(0)), dtype=float)
        same = acc.shape == y.shape and np.array_equal(acc - pending, y)
        self._s = acc.copy() if same else y + pending

    def _pending(self, m: int, fprev: np.ndarray, gh: np.ndarray) -> np.ndarray:
        """What the accumulated state holds beyond the state at ``m`` substeps per sample:
        the influence of the drive and hold history on the coming substeps (Method)."""
        return self._kernel(m).r_z @ np.concatenate([fprev, gh[:, ::-1].T.ravel()])

    # --- running ----------------------------------------------------------------------
    def run(self, force: np.ndarray) -> PlantOutput:
        """Drive the plant with ``force`` (n, n_in) from its current state.

        Returns the noise-free displacement, velocity and acceleration at the ``n`` sample
        instants (instantaneous values: `remove_hold_images` makes a record of them what an
        anti-aliased sensor sees), the noisy `response` and the element forces.
        """
        force = np.asarray(force, dtype=float)
        n_in = self.force_dofs.size
        if force.ndim == 1 and n_in == 1:
            force = force[:, None]
        if force.ndim != 2 or force.shape[1] != n_in:
            raise PlantError(f"force must have shape (n, {n_in}) for force_dofs "
                             f"{self.force_dofs.tolist()}, got {force.shape}")
        if not np.all(np.isfinite(force)):
            raise PlantError("force holds NaN or infinite samples; repair the drive first")
        force = np.ascontiguousarray(force)
        n, ndof = force.shape[0], self.model.n_dof
        out = self._outputs(n)
        i = 0
        while i < n:
            i = self._advance(force, out, i)
        clean = {"displacement": out.x, "velocity": out.v,
                 "acceleration": out.a}[self.response_kind]
        response = clean.copy()
        if np.any(self.noise_std):
            response += self._rng.standard_normal((n, ndof)) * self.noise_std
        return PlantOutput(out.x, out.v, out.a, response, out.g, self.oversample)

    def _outputs(self, n: int) -> "_Outputs":
        """Empty output arrays for ``n`` samples."""
        npt, ne = self.model.n_dof, len(self.model.elements)
        return _Outputs(np.empty((n, npt)), np.empty((n, npt)), np.empty((n, npt)),
                      np.empty((n, ne)), np.empty((n, 2 * ne)))

    def _advance(self, force: np.ndarray, out: "_Outputs", i: int) -> int:
        """Integrate from sample ``i`` into ``out``; returns the sample to continue from.

        Fixed substeps: the rest of the record in one kernel call. Automatic ones: chunks of
        ``CHUNK`` samples in one kernel call while every element's deformation and rate
        peaks stay within those the check has cleared (`_checked`: the element slopes grow
        with them), then the first chunk beyond them is checked here."""
        n = force.shape[0]
        if not self.adaptive:
            self._integrate(force[i:], self.oversample, _Outputs(*(a[i:] for a in out)))
            return n
        j = i + self._integrate(force[i:], self.oversample, _Outputs(*(a[i:] for a in out)),
                                CHUNK, self._peak_ok)
        if j >= n:
            return n
        end = min(j + CHUNK, n)
        self._checked(force[j:end], _Outputs(*(a[j:end] for a in out)),
                      (*(a.copy() for a in self._start), self.oversample))
        return end

    def _integrate(self, force: np.ndarray, m: int, out: "_Outputs", chunk: int = 0,
                   peak_ok: np.ndarray | None = None) -> int:
        """Outputs at the points, element forces and deformations over ``force`` with ``m``
        substeps, into ``out``; with ``chunk`` and ``peak_ok``, stops after the first chunk
        whose element peaks exceed ``peak_ok`` and returns its first sample (`_advance`;
        its start state is in ``self._start``), else returns ``force.shape[0]``."""
        kern = self._kernel(m)
        strict = any(spec.code >= N_BUILTIN for spec in KINDS.values())
        kernel = _k.integrate_strict if strict else _k.integrate
        if peak_ok is None or strict:       # slopes of registered kinds: checked in Python
            peak_ok = self._no_peaks if peak_ok is not None else self._any_peaks
        done = kernel(force, m, kern.disc, PlantState(self._s, self._gh, self._uh,
                                                             self._es, self._fprev),
                      out, self.stats, chunk or max(force.shape[0], 1), peak_ok, self._start)
        if not np.all(np.isfinite(self._s)):
            raise PlantError("the simulation diverged; raise oversample or lower the drive")
        return done

    def _checked(self, force: np.ndarray, res: "_Outputs", start: tuple[Any, ...]) -> None:
        """The step-doubling check of the module docstring on one chunk ``force``, already
        integrated into ``res`` from the state ``start`` (`_snapshot`)."""
        peaks = _k.abs_peak(res.uv) if res.uv.size else np.zeros(res.uv.shape[1])
        slopes = _element_slopes(self.model, peaks)
        if np.all(slopes <= self._bound_slopes):
            self._peak_ok = np.maximum(self._peak_ok, peaks)
            return
        self._peak_ok = peaks
        omega = _tangent_omega(self.model, slopes)
        if omega <= self._checked_omega:
            self._bound_slopes = _bound(slopes, self._checked_omega / omega)
            return
        fine = self._outputs(force.shape[0])
        while True:
            end = self._snapshot()
            m = self.oversample
            self._restore(start, 2 * m)
            self._integrate(force, 2 * m, fine)
            err = max(_rel_diff(res.x, fine.x), _rel_diff(res.v, fine.v))
            if err <= self.accuracy or 2 * m > MAX_OVERSAMPLE:
                self._restore(end, m)
                self._checked_omega = CHECK_MARGIN * omega
                self._bound_slopes = _bound(slopes, CHECK_MARGIN)
                return
            # the difference is the error of the coarse run, ~ h^ORDER: aim below accuracy
            new = min(2 * m, max(m + 1, math.ceil(m * RAISE_SAFETY
                                                  * (err / self.accuracy) ** (1 / ORDER))))
            self.oversample = new
            self.raised += 1
            if new == 2 * m:
                for a, b in zip(res, fine):
                    a[...] = b
            else:
                self._restore(start, new)
                self._integrate(force, new, res)
            start = self._restore_copy(start, new)

    def _snapshot(self) -> tuple[Any, ...]:
        return (*(a.copy() for a in (self._s, self._gh, self._uh, self._es, self._fprev)),
                self.oversample)

    def _restore_copy(self, snap: tuple[Any, ...], m: int) -> tuple[Any, ...]:
        """``snap`` respaced for ``m`` substeps (see `_restore`), the state untouched."""
        keep = self._snapshot()
        self._restore(snap, m)
        out = (*self._snapshot()[:-1], m)
        self._restore(keep, keep[-1])
        return out

    def _restore(self, snap: tuple[Any, ...], m: int) -> None:
        """Set the integrator state to ``snap`` respaced for ``m`` substeps per sample
        (``m >=`` those of ``snap``): the hold history resampled by interpolation through
        its nodes, the accumulated state recomputed."""
        s, gh, uh, es, fprev = (a.copy() for a in snap[:-1])
        m_old = snap[-1]
        if m != m_old:
            y = s - self._pending(m_old, fprev, gh)
            q = gh.shape[1]
            old = np.arange(1 - q, 1, dtype=float)
            lag = np.array([[np.prod([(t - old[k]) / (old[i] - old[k])
                                      for k in range(q) if k != i]) for i in range(q)]
                            for t in old * m_old / m])
            gh, uh = gh @ lag.T, uh @ lag.T
            s = y + self._pending(m, fprev, gh)
        self._s, self._gh, self._uh, self._es, self._fprev = s, gh, uh, es, fprev

    def describe_stats(self) -> dict[str, float]:
        """Substeps (step-doubling checks included), mean corrector iterations, located
        events, unconverged substeps, substeps per sample now and times they were raised."""
        s = self.stats
        return {"substeps": int(s[0]), "iterations_per_substep": float(s[1] / max(s[0], 1)),
                "events": int(s[2]), "unconverged": int(s[3]), "oversample": self.oversample,
                "oversample_raised": self.raised}


def _bound(slopes: np.ndarray, factor: float) -> np.ndarray:
    """Element slopes up to which the tangent frequency stays below ``factor`` times that of
    ``slopes`` (``factor >= 1``): ``K + f S <= f (K + S)`` for ``K >= 0``, so the stiffness
    part grows by at most ``sqrt(f)`` and the viscous rate by ``f``."""
    return slopes * min(factor, 1e300)


def _rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    """``|a - b| / |b|`` (Frobenius), 0 for two zero arrays."""
    nb = np.linalg.norm(b)
    d = np.linalg.norm(a - b)
    return float(d / nb) if nb > 0 else (0.0 if d == 0 else math.inf)


def simulate(model: Model, force: np.ndarray, fs: float, force_dofs: Sequence[int], *,
             response_kind: str = "displacement", noise_std: float | np.ndarray = 0.0,
             seed: int | None = None, oversample: int | None = None) -> np.ndarray:
    """Anti-aliased response of a plant at rest to one drive record (`remove_hold_images`;
    see `Plant` for the parameters)."""
    plant = Plant(model, fs, force_dofs, oversample=oversample, noise_std=noise_std,
                  response_kind=response_kind, seed=seed)
    force = np.asarray(force, dtype=float)
    return remove_hold_images(plant.run(force).response, force, fs, response_kind,
                              plant.image_gains)


def add_relative_noise(signal: np.ndarray, fraction: float,
                       rng: np.random.Generator | int | None = None) -> np.ndarray:
    """Return ``signal`` plus Gaussian noise of std ``fraction * rms`` of each channel.

    Channels are along the last axis; the rms is taken over all other axes.
    """
    signal = np.asarray(signal, dtype=float)
    if not (math.isfinite(fraction) and fraction >= 0):
        raise PlantError(f"noise fraction must be a number >= 0, got {fraction!r}")
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    axes = tuple(range(signal.ndim - 1))
    rms = np.sqrt(np.mean(signal ** 2, axis=axes, keepdims=True)) if signal.ndim else \
        np.abs(signal)
    return signal + fraction * rms * rng.standard_normal(signal.shape)
