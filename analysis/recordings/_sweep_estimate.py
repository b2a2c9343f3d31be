"""The sweep law of a swept-sine record that names none, read off its force.

Exports of commercial acquisition systems carry the arrays and the sample rate only. The
sweep is found in the force: trailing zero samples and the quiet lead-in before the sweep
are trimmed (`active_span`), then the law is fitted to the instantaneous phase of the force
(`estimate_sweep`): the analytic-signal (Hilbert) phase, read as block frequencies for a
robust (Theil-Sen) first guess of each law, then refined by a robust least-squares fit of the
phase itself; the law with the smaller phase residual is kept (linear unless the log law
fits clearly better).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import hilbert
from scipy.stats import spearmanr, theilslopes

from ..errors import RecordingError
from ._sweep_law import SWEEP_LAWS, Sweep, SweepLaw

#: a sample is a (trailing) zero when below this fraction of the force peak
ZERO_FRACTION = 1e-6
#: the sweep is where the force envelope exceeds this fraction of its median
ACTIVE_FRACTION = 0.25
#: the log law is chosen when its phase residual is below this fraction of the linear law's
LOG_PREFERENCE = 0.7
#: samples of the phase used in the least-squares refinement (decimated beyond)
FIT_SAMPLES = 20000
#: a record is taken as a sweep when the rank correlation of its block frequencies with time
#: is beyond this (a random or multisine force: near 0; a sweep: 1 up to noise)
SWEEP_MONOTONY = 0.95


def active_span(force: np.ndarray) -> tuple[int, int]:
    """Sample range ``[start, stop)`` of the sweep in a record.

    Parameters
    ----------
    force : ndarray, shape (n,)
        The force channel.

    Returns
    -------
    start, stop : int
        ``stop`` follows the last sample above `ZERO_FRACTION` of the peak (trailing zeros
        cut); ``start`` is where the signal last crossed zero before it first reaches
        `ACTIVE_FRACTION` of its median envelope (a quiet lead-in cut), ``stop`` likewise
        after it last does.
    """
    f = np.asarray(force, dtype=float).reshape(-1)
    peak = np.max(np.abs(f)) if f.size else 0.0
    live = np.flatnonzero(np.abs(f) > ZERO_FRACTION * peak)
    if live.size < 16:
        raise RecordingError("the force holds no sweep (all samples zero or nearly so); check "
                             "the force channel")
    stop = int(live[-1]) + 1
    env = np.abs(hilbert(f[:stop] - f[:stop].mean()))
    ref = np.median(env[env > ACTIVE_FRACTION * np.median(env)])
    on = np.flatnonzero(np.abs(f[:stop]) >= ACTIVE_FRACTION * ref)
    return _to_crossing(f, int(on[0]), -1), _to_crossing(f, int(on[-1]), 1) + 1


def _to_crossing(f: np.ndarray, i: int, step: int) -> int:
    """From sample ``i``, walk by ``step`` while the samples keep their sign and shrink: the
    last sample before the signal crosses zero (where a sweep starting or ending at zero
    phase begins or ends)."""
    while 0 <= i + step < f.size and f[i + step] * f[i] > 0 and abs(f[i + step]) < abs(f[i]):
        i += step
    return i


def force_phase(force: np.ndarray) -> np.ndarray:
    """Unwrapped analytic-signal phase of a force record, rad."""
    f = np.asarray(force, dtype=float).reshape(-1)
    return np.unwrap(np.angle(hilbert(f - f.mean())))


def looks_like_sweep(force: np.ndarray, fs: float) -> bool:
    """Whether a record's force is a swept sine that names none (an export imported as random).

    Parameters
    ----------
    force : ndarray, shape (n,)
        The force channel.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    bool
        True when the force's instantaneous frequency (block slopes of its Hilbert phase, as
        `estimate_sweep` reads them) rises or falls monotonically over at least 16 blocks:
        Spearman's rank correlation with time beyond `SWEEP_MONOTONY` in size, every block
        frequency positive and the covered range over a quarter of the highest.
    """
    f = np.asarray(force, dtype=float).reshape(-1)
    if f.size < 512 or not np.any(f):
        return False
    try:
        start, stop = active_span(f)
    except RecordingError:
        return False
    phase = force_phase(f[start:stop])
    block = max(32, phase.size // 200)
    starts = np.arange(0, phase.size - block, block)
    if starts.size < 16:
        return False
    t = np.arange(block) / fs
    fb = np.array([np.polyfit(t, phase[a:a + block], 1)[0] for a in starts]) / (2 * np.pi)
    rho = spearmanr(np.arange(fb.size), fb)[0]
    return bool(np.all(fb > 0) and abs(rho) > SWEEP_MONOTONY
                and np.ptp(fb) > 0.25 * fb.max())


def estimate_sweep(force: np.ndarray, fs: float, *, law: str | None = None
                   ) -> tuple[Sweep, float]:
    """The sweep of a record, from its force alone.

    Parameters
    ----------
    force : ndarray, shape (n,)
        The force channel, lead-in and trailing zeros included.
    fs : float
        Sample rate, Hz.
    law : {"linear", "log"}, optional
        The law if known; else the better-fitting one.

    Returns
    -------
    sweep : Sweep
        ``estimated`` True; the law starts at the first kept sample; ``trimmed_lead`` and
        ``trimmed_tail`` say how many samples to drop from each end of the record.
    amplitude : float
        Median force envelope over the sweep, N (the level of the record).
    """
    f = np.asarray(force, dtype=float).reshape(-1)
    start, stop = active_span(f)
    seg = f[start:stop]
    n = seg.size
    if n < 64:
        raise RecordingError(f"the sweep holds {n} samples; too short to estimate its law")
    phase = force_phase(seg)
    t = np.arange(n) / fs
    edge = max(n // 50, 1)                                  # Hilbert edge effects
    step = max(1, (n - 2 * edge) // FIT_SAMPLES)
    ti, pi = t[edge:n - edge:step], phase[edge:n - edge:step]
    # block frequencies: phase slope over blocks of ~ n/200 samples (at least 32)
    block = max(32, n // 200)
    starts = np.arange(edge, n - edge - block, block)
    if starts.size < 8:
        raise RecordingError("the sweep is too short to estimate its law (fewer than 8 blocks)")
    tc = t[starts + block // 2]
    fb = np.array([np.polyfit(t[a:a + block], phase[a:a + block], 1)[0]
                   for a in starts]) / (2 * np.pi)
    if np.any(fb <= 0):
        raise RecordingError("the force's phase does not advance steadily: it is not a sweep "
                             "(or the force channel is wrong)")
    fits = {}
    for name in ((law,) if law else SWEEP_LAWS):
        if name not in SWEEP_LAWS:
            raise RecordingError(f"sweep law '{name}' is not one of {', '.join(SWEEP_LAWS)}")
        y = fb if name == "linear" else np.log(fb)
        slope, icept, *_ = theilslopes(y, tc)
        fits[name] = _refine(name, ti, pi, icept, slope)
    name = "linear"
    if "log" in fits and ("linear" not in fits
                          or fits["log"][1] < LOG_PREFERENCE * fits["linear"][1]):
        name = "log"
    (f0, slope), _ = fits[name]
    t_end = (n - 1) / fs
    f1 = f0 + slope * t_end if name == "linear" else f0 * np.exp(slope * t_end)
    rate = abs(slope) if name == "linear" else abs(slope) * 60 / np.log(2)
    if not (f0 > 0 and f1 > 0 and max(f0, f1) < fs / 2):
        raise RecordingError(f"the estimated sweep {f0:.3g} -> {f1:.3g} Hz is not a sweep below "
                             "fs/2; give --sweep START:STOP:LAW:RATE")
    env = np.abs(hilbert(seg - seg.mean()))
    sweep = Sweep(SweepLaw(float(f0), float(f1), name, float(rate)), estimated=True,
                  trimmed_lead=start, trimmed_tail=f.size - stop)
    return sweep, float(np.median(env[edge:n - edge]))


def _refine(name: str, t: np.ndarray, phase: np.ndarray, icept: float, slope: float
            ) -> tuple[tuple[float, float], float]:
    """Robust least-squares fit of the law's phase; ``((f0, slope), rms residual)``.

    ``slope`` is Hz/s (linear) or 1/s in ``f = f0 exp(slope t)`` (log).
    """
    f0 = icept if name == "linear" else np.exp(icept)

    def model(p: np.ndarray) -> np.ndarray:
        a, s, c = p
        if name == "linear":
            return 2 * np.pi * (a * t + 0.5 * s * t * t) + c
        return 2 * np.pi * a * t * _exprel(s * t) + c

    c0 = np.median(phase - model(np.array([f0, slope, 0.0])))
    res = least_squares(lambda p: model(p) - phase, [f0, slope, c0], loss="soft_l1",
                        f_scale=0.5, x_scale=[abs(f0), abs(slope) + 1e-9, 1.0])
    a, s, _ = res.x
    return (float(a), float(s)), float(np.sqrt(np.mean(res.fun ** 2)))


def _exprel(x: np.ndarray) -> np.ndarray:
    """``(exp(x) - 1) / x``, 1 at 0."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 1e-8
    return np.where(small, 1 + x / 2, np.expm1(x) / np.where(small, 1, x))
