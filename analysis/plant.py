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
  deformations (predictor = extrapolated history, corrector to a relative 1e-13). Element memory
  state is committed only when a substep is accepted (`element_force` ``s_in``/``s_out``).
* ``stick_slip`` transitions are located inside the substep: stick -> slip where the stick
  branch reaches ``+-fd``, slip -> stick where the deformation rate reverses (cubic Hermite
  interpolation). The force jump relative to the hold polynomial is integrated exactly with the
  phi-function series, and the slider position is taken at the located reversal, so the
  nonsmooth element keeps the scheme's accuracy. The other kinds use `element_force` as is
  (hysteresis reversals are taken at substep resolution).

Auto oversampling (``oversample=None``) keeps ``h * omega <= 0.25`` where ``omega`` is the
largest of: the highest natural frequency (rad/s) of ``K`` stiffened by every piecewise-linear
element at its stiffest (stick_slip ``kd``, hysteresis initial slope ``kd``, gap ``k``), and the
decay rate of the Coulomb elements' viscous slope ``fc / v_reg``. Amplitude-dependent tangents
(cubic and quadratic springs and dampers) are not known before the run: the implicit corrector
keeps them stable; at levels where their tangent exceeds the stiffness above, pass a larger
``oversample`` for full accuracy (`Plant.stats` reports corrector iterations per substep).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from scipy.linalg import eigh, expm

from . import _plant_kernels as _k
from .elements import KINDS, N_PARAM, N_STATE, pack_params
from .errors import InputError
from .model import Model
from .recording import RESPONSE_KINDS

HOLD_DEGREE = 5
AUTO_H_OMEGA = 0.25
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


def auto_oversample(model: Model, fs: float) -> int:
    """Substeps per output sample chosen by the rule in the module docstring."""
    if not model.elements:
        return 1
    stiff = model.stiffness.copy()
    visc = np.zeros_like(stiff)
    for el in model.elements:
        spec, ww = KINDS[el.kind], np.outer(el.w, el.w)
        if spec.stiffness is not None:
            stiff += spec.stiffness(el.params) * ww
        if spec.damping is not None:
            visc += spec.damping(el.params) * ww
    omega = math.sqrt(max(eigh(stiff, model.mass, eigvals_only=True).max(), 0.0))
    rate = max(eigh(visc, model.mass, eigvals_only=True).max(), 0.0)
    return max(1, math.ceil(max(omega, rate) / (AUTO_H_OMEGA * fs)))


def _phi_functions(z: np.ndarray, p: int) -> list[np.ndarray]:
    """``[exp(z), phi_1(z), ..., phi_p(z)]`` from one augmented matrix exponential."""
    n = z.shape[0]
    big = np.zeros((n * (p + 1), n * (p + 1)))
    big[:n, :n] = z
    for i in range(p):
        big[n * i:n * (i + 1), n * (i + 1):n * (i + 2)] = np.eye(n)
    e = expm(big)
    return [e[:n, n * i:n * (i + 1)] for i in range(p + 1)]


class Plant:
    """Simulated structure driven by forces, with optional sensor noise.

    Parameters
    ----------
    model : Model
        Complete model (every element parameter known).
    fs : float
        Output sample rate, Hz.
    force_dofs : sequence of int
        DOF (0-based) each drive channel acts on.
    oversample : int, optional
        Internal substeps per output sample; None chooses it by `auto_oversample`.
    noise_std : float or array_like of shape (n_dof,)
        Absolute sensor-noise standard deviation per DOF, in the units of `response_kind`.
    response_kind : {"displacement", "velocity", "acceleration"}
        Quantity reported in `PlantOutput.response`.
    seed : int, optional
        Seed of the noise generator (re-seeded by `reset`).
    """

    def __init__(self, model: Model, fs: float, force_dofs: Sequence[int], *,
                 oversample: int | None = None, noise_std: float | np.ndarray = 0.0,
                 response_kind: str = "displacement", seed: int | None = None) -> None:
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
        if oversample is None:
            oversample = auto_oversample(model, self.fs)
        if isinstance(oversample, bool) or not isinstance(oversample, (int, np.integer)) \
                or oversample < 1:
            raise PlantError(f"oversample must be an integer >= 1 (or None for auto), "
                             f"got {oversample!r}")
        self.oversample = int(oversample)
        self.seed = seed
        self._discretise()
        self.reset()

    # --- set-up -----------------------------------------------------------------------
    def _discretise(self) -> None:
        model, n, q = self.model, self.model.n_dof, HOLD_DEGREE
        h = 1.0 / (self.fs * self.oversample)
        minv = np.linalg.inv(model.mass)
        a = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-minv @ model.stiffness, -minv @ model.damping]])
        sel = np.zeros((n, self.force_dofs.size))
        sel[self.force_dofs, np.arange(self.force_dofs.size)] = 1.0
        wmat = np.array([el.w for el in model.elements]).reshape(-1, n)
        ne = wmat.shape[0]
        bf = np.vstack([np.zeros_like(sel), minv @ sel])
        bg = np.vstack([np.zeros((n, ne)), -minv @ wmat.T])
        phis = _phi_functions(a * h, q + 1)
        nodes = np.arange(1 - q, 2, dtype=float)
        vinv = np.linalg.inv(np.vander(nodes, increasing=True))
        mono = [h * math.factorial(j) * phis[j + 1] @ bg for j in range(q + 1)]
        weights = [sum(vinv[j, i] * mono[j] for j in range(q + 1)) for i in range(q + 1)]
        proj = np.zeros((2 * ne, 2 * n))
        proj[:ne, :n] = wmat
        proj[ne:, n:] = wmat
        ab = np.zeros((ne, _N_TAYLOR, 2 * n))
        for e in range(ne):
            col = bg[:, e]
            for i in range(_N_TAYLOR):
                ab[e, i] = col
                col = a @ col
        hist = nodes[:q]
        xpred = np.array([np.prod([(1.0 - hist[k]) / (hist[i] - hist[k])
                                   for k in range(q) if k != i]) for i in range(q)])
        we = np.ascontiguousarray(weights[q])
        self._h = h
        self._kernel_args = dict(
            phi=phis[0], wf0=h * (phis[1] - phis[2]) @ bf, wf1=h * phis[2] @ bf,
            wh=np.ascontiguousarray(np.array(weights[:q]).reshape(q, 2 * n, ne)), we=we,
            proj=proj, pwe=proj @ we, ab=ab, pab=np.ascontiguousarray(ab @ proj.T),
            vinv=np.ascontiguousarray(vinv), xpred=xpred,
            inv_fact=np.array([1.0 / math.factorial(k) for k in range(_N_TAYLOR + q + 3)]),
            acc_f=minv @ sel, acc_y=np.hstack([-minv @ model.stiffness, -minv @ model.damping]),
            acc_g=-minv @ wmat.T,
            codes=np.array([KINDS[el.kind].code for el in model.elements], dtype=np.int64),
            prm=np.array([pack_params(el.kind, el.params)
                          for el in model.elements]).reshape(ne, N_PARAM))
        self._kernel_args = {k: np.ascontiguousarray(v) for k, v in self._kernel_args.items()}
        self.stats = np.zeros(4, dtype=np.int64)

    # --- state ------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to rest with virgin elements and zero force; the noise RNG is re-seeded."""
        n, ne = self.model.n_dof, len(self.model.elements)
        self._y = np.zeros(2 * n)
        self._gh = np.zeros((ne, HOLD_DEGREE))
        self._uh = np.zeros((ne, HOLD_DEGREE))
        self._es = np.zeros((ne, N_STATE))
        self._fprev = np.zeros(self.force_dofs.size)
        self._rng = np.random.default_rng(self.seed)

    @property
    def state(self) -> dict[str, Any]:
        """Copy of the full state: ``x``, ``v``, element memory and hold history, last force
        sample and noise-generator state. Pass it to `set_state` to resume from here."""
        n = self.model.n_dof
        return {"x": self._y[:n].copy(), "v": self._y[n:].copy(),
                "element_state": self._es.copy(), "force_history": self._gh.copy(),
                "deformation_history": self._uh.copy(), "force_prev": self._fprev.copy(),
                "rng": self._rng.bit_generator.state}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a state returned by `state` (of a plant with the same model and settings)."""
        new = {"_y": np.concatenate([state["x"], state["v"]]), "_es": state["element_state"],
               "_gh": state["force_history"], "_uh": state["deformation_history"],
               "_fprev": state["force_prev"]}
        for key, value in new.items():
            old = getattr(self, key)
            value = np.array(value, dtype=float)
            if value.shape != old.shape:
                raise PlantError(f"state entry for {key.strip('_')} has shape {value.shape}, "
                                 f"this plant needs {old.shape}")
            setattr(self, key, value)
        self._rng = np.random.default_rng()
        self._rng.bit_generator.state = state["rng"]

    # --- running ----------------------------------------------------------------------
    def run(self, force: np.ndarray) -> PlantOutput:
        """Drive the plant with ``force`` (n, n_in) from its current state.

        Returns the noise-free displacement, velocity and acceleration at the ``n`` sample
        instants, the noisy `response` and the element forces.
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
        n, ndof, ne = force.shape[0], self.model.n_dof, len(self.model.elements)
        out_y = np.empty((n, 2 * ndof))
        out_g = np.empty((n, ne))
        acc = np.empty((n, ndof))
        _k.integrate(force, self.oversample, **self._kernel_args, h=self._h, y=self._y,
                     gh=self._gh, uh=self._uh, es=self._es, fprev=self._fprev,
                     out_y=out_y, out_g=out_g, out_a=acc, stats=self.stats)
        if not np.all(np.isfinite(self._y)):
            raise PlantError("the simulation diverged; raise oversample or lower the drive")
        x, v = out_y[:, :ndof], out_y[:, ndof:]
        clean = {"displacement": x, "velocity": v, "acceleration": acc}[self.response_kind]
        response = clean.copy()
        if np.any(self.noise_std):
            response += self._rng.standard_normal((n, ndof)) * self.noise_std
        return PlantOutput(x, v, acc, response, out_g)

    def describe_stats(self) -> dict[str, float]:
        """Substeps, mean corrector iterations, located events, unconverged substeps."""
        s = self.stats
        return {"substeps": int(s[0]), "iterations_per_substep": float(s[1] / max(s[0], 1)),
                "events": int(s[2]), "unconverged": int(s[3])}


def simulate(model: Model, force: np.ndarray, fs: float, force_dofs: Sequence[int], *,
             response_kind: str = "displacement", noise_std: float | np.ndarray = 0.0,
             seed: int | None = None, oversample: int | None = None) -> np.ndarray:
    """Response of a plant at rest to one drive record (see `Plant` for the parameters)."""
    plant = Plant(model, fs, force_dofs, oversample=oversample, noise_std=noise_std,
                  response_kind=response_kind, seed=seed)
    return plant.run(force).response


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
