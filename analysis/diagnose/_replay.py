"""Time residuals: the measured force replayed through a model, as short-horizon predictions.

A long time-domain replay of a nonlinear model under random drive can drift far from the
recording even when the model is exact (and a lightly damped linear model with a small
frequency error drifts too), so the replay restarts from the *measured* state every
``horizon`` samples: each window is a prediction of the next few periods of the motion from
the measured displacement and velocity and the measured force. The residual per DOF is the
relative rms of ``x_measured - x_predicted`` over all windows of a level.

Details that keep the prediction honest:

* the force is resampled band-limited (`scipy.signal.resample_poly`) to `UPSAMPLE` times the
  sample rate before the plant's first-order hold sees it, as a DAQ samples a continuous force;
* the plant's hold history (element forces and deformations a few substeps before the
  restart) is rebuilt from a cubic Hermite interpolation of the measured motion, and memory
  elements get their state by running the force law along the measured motion up to the
  restart; a zero history would add a spurious impulse at every restart;
* windows are spread evenly over the record, at most `MAX_SAMPLES` predicted samples per level
  (the plant's cost is what limits the diagnosis time).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.signal import resample, resample_poly

from ..models import KINDS, Model, restoring_force
from ..plant import HOLD_DEGREE, Plant
from ..recordings import KIND_ORDER, periodic_kinematics
from ._prepare import Prepared

UPSAMPLE = 4
MAX_SAMPLES = 8192
"""Predicted samples per level and model (cost cap)."""
HORIZON_PERIODS = 3.0
"""Prediction horizon in periods of the model's lowest natural frequency."""
EXCERPT_WINDOWS = 3
"""Windows kept for the before/after time-residual plots."""


@dataclass
class Replay:
    """Short-horizon replays of one level through one model.

    Attributes
    ----------
    residual : ndarray, shape (n_dof,)
        Relative rms of ``x_measured - x_predicted`` per DOF over all windows.
    t : ndarray, shape (n_excerpt,)
        Times (s) of the first `EXCERPT_WINDOWS` windows, NaN between windows.
    measured, predicted : ndarray, shape (n_excerpt, n_dof)
        Measured and predicted displacement on ``t`` (NaN between windows).
    """

    residual: np.ndarray
    t: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    kind: str = "displacement"
    """Response kind compared (steady-state replays: the recorded one)."""


def horizon_samples(model: Model, fs: float) -> int:
    """Prediction horizon: `HORIZON_PERIODS` periods of the lowest natural frequency."""
    fn = model.natural_frequencies()
    f1 = fn[fn > 0].min() if np.any(fn > 0) else fs / 64
    return int(max(16, round(HORIZON_PERIODS * fs / f1)))


def _window_starts(n: int, horizon: int, max_samples: int) -> np.ndarray:
    margin = max(int(0.02 * n), 8 * UPSAMPLE)
    room = n - 2 * margin - horizon - 1
    if room <= 0:
        return np.zeros(0, dtype=int)
    n_win = max(1, min(max_samples // horizon, room // horizon))
    return np.linspace(margin, margin + room, n_win).astype(int)


def state_map(model: Model, weight: np.ndarray) -> np.ndarray:
    """Map, shape (n_q, n_dof), from motion at the points to internal coordinates.

    The identity for a model over its points. For a modal model (``x = T q``), the ``q``
    of least ``q^T W q`` that reproduces the measured motion (least squares when there are
    more points than coordinates): ``W = K`` (least strain energy) for displacements,
    ``W = M`` (least kinetic energy) for velocities; ``M`` where ``K`` is singular. The
    modes the points do not observe are set to the smoothest motion consistent with them.

    Parameters
    ----------
    model : Model
    weight : ndarray, shape (n_q, n_q)
        ``W`` (symmetric; positive definite, else the mass is used).
    """
    if not model.is_modal:
        return np.eye(model.n_q)
    ev, vec = np.linalg.eigh(weight)
    if ev.min() <= 1e-12 * ev.max():
        ev, vec = np.linalg.eigh(model.mass)
    half = (vec / np.sqrt(ev)) @ vec.T            # W^-1/2
    return half @ np.linalg.pinv(model.shapes @ half)


class _Restarter:
    """Sets a plant to the measured state at a sample (state, hold history, memory; a
    modal model's coordinates from the measured points by `state_map`)."""

    def __init__(self, model: Model, plant: Plant, p: Prepared) -> None:
        self.model, self.plant, self.p = model, plant, p
        self.qx, self.qv = state_map(model, model.stiffness), state_map(model, model.mass)
        self.h = 1.0 / (plant.fs * plant.oversample)
        self.offsets = -(HOLD_DEGREE - 1 - np.arange(HOLD_DEGREE)) * self.h
        self.memory = [i for i, el in enumerate(model.elements) if KINDS[el.kind].memory]
        self.template = plant.state
        self.last = 0
        self.states = {i: None for i in self.memory}

    def _advance_memory(self, k: int) -> None:
        """Element memory along the measured motion up to sample ``k - 1``."""
        for i in self.memory:
            el = self.model.elements[i]
            seg = slice(self.last, k)
            self.states[i] = restoring_force(el.kind, el.params, self.p.x[seg] @ el.w,
                                             self.p.v[seg] @ el.w, self.states[i])[1]
        self.last = max(self.last, k)

    def set(self, k: int, force_prev: np.ndarray) -> None:
        p, ne = self.p, len(self.model.elements)
        self._advance_memory(k)
        t = np.array([-1.0, 0.0]) / p.fs
        spline = CubicHermiteSpline(t, p.x[k - 1:k + 1], p.v[k - 1:k + 1], axis=0)
        xh, vh = spline(self.offsets), spline.derivative()(self.offsets)
        gh, uh = np.zeros((ne, HOLD_DEGREE)), np.zeros((ne, HOLD_DEGREE))
        es = np.zeros_like(self.template["element_state"])
        for i, el in enumerate(self.model.elements):
            uh[i] = xh @ el.w
            g, s = restoring_force(el.kind, el.params, uh[i], vh @ el.w,
                                   self.states.get(i))
            gh[i] = g
            if i in self.memory:
                es[i] = s
                restart = KINDS[el.kind].plant_restart
                if restart is not None:   # the plant's own state slots (slip direction)
                    restart(es[i], el.params, g[-1], vh[-1] @ el.w)
        self.plant.set_state(dict(self.template, x=self.qx @ p.x[k], v=self.qv @ p.v[k],
                                  element_state=es,
                                  force_history=gh, deformation_history=uh,
                                  force_prev=force_prev))


SETTLE = 1e-3
"""Decay of the slowest mode before a steady-state replay is compared (periodic drives)."""


def steady_replay(model: Model, p: Prepared, highpass: float, lowpass: float) -> Replay:
    """Steady-state replay of a periodic (multisine) recording through ``model``.

    The measured force period, repeated until the slowest mode has decayed to `SETTLE` and
    then for every recorded period, drives the model; its steady displacement is compared
    with the measured one over all recorded periods (both band-limited to
    ``highpass``..``lowpass``, as the measured one was formed). A periodic drive has one
    steady state, so this is a prediction of the whole record with no restart: it works for
    any model, including modal ones with more modes than measured points and memory
    elements. The comparison is in the recorded response kind (an accelerometer's doubly
    integrated noise would otherwise dominate a displacement residual).
    """
    period, n_dof = int(p.period), p.x.shape[1]
    n_per = p.x.shape[0] // period
    nq = model.n_q
    minv = np.linalg.inv(model.mass)
    lam = np.linalg.eigvals(np.block([[np.zeros((nq, nq)), np.eye(nq)],
                                      [-minv @ model.stiffness, -minv @ model.damping]]))
    decay = max(float(np.abs(lam.real).min()), 2 * np.pi * p.fs / period * 1e-3)
    settle = int(np.ceil(-np.log(SETTLE) / decay * p.fs / period))
    # Band-limited resampling of one exact period (FFT) for the plant's linear hold.
    one = resample(p.force[:period], period * UPSAMPLE, axis=0)
    force = np.tile(one, (settle + n_per, 1))
    plant = Plant(model, p.fs * UPSAMPLE, p.force_dofs)
    out = plant.run(force).displacement[settle * period * UPSAMPLE::UPSAMPLE]
    pred = periodic_kinematics(out.reshape(n_per, period, n_dof), p.fs, "displacement",
                               highpass=highpass, lowpass=lowpass)[0].reshape(-1, n_dof)
    k = KIND_ORDER[p.response_kind]
    meas, pred = (_differentiated(a, p.fs, period, k) for a in (p.x[:n_per * period], pred))
    res = np.sqrt(np.sum((meas - pred) ** 2, axis=0) / np.maximum(np.sum(meas**2, axis=0),
                                                                    1e-300))
    show = slice(0, min(2 * period, meas.shape[0]))
    return Replay(res, np.arange(show.stop) / p.fs, meas[show], pred[show], p.response_kind)


def _differentiated(x: np.ndarray, fs: float, period: int, order: int) -> np.ndarray:
    """``order`` time derivatives of whole periods of ``x`` on their exact DFT lines."""
    if order == 0:
        return x
    per = x.reshape(-1, period, x.shape[1])
    gain = (2j * np.pi * np.fft.rfftfreq(period, 1 / fs)) ** order
    if period % 2 == 0 and order % 2:
        gain[-1] = 0.0
    return np.fft.irfft(np.fft.rfft(per, axis=1) * gain[:, None], period, axis=1).reshape(x.shape)


def replay(model: Model, p: Prepared, horizon: int, *,
           max_samples: int = MAX_SAMPLES) -> Replay:
    """Short-horizon replays of the recording ``p`` through ``model``.

    Parameters
    ----------
    model : Model
        Complete model.
    p : Prepared
        The recording (measured displacement, velocity and force).
    horizon : int
        Samples predicted from each restart.
    max_samples : int
        Cap on the predicted samples (windows are spread evenly over the record).
    """
    n, n_dof = p.x.shape
    starts = _window_starts(n, horizon, max_samples)
    plant = Plant(model, p.fs * UPSAMPLE, p.force_dofs)
    force = resample_poly(p.force, UPSAMPLE, 1, axis=0)
    restart = _Restarter(model, plant, p)
    num, den = np.zeros(n_dof), np.zeros(n_dof)
    t_ex, m_ex, p_ex = [], [], []
    gap = np.full((1, n_dof), np.nan)
    for w, k in enumerate(starts):
        restart.set(int(k), force[k * UPSAMPLE])
        out = plant.run(force[k * UPSAMPLE + 1:(k + horizon) * UPSAMPLE + 1])
        pred = out.displacement[UPSAMPLE - 1::UPSAMPLE]
        meas = p.x[k + 1:k + horizon + 1]
        num += np.sum((meas - pred) ** 2, axis=0)
        den += np.sum(meas**2, axis=0)
        if w < EXCERPT_WINDOWS:
            t_ex += [np.arange(k + 1, k + horizon + 1) / p.fs, [np.nan]]
            m_ex += [meas, gap]
            p_ex += [pred, gap]
    if not t_ex:
        empty = np.zeros((0, n_dof))
        return Replay(np.full(n_dof, np.nan), np.zeros(0), empty, empty)
    return Replay(np.sqrt(num / np.maximum(den, 1e-300)), np.concatenate(t_ex)[:-1],
                  np.concatenate(m_ex)[:-1], np.concatenate(p_ex)[:-1])


def periodic_replay(freqs: np.ndarray, harmonics: np.ndarray, X_meas: np.ndarray,
                    X_model: np.ndarray, *, n_time: int = 128) -> Replay:
    """Time residual of stepped-sine steps from their harmonics (steady-state replay).

    The model's steady-state response to each step's measured sine force (a harmonic-balance
    solution) is compared with the measured periodic response; by Parseval the relative rms
    of the periodic time residual is ``sqrt(sum |X_meas - X_model|^2 / sum |X_meas|^2)``
    over steps and harmonics. The excerpt shows two periods of the step with the largest
    response.

    Parameters
    ----------
    freqs : ndarray, shape (n_steps,)
    harmonics : ndarray of int, shape (n_h,)
    X_meas, X_model : ndarray, complex, shape (n_steps, n_h, n_dof)
        Displacement harmonics ``x(t) = Re(sum_k X_k e^{j h_k omega t})``.
    """
    num = np.sum(np.abs(X_meas - X_model) ** 2, axis=(0, 1))
    den = np.sum(np.abs(X_meas) ** 2, axis=(0, 1))
    s = int(np.argmax(np.sum(np.abs(X_meas) ** 2, axis=(1, 2))))
    t = np.arange(2 * n_time) / (n_time * freqs[s])
    e = np.exp(2j * np.pi * freqs[s] * np.outer(t, harmonics))
    return Replay(np.sqrt(num / np.maximum(den, 1e-300)), t, (e @ X_meas[s]).real,
                  (e @ X_model[s]).real)
