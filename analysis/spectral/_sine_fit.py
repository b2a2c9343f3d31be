"""Stepped-sine FRFs and harmonic content from time blocks by least-squares sine fitting.

Each step's block is fitted with ``c + sum_k (a_k cos(h_k ω t) + b_k sin(h_k ω t))`` at the known
drive frequency. Unlike an FFT, this needs no whole number of cycles in the block and leaks
nothing between harmonics; white measurement noise only enters through its projection on the
fitted sines, so the amplitude error falls as ``noise_rms * sqrt(2 / n)``.

Coefficients follow the harmonic-balance convention ``x(t) = Re(sum_k X_k e^{j h_k ω t})`` with
the phase referenced to the force fundamental, so ``X_1 / F_1`` is the FRF and the higher
``X_k`` compare directly with `analysis.hbm._hbm` results for a real force amplitude.

A step recorded from the change of drive holds the free decay of the previous step's motion
(the transient, at the structure's natural frequencies, next to the drive's when the step is
near a mode); `steady_start` finds where it has died out and only the steady part is fitted.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import RecordingError
from ..recordings import KIND_ORDER, Excitation, Recording, ResponseKind, StepTable


def sine_fit(block: np.ndarray, fs: float, freq: float,
             harmonics: Sequence[int] = (1,)) -> np.ndarray:
    """Complex amplitudes of the given harmonics of ``freq`` in a block.

    Parameters
    ----------
    block : ndarray, shape (n,) or (n, channels)
        Steady-state samples.
    fs, freq : float
        Sample rate and drive frequency, Hz.
    harmonics : sequence of int
        Harmonic orders (>= 1) to fit; a constant offset is always fitted too.

    Returns
    -------
    ndarray, complex, shape (n_h,) or (n_h, channels)
        ``X_k`` with the block's first sample at ``t = 0``.
    """
    x = np.asarray(block, dtype=float)
    h = np.asarray(harmonics, dtype=int)
    if h.size == 0 or h.min() < 1:
        raise RecordingError("sine-fit harmonics must be orders >= 1, e.g. 1,3,5,7")
    if not 0 < freq * h.max() < fs / 2:
        raise RecordingError(f"harmonic {h.max()} of {freq} Hz is above Nyquist ({fs / 2} Hz); "
                             "drop the high harmonics or sample faster")
    n = x.shape[0]
    if n < 2 * h.size + 1:
        raise RecordingError(f"block of {n} samples is too short to fit {h.size} harmonics")
    out = _fit(x.reshape(n, -1), fs, freq, h)[0]
    return out if x.ndim > 1 else out[:, 0]


def _fit(x: np.ndarray, fs: float, freq: float, h: np.ndarray
         ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares harmonics ``X_k`` (n_h, channels) of ``x`` (n, channels) and the
    residual's mean square per channel."""
    n = x.shape[0]
    phase = 2 * np.pi * freq * np.arange(n)[:, None] / fs * h[None, :]
    design = np.hstack([np.ones((n, 1)), np.cos(phase), np.sin(phase)])
    coef, *_ = np.linalg.lstsq(design, x, rcond=None)
    return coef[1:1 + h.size] - 1j * coef[1 + h.size:], np.mean((x - design @ coef) ** 2, axis=0)


SETTLE_WINDOWS = 16
"""Windows a step is cut into to find where its response has settled (`steady_start`)."""
SETTLE_TOL = 1e-3
"""Relative distance of a window's FRF to the step's steady one under which the window is
settled (raised to `SETTLE_NOISE` times the windows' noise when that is larger). On the
noise-free stepped twin of docs/daq-artifacts.md the hbm cubic is then -0.08 % off (+9 % from
whole steps), inside the +0.14 % the default harmonic orders leave."""
SETTLE_NOISE = 4.0
"""A window further from the steady FRF than this many times a window's standard error (from
the fit residual of the step's last quarter) is still transient."""


def steady_start(force: np.ndarray, response: np.ndarray, fs: float, freq: float,
                 harmonics: Sequence[int] = (1,)) -> int:
    """First sample of the steady part of one stepped-sine step.

    The step is cut into `SETTLE_WINDOWS` windows and each window's fundamental FRF (each
    response channel over the force; ``harmonics`` fitted with it, so that they do not leak
    into it) compared with the FRF of the step's last quarter; a channel's noise is its
    window's standard error from the residual of that quarter's fit. The step is steady from
    the first window after which every window of every channel is within
    ``max(SETTLE_TOL, SETTLE_NOISE * noise)`` of it, relative (a noisy channel does not loosen
    a clean one's test; a window further off, the transient's free decay, is dropped with all
    before it). The last quarter is always kept.

    Parameters
    ----------
    force : ndarray, shape (n,)
        The step's force channel.
    response : ndarray, shape (n, channels)
    fs, freq : float
        Sample rate and drive frequency, Hz.
    harmonics : sequence of int
        Orders fitted in each window (the fundamental is always one).

    Returns
    -------
    int
        0 when the step is steady from its start or too short to tell (windows of fewer than
        two cycles or than the fit's coefficients); the last quarter's first sample when the
        step has not settled by then.
    """
    n = len(force)
    w = n // SETTLE_WINDOWS
    h = np.asarray(sorted(set(int(k) for k in harmonics) | {1}))
    h = h[h * freq < fs / 2]
    if w < max(2 * fs / freq, 4 * h.size + 2):
        return 0
    resp = np.asarray(response, dtype=float).reshape(n, -1)
    last = SETTLE_WINDOWS - SETTLE_WINDOWS // 4

    def frf(lo: int, hi: int) -> np.ndarray:
        return sine_fit(resp[lo:hi], fs, freq, h)[0] / sine_fit(force[lo:hi], fs, freq)[0]

    ref = frf(last * w, n)
    d = np.abs(np.stack([frf(i * w, i * w + w) for i in range(last)]) - ref)
    d /= np.maximum(np.abs(ref), 1e-300)
    tol = np.maximum(SETTLE_TOL, SETTLE_NOISE * _window_noise(force[last * w:], resp[last * w:],
                                                              fs, freq, h, w))
    off = np.flatnonzero((d > tol).any(axis=1))
    return int(off[-1] + 1) * w if off.size else 0


def _window_noise(force: np.ndarray, resp: np.ndarray, fs: float, freq: float,
                  h: np.ndarray, w: int) -> np.ndarray:
    """Relative standard error of a ``w``-sample window's FRF per response channel from the
    fit residuals of a steady block (least squares: each of Re, Im of an amplitude has
    ``sigma sqrt(2 / w)``)."""
    amp_f, var_f = _fit(force[:, None], fs, freq, h[:1])
    amp_x, var_x = _fit(resp, fs, freq, h)
    rel = var_f[0] / max(abs(amp_f[0, 0]) ** 2, 1e-300) + var_x / np.maximum(
        np.abs(amp_x[0]) ** 2, 1e-300)
    return np.sqrt(4 * rel / w)


def hold_gain(freq: np.ndarray | float, fs: float, hold: str | None) -> np.ndarray:
    """Gain from the recorded force samples to the force that acted, at ``freq``.

    A force applied as the first-order hold of its samples (``hold="linear"``, the simulated
    plant's drive) acts in band with ``sinc^2(f / fs)`` of the sampled amplitude; a force
    measured by a transducer behind an anti-alias filter (``None`` or ``"none"``) acts as
    recorded.
    """
    f = np.asarray(freq, dtype=float)
    if hold in (None, "none"):
        return np.ones_like(f)
    if hold == "linear":
        return np.sinc(f / fs) ** 2
    raise RecordingError(f"force_hold '{hold}' must be none or linear")


@dataclass
class SteppedSineFRF:
    """FRF and harmonic content of one stepped-sine level.

    Attributes
    ----------
    freqs : ndarray, shape (n_steps,)
    harmonics : ndarray of int, shape (n_h,)
    force : ndarray, shape (n_steps,)
        Force fundamental amplitude of the driving input at each step, N.
    X : ndarray, complex, shape (n_steps, n_h, n_dof)
        Displacement harmonics, phase referenced to the force fundamental.
    level : float
        Nominal level (mean force amplitude unless the recording names one).
    steady_from : ndarray of int, shape (n_steps,)
        First sample of each step's steady part, the one fitted (`steady_start`).
    unsettled : tuple of float
        Frequencies (Hz) of the steps still transient at their last quarter (that quarter
        is fitted; longer steps would settle).
    """

    freqs: np.ndarray
    harmonics: np.ndarray
    force: np.ndarray
    X: np.ndarray
    level: float
    force_dof: int = 0
    steady_from: np.ndarray | None = None
    unsettled: tuple[float, ...] = ()

    @property
    def frf(self) -> np.ndarray:
        """Receptance ``X_1 / F`` at every DOF, shape (n_steps, n_dof)."""
        i1 = int(np.flatnonzero(self.harmonics == 1)[0])
        return self.X[:, i1] / self.force[:, None]


def stepped_sine_frf(recording: Recording | StepTable, harmonics: Sequence[int] = (1, 3, 5, 7),
                     input_index: int = 0) -> SteppedSineFRF:
    """Sine-fit every step of a stepped-sine recording (a table: its phasors).

    Each step is fitted from where it has settled (`steady_start`). Velocity and
    acceleration responses are converted to displacement harmonics (division by ``j h ω`` or
    ``-(h ω)^2``); the force amplitude is the one that acted (`hold_gain` of the recording's
    ``force_hold``). A table gives the fundamental and the orders of ``harmonics`` it holds
    (`table_harmonics`).
    """
    if isinstance(recording, StepTable):
        return table_harmonics(recording, harmonics, input_index)
    if recording.excitation != Excitation.STEPPED_SINE:
        raise RecordingError("harmonic balance needs stepped-sine recordings, got "
                             f"{recording.excitation}; record a stepped-sine level")
    if not 0 <= input_index < recording.n_in:
        raise RecordingError(f"input {input_index} does not exist; the recording has "
                             f"{recording.n_in} force channel(s)")
    h = np.asarray(sorted(set(int(k) for k in harmonics) | {1}), dtype=int)
    if h.min() < 1:
        raise RecordingError("sine-fit harmonics must be orders >= 1")
    n_steps = recording.freqs.size
    gain = hold_gain(recording.freqs, recording.fs, recording.force_hold)
    X = np.empty((n_steps, h.size, recording.n_dof), dtype=complex)
    force = np.empty(n_steps)
    start = np.zeros(n_steps, dtype=int)
    for s, f in enumerate(recording.freqs):
        fc = sine_fit(recording.force[s, :, input_index], recording.fs, f, (1,))[0]
        if abs(fc) == 0:
            raise RecordingError(f"step {s} ({f:g} Hz) has no force at the drive frequency")
        start[s] = steady_start(recording.force[s, :, input_index], recording.response[s],
                                recording.fs, f, h)
        fc = sine_fit(recording.force[s, start[s]:, input_index], recording.fs, f, (1,))[0]
        xc = sine_fit(recording.response[s, start[s]:], recording.fs, f, h)
        ref = np.exp(-1j * h * np.angle(fc))          # force fundamental phase -> 0
        xc = xc * ref[:, None]
        w = 2 * np.pi * f * h
        if recording.response_kind == ResponseKind.VELOCITY:
            xc = xc / (1j * w)[:, None]
        elif recording.response_kind == ResponseKind.ACCELERATION:
            xc = xc / (-(w ** 2))[:, None]
        X[s] = xc
        force[s] = abs(fc) * gain[s]
    level = float(recording.level) if recording.level else float(force.mean())
    last = (SETTLE_WINDOWS - SETTLE_WINDOWS // 4) * (recording.force.shape[1] // SETTLE_WINDOWS)
    return SteppedSineFRF(recording.freqs.copy(), h, force, X, level,
                          int(recording.force_dofs[input_index]), start,
                          tuple(float(f) for f, s in zip(recording.freqs, start) if s >= last > 0))


def table_harmonics(table: StepTable, harmonics: Sequence[int] = (1, 3, 5, 7),
                    input_index: int = 0) -> SteppedSineFRF:
    """`SteppedSineFRF` of a stepped-sine table: the fundamental, and the requested orders
    the table holds (``table.harmonics``), as displacement referenced to the force
    fundamental's phase.

    Parameters
    ----------
    table : StepTable
    harmonics : sequence of int
        Orders wanted; those the table does not hold are left out (never zero-filled).
    input_index : int
        Force channel whose fundamental is the reference.

    Returns
    -------
    SteppedSineFRF
    """
    if not 0 <= input_index < table.n_in:
        raise RecordingError(f"input {input_index} does not exist; the table has "
                             f"{table.n_in} force channel(s)")
    held = [int(k) for k in harmonics if int(k) in table.harmonics and int(k) != 1]
    h = np.asarray([1] + sorted(set(held)), dtype=int)
    X = np.empty((table.n_steps, h.size, table.n_dof), dtype=complex)
    X[:, 0] = table.response_phasor
    for i, k in enumerate(h[1:], 1):
        X[:, i] = table.response_harmonics[:, table.harmonics.index(int(k))]
    fc = table.force_phasor[:, input_index]
    X = X * np.exp(-1j * h[None, :] * np.angle(fc)[:, None])[:, :, None]
    order = KIND_ORDER[table.response_kind]
    X = X / ((1j * 2 * np.pi * table.freqs[:, None] * h[None, :]) ** order)[:, :, None]
    level = table.level if table.control == "force" else float(np.abs(fc).mean())
    return SteppedSineFRF(table.freqs.copy(), h, np.abs(fc), X, level,
                          int(table.force_dofs[input_index]))


def recording_table(rec: Recording) -> StepTable:
    """The fundamental phasors of a stepped-sine recording's time blocks as a `StepTable`
    holding what the recording held (`Recording.control`; each step sine-fitted, the force
    as it acted: `hold_gain`).

    Parameters
    ----------
    rec : Recording
        A stepped-sine level.

    Returns
    -------
    StepTable
    """
    if rec.excitation != Excitation.STEPPED_SINE:
        raise RecordingError(f"a stepped-sine table comes from stepped-sine data, not "
                             f"{rec.excitation}")
    gain = hold_gain(rec.freqs, rec.fs, rec.force_hold)
    force = np.stack([sine_fit(rec.force[i], rec.fs, f)[0] for i, f in enumerate(rec.freqs)])
    resp = np.stack([sine_fit(rec.response[i], rec.fs, f)[0] for i, f in enumerate(rec.freqs)])
    held = force[:, 0] if rec.control == "force" else resp[:, rec.control_dof or 0]
    level = rec.level if rec.level else float(np.abs(held).mean())
    return StepTable(rec.freqs, force * gain[:, None], resp, rec.force_dofs, rec.control,
                     level, response_kind=rec.response_kind, control_dof=rec.control_dof,
                     sensors=rec.sensors, meta=dict(rec.meta))
