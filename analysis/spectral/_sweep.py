"""Swept-sine tests: the sweep law, FRFs by sine-fit tracking, the sweep-rate check.

A sweep is read as a sequence of quasi-steady sine blocks: around each analysis frequency a
window of a few cycles is fitted with ``c + sum_k a_k cos(k θ(t)) + b_k sin(k θ(t))`` on the
sweep's own phase ``θ(t)`` (so the frequency change inside the window leaks nothing), for the
force and every response channel. Fractional orders (1.5, 2.5) are fitted alongside: no
harmonic of a periodic response lies there, so they measure the noise in each window. The
result is a `SteppedSineFRF` (plus the noise), so everything that reads stepped sines — the
harmonic-balance fit, plots — reads sweeps too.

The phase is the law's (``sweep_start_hz``, ``sweep_stop_hz``, ``sweep_law``, ``sweep_rate``)
corrected by a smooth fit to the measured force's analytic-signal phase, so an acquisition that
starts a little before or after the generator, or a generator whose rate is slightly off, is
tracked correctly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.linalg import eig
from scipy.signal import hilbert
from scipy.stats import f as f_dist

from ..errors import RecordingError
from ._sine_fit import SteppedSineFRF, hold_gain
from ..recordings import (SWEEP_LAWS, Excitation, Sweep, SweepLaw,  # noqa: F401  (re-exported)
                          active_span)

NOISE_ORDERS = (1.5, 2.5)
#: orders are fitted up to this fraction of fs (near Nyquist a sine fit is ill-conditioned
#: and the anti-alias filter has cut the signal)
FIT_LIMIT = 0.45
#: ISO 7626-2's linear sweep-rate limit, ``S < 54 f_r^2 ζ^2`` Hz/min, in Hz/s per (f ζ)^2
ISO_RATE = 54.0 / 60.0
#: displacement from each response kind's harmonic at angular frequency w
CONVERSIONS = {"displacement": lambda w: np.ones_like(w), "velocity": lambda w: 1 / (1j * w),
               "acceleration": lambda w: -1 / w ** 2}


def sweep_signal(law: SweepLaw, fs: float, amplitude: float) -> np.ndarray:
    """Drive samples ``amplitude * sin θ(t)`` over the whole sweep."""
    n = int(round(law.duration * fs))
    if not max(law.start_hz, law.stop_hz) < fs / 2:
        raise RecordingError(f"sweep up to {max(law.start_hz, law.stop_hz):g} Hz needs fs above "
                             f"{2 * max(law.start_hz, law.stop_hz):g} Hz")
    return amplitude * np.sin(law.phase(np.arange(n) / fs))


def tracked_phase(force: np.ndarray, fs: float, law: SweepLaw) -> tuple[np.ndarray, np.ndarray]:
    """Phase and instantaneous frequency of the force fundamental at every sample.

    The law's, corrected by a quadratic in time fitted to the force's analytic-signal phase: a
    record started before or after the generator, or a rate slightly off, is tracked.
    """
    t = np.arange(force.size) / fs
    theta = law.phase(t)
    measured = np.unwrap(np.angle(hilbert(force - force.mean())))
    offset = np.unwrap(measured - theta)
    inner = slice(force.size // 20, force.size - force.size // 20)   # Hilbert edge effects
    coef = np.polyfit(t[inner], offset[inner], 2)
    freq = law.frequency(t) + np.polyval(np.polyder(coef), t) / (2 * np.pi)
    return theta + np.polyval(coef, t), freq


@dataclass
class SweepFRF(SteppedSineFRF):
    """FRF and harmonic content of one sweep, read as quasi-steady blocks.

    Attributes (besides those of `SteppedSineFRF`)
    ----------------------------------------------
    noise : ndarray, shape (n_f, n_dof)
        Displacement amplitude of the noise in each window (rms of the fractional orders).
    direction : int
        +1 up-sweep, -1 down-sweep.
    force_harmonics : ndarray, complex, shape (n_f, n_h)
        Force harmonics (as recorded), phase referenced to the fundamental.
    times, window_s : ndarray, shape (n_f,)
        Centre and length of each analysis window, s from the start of the sweep.
    """

    noise: np.ndarray | None = None
    direction: int = 1
    force_harmonics: np.ndarray | None = None
    times: np.ndarray | None = None
    window_s: np.ndarray | None = None


def sweep_frf(force: np.ndarray, response: np.ndarray, fs: float, law: SweepLaw, *,
              harmonics: Sequence[int] = (1, 2, 3, 5), cycles: float = 8.0, points: int = 200,
              response_kind: str = "displacement", force_hold: str | None = None,
              force_dof: int = 0, level: float | None = None) -> SweepFRF:
    """FRF of a swept-sine record by sine-fit tracking.

    Parameters
    ----------
    force : ndarray, shape (n,)
        Driving force, N.
    response : ndarray, shape (n,) or (n, channels)
        Response channels (``X`` has a channel axis either way).
    fs : float
        Sample rate, Hz.
    law : SweepLaw
        The sweep as generated, nominally starting at the record's first sample (an offset
        or a small rate error is read off the force, see `tracked_phase`).
    harmonics : sequence of int
        Orders fitted (1 is always included).
    cycles : float
        Window length in cycles of the local frequency: fewer resolve sharper peaks on a fast
        sweep, more average the noise down.
    points : int
        Analysis frequencies, spaced like the law, inside the swept band.
    response_kind : {"displacement", "velocity", "acceleration"}
        Responses are converted to displacement harmonics.
    force_hold : {"none", "linear"}, optional
        How the force samples acted (see `sine_fit.hold_gain`).

    Returns
    -------
    SweepFRF
        Frequencies in sweep order (ascending for an up-sweep).
    """
    force = np.asarray(force, dtype=float).reshape(-1)
    y = np.asarray(response, dtype=float)
    y2 = y.reshape(y.shape[0], -1)
    if y2.shape[0] != force.size:
        raise RecordingError(f"force ({force.size}) and response ({y2.shape[0]}) differ in "
                             "length")
    if response_kind not in CONVERSIONS:
        raise RecordingError(f"response_kind '{response_kind}' is not one of "
                             f"{', '.join(CONVERSIONS)}")
    if cycles < 2 or points < 2:
        raise RecordingError("sweep tracking needs cycles >= 2 and points >= 2")
    h = np.asarray(sorted(set(int(k) for k in harmonics) | {1}), dtype=int)
    orders = np.concatenate([h, NOISE_ORDERS]).astype(float)
    theta, inst = tracked_phase(force, fs, law)
    grid, centres = _analysis_grid(inst, fs, law, cycles, points)
    nh = h.size
    X = np.empty((points, nh, y2.shape[1]), dtype=complex)
    F = np.empty(points)
    Fh = np.empty((points, nh), dtype=complex)
    noise = np.empty((points, y2.shape[1]))
    for i, f in enumerate(grid):
        tc = centres[i]
        a = max(0, int(round((tc - 0.5 * cycles / f) * fs)))
        b = min(force.size, int(round((tc + 0.5 * cycles / f) * fs)) + 1)
        c = _window_orders(theta[a:b], np.column_stack([force[a:b], y2[a:b]]), orders, f, fs)
        f1 = c[0, 0]
        if f1 == 0:
            raise RecordingError(f"no force at {f:.4g} Hz in the sweep; check the force channel")
        ref = np.exp(-1j * h * np.angle(f1))
        resp = c[:, 1:] * CONVERSIONS[response_kind](2 * np.pi * f * orders)[:, None]
        X[i] = resp[:nh] * ref[:, None]
        Fh[i] = c[:nh, 0] * ref
        noise[i] = np.sqrt(np.mean(np.abs(resp[nh:]) ** 2, axis=0))
        F[i] = abs(f1) * float(hold_gain(f, fs, force_hold))
    return SweepFRF(grid, h, F, X, float(level or F.mean()), force_dof,
                    noise=noise, direction=law.direction, force_harmonics=Fh,
                    times=centres, window_s=cycles / grid)


def _analysis_grid(inst: np.ndarray, fs: float, law: SweepLaw, cycles: float, points: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Analysis frequencies of a sweep, in sweep order, and their window centres.

    Parameters
    ----------
    inst : ndarray, shape (n,)
        Tracked instantaneous frequency of the force at every sample, Hz.
    fs : float
        Sample rate, Hz.
    law : SweepLaw
    cycles : float
        Window length in cycles of the local frequency.
    points : int
        Number of analysis frequencies, spaced like the law.

    Returns
    -------
    grid, centres : ndarray, shape (points,)
        Frequencies (Hz) whose whole window lies in the record with every order below
        `FIT_LIMIT`, and the time (s) the sweep passes each.
    """
    t = np.arange(inst.size) / fs
    if np.any(np.diff(inst) * law.direction <= 0):
        raise RecordingError("the force does not sweep monotonically as the sweep law says; "
                             "check sweep_start_hz, sweep_stop_hz, sweep_law and sweep_rate")
    ordered = slice(None, None, law.direction)

    def time_at(f: np.ndarray) -> np.ndarray:
        return np.interp(f, inst[ordered], t[ordered])

    spacing = np.geomspace if law.law == "log" else np.linspace
    dense = spacing(inst.min(), inst.max(), 50 * points)
    tc = time_at(dense)
    ok = (tc - 0.5 * cycles / dense >= 0) & (tc + 0.5 * cycles / dense <= t[-1]) \
        & (dense * max(NOISE_ORDERS) < FIT_LIMIT * fs)
    if ok.sum() < 2:
        raise RecordingError(f"the sweep is too short for windows of {cycles:g} cycles (or "
                             "too close to Nyquist); use fewer cycles or a longer sweep")
    grid = spacing(dense[ok].min(), dense[ok].max(), points)
    grid = grid[::law.direction]
    return grid, time_at(grid)


def _window_orders(theta: np.ndarray, signals: np.ndarray, orders: np.ndarray, f: float,
                   fs: float) -> np.ndarray:
    """Complex amplitudes of each order of the sweep phase in one window (least squares).

    Parameters
    ----------
    theta : ndarray, shape (m,)
        Sweep phase over the window, rad.
    signals : ndarray, shape (m, n_signals)
        The window of each signal (force first).
    orders : ndarray, shape (n_orders,)
        Orders of ``theta`` fitted beside a constant.
    f : float
        The window's frequency, Hz.
    fs : float
        Sample rate, Hz: orders at or above `FIT_LIMIT` ``* fs`` are left out (NaN), near
        Nyquist a fit is ill-conditioned.

    Returns
    -------
    ndarray, complex, shape (n_orders, n_signals)
        ``a - i b`` of ``a cos(k θ) + b sin(k θ)`` per order and signal.
    """
    use = orders * f < FIT_LIMIT * fs
    ph = theta[:, None] * orders[None, use]
    design = np.hstack([np.ones((theta.size, 1)), np.cos(ph), np.sin(ph)])
    coef, *_ = np.linalg.lstsq(design, signals, rcond=None)
    c = np.full((orders.size, coef.shape[1]), np.nan, dtype=complex)
    c[use] = coef[1:1 + use.sum()] - 1j * coef[1 + use.sum():]
    return c


def max_sweep_rate(fn: float, zeta: float, law: str = "linear") -> float:
    """Largest sweep rate that passes a mode at ``fn`` Hz, damping ratio ``zeta``, quasi-steady.

    ISO 7626-2: a linear sweep slower than ``54 (fn ζ)^2`` Hz/min keeps the peak amplitude error
    near 1 %. Returned in the law's unit: Hz/s (linear) or octaves/min (log, the same Hz/s
    at ``fn``).
    """
    linear = ISO_RATE * (fn * zeta) ** 2
    return linear if law == "linear" else linear / (fn * np.log(2.0)) * 60.0


def sweep_rate_check(law: SweepLaw, modes: Sequence[tuple[float, float]]) -> list[str]:
    """Warnings for the modes (``(fn, zeta)``) the sweep passes too fast to read as steady."""
    out = []
    lo, hi = sorted((law.start_hz, law.stop_hz))
    unit = "Hz/s" if law.law == "linear" else "oct/min"
    for fn, zeta in modes:
        if lo <= fn <= hi and law.rate > (limit := max_sweep_rate(fn, zeta, law.law)):
            out.append(f"the sweep passes the {fn:.4g} Hz mode (damping {100 * zeta:.2g} %) at "
                       f"{law.rate:.3g} {unit}, above the quasi-steady limit {limit:.3g} {unit} "
                       "(ISO 7626-2): its peak reads low and shifted in the sweep direction; "
                       "sweep slower or analyse a stepped sine")
    return out


def harmonic_distortion(frf: SweepFRF, alpha: float = 1e-3, smooth: int = 5) -> dict:
    """Is a single sweep nonlinear? Response harmonics beyond what the force's own harmonics
    and the noise explain.

    Every order ``k >= 2`` of every response channel is tested in windows that do not overlap
    (independent noise): the part of ``X_k`` not explained by the force harmonic through the
    sweep's own FRF at ``k f`` (where ``k f`` was swept; elsewhere the window is tested only
    when the force harmonic is itself below the noise) is compared with the noise amplitude
    (fractional orders, pooled over ``2 smooth + 1`` neighbouring windows): an F test at
    level ``alpha``. A linear structure flags about ``alpha`` of the tests; the verdict is
    nonlinear when the share flagged exceeds the binomial chance limit (5 standard deviations).

    Returns
    -------
    dict
        ``method`` "sweep-harmonics", ``share_flagged``, ``share_limit``, ``nonlinear``,
        ``band_hz`` (range of the flagged windows) and ``tests`` (number of tests).
    """
    keep = independent_windows(frf.times, frf.window_s)
    freqs, X, noise = frf.freqs[keep], frf.X[keep], frf.noise[keep]
    Fh = frf.force_harmonics[keep]
    order = np.argsort(frf.freqs)
    i1 = int(np.flatnonzero(frf.harmonics == 1)[0])
    H1 = frf.X[order, i1] / frf.force[order, None]             # (n_f, channels)
    # noise power: fractional orders (2 complex values a window) pooled over neighbours
    pooled = [slice(max(0, i - smooth), i + smooth + 1) for i in range(len(freqs))]
    level = np.sqrt(np.array([np.mean(noise[sl] ** 2, axis=0) for sl in pooled]))
    dof = np.array([4 * (sl.stop - sl.start) for sl in pooled])
    dof = np.minimum(dof, 4 * len(freqs))
    threshold = f_dist.isf(alpha, 2, dof)[:, None]     # |R|^2 / level^2 ~ F(2, dof) if linear
    flagged, tests, where = 0, 0, []
    for j, k in enumerate(frf.harmonics):
        if k < 2:
            continue
        fk = k * freqs
        inside = (fk >= freqs.min()) & (fk <= freqs.max())
        Hk = np.stack([np.interp(fk, frf.freqs[order], H1[:, c].real)
                       + 1j * np.interp(fk, frf.freqs[order], H1[:, c].imag)
                       for c in range(H1.shape[1])], axis=1)
        residual = X[:, j] - Hk * Fh[:, j, None] * inside[:, None]
        # where k f was not swept, test only when the force harmonic is itself negligible
        usable = (inside[:, None] | (np.abs(Fh[:, j, None] * H1[:, None, :].mean(0))
                                     < 0.1 * level)) & np.isfinite(residual)
        stat = np.nan_to_num(np.abs(residual) ** 2 / np.maximum(level, 1e-300) ** 2)
        hit = (stat > threshold) & usable
        flagged += int(hit.sum())
        tests += int(usable.sum())
        where += list(freqs[hit.any(axis=1)])
    share = flagged / tests if tests else 0.0
    limit = alpha + 5 * np.sqrt(alpha * (1 - alpha) / max(tests, 1))
    nonlinear = bool(tests and share > limit)
    return {"method": "sweep-harmonics", "share_flagged": share, "share_limit": float(limit),
            "nonlinear": nonlinear, "tests": tests,
            "band_hz": [float(min(where)), float(max(where))] if where and nonlinear else None}


def independent_windows(times: np.ndarray, window_s: np.ndarray) -> np.ndarray:
    """Indices of analysis windows that do not overlap (greedy, in time order)."""
    keep, end = [], -np.inf
    for i in np.argsort(times):
        if times[i] - 0.5 * window_s[i] >= end:
            keep.append(i)
            end = times[i] + 0.5 * window_s[i]
    return np.sort(np.array(keep, dtype=int))


def recording_sweep_frf(rec, *, harmonics: Sequence[int] = (1, 2, 3, 5), **kwargs) -> SweepFRF:
    """`sweep_frf` of a swept-sine `Recording` (first force channel), over the part of the
    record where the force sweeps (`analysis.recordings.active_span`: trailing zeros and
    a quiet lead-in are left out; the tracking reads the law's start off the force).

    Parameters
    ----------
    rec : Recording
        ``excitation == "swept-sine"``.
    harmonics : sequence of int
        Orders fitted.
    **kwargs
        Passed to `sweep_frf` (``cycles``, ``points``).
    """
    if rec.excitation != Excitation.SWEPT_SINE or rec.sweep is None:
        raise RecordingError(f"a sweep FRF needs swept-sine data, got {rec.excitation}")
    a, b = active_span(rec.force[:, 0])
    return sweep_frf(rec.force[a:b, 0], rec.response[a:b], rec.fs, rec.sweep.law,
                     harmonics=harmonics, response_kind=rec.response_kind,
                     force_hold=rec.force_hold, force_dof=int(rec.force_dofs[0]),
                     level=rec.level, **kwargs)


def linear_modes(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray
                 ) -> list[tuple[float, float]]:
    """``(fn Hz, zeta)`` of the underdamped modes of ``M q'' + C q' + K q``, ascending."""
    n = mass.shape[0]
    inv = np.linalg.solve(mass, np.hstack([stiffness, damping]))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-inv[:, :n], -inv[:, n:]]])
    lam = eig(A, right=False)
    lam = lam[lam.imag > 0]
    out = sorted((float(abs(v) / (2 * np.pi)), float(-v.real / abs(v))) for v in lam)
    return [(f, z) for f, z in out if 0 < z < 1]


def quasi_steady(frf: SweepFRF, law: SweepLaw, modes: Sequence[tuple[float, float]],
                 error: float = 0.05, bandwidths: float = 5.0) -> tuple[SweepFRF, list[str]]:
    """The analysis points of a sweep that read as stepped-sine points, and the warnings.

    An engineer's check (ISO 7626-2, `sweep_rate_check`) for every mode ``(fn, zeta)``; where
    the sweep passes a mode faster than its quasi-steady limit, the response lags the sweep
    by about one time constant, i.e. by ``d = r / (2 pi zeta fn)`` Hz at rate ``r`` (Hz/s at
    ``fn``), and the tracked FRF at ``|f - fn| = delta`` is off by about ``d / delta`` (the
    mode's ``d ln|H| / df``). Points closer to the mode than ``max(d / error, bandwidths
    zeta fn)`` are left out.

    Returns
    -------
    SweepFRF
        The kept points (every array cut alike).
    warnings : list of str
        One per mode passed too fast, with the points dropped.
    """
    keep = np.ones(frf.freqs.size, bool)
    warnings = []
    for (fn, zeta), text in zip(*_too_fast(law, modes)):
        rate = law.rate if law.law == "linear" else law.rate / 60 * np.log(2.0) * fn
        radius = max(rate / (2 * np.pi * zeta * fn) / error, bandwidths * zeta * fn)
        near = np.abs(frf.freqs - fn) <= radius
        keep &= ~near
        warnings.append(f"{text}; the {int(near.sum())} sweep point(s) within {radius:.3g} Hz "
                        f"of it (where the lag reads the FRF more than {100 * error:g} % off) "
                        "are left out of the fit")
    if not keep.any():
        raise RecordingError("no quasi-steady point left in the sweep: it passes its modes "
                             "too fast (ISO 7626-2); sweep slower or record a stepped sine")
    cut = {name: getattr(frf, name)[keep] for name in
           ("freqs", "force", "X", "noise", "force_harmonics", "times", "window_s")}
    return SweepFRF(harmonics=frf.harmonics, level=frf.level, force_dof=frf.force_dof,
                    direction=frf.direction, **cut), warnings


def _too_fast(law: SweepLaw, modes: Sequence[tuple[float, float]]
              ) -> tuple[list[tuple[float, float]], list[str]]:
    """The modes a sweep passes too fast and the `sweep_rate_check` warning of each."""
    pairs = [(m, w) for m in modes for w in sweep_rate_check(law, [m])]
    return [m for m, _ in pairs], [w for _, w in pairs]
