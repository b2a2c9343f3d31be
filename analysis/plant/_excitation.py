"""Drive-signal generators: random, periodic random (multisine), burst, stepped and swept sine.

All generators return float arrays of samples at ``fs`` and are deterministic for a given
``seed``. Bands are ``(f_lo, f_hi)`` in Hz with ``0 <= f_lo < f_hi <= fs/2``.
"""

from __future__ import annotations

import math
from typing import NamedTuple, Sequence

import numpy as np
from scipy import signal as _signal

from ..errors import InputError


class ExcitationError(InputError):
    """Bad excitation settings."""


class SineStep(NamedTuple):
    """One stepped-sine step: drive frequency (Hz), settle and measure lengths (samples)."""

    freq: float
    n_settle: int
    n_measure: int


def _check_common(n: int, fs: float, rms: float | None = None) -> None:
    if not (isinstance(n, (int, np.integer)) and n >= 2):
        raise ExcitationError(f"number of samples must be an integer >= 2, got {n!r}")
    if not (math.isfinite(fs) and fs > 0):
        raise ExcitationError(f"sample rate fs must be a positive number, got {fs!r}")
    if rms is not None and not (math.isfinite(rms) and rms >= 0):
        raise ExcitationError(f"rms must be a number >= 0, got {rms!r}")


def _band_bins(n: int, fs: float, band: Sequence[float]) -> np.ndarray:
    """Indices of the rfft bins of an n-sample record inside ``band``."""
    try:
        lo, hi = (float(b) for b in band)
    except (TypeError, ValueError):
        raise ExcitationError(f"band must be (f_lo, f_hi) in Hz, got {band!r}") from None
    if not (0 <= lo < hi <= fs / 2):
        raise ExcitationError(f"band ({lo}, {hi}) Hz must satisfy 0 <= f_lo < f_hi <= fs/2 "
                              f"= {fs / 2}")
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    bins = np.flatnonzero((freqs >= lo) & (freqs <= hi) & (freqs > 0))
    if bins.size == 0:
        raise ExcitationError(f"band ({lo}, {hi}) Hz holds no frequency line of a {n}-sample "
                              f"record at fs = {fs} (resolution {fs / n:.4g} Hz); widen the "
                              "band or lengthen the record")
    return bins


def _scale(x: np.ndarray, rms: float) -> np.ndarray:
    actual = np.sqrt(np.mean(x ** 2))
    return x * (rms / actual) if actual > 0 else x


def random_gaussian(n: int, fs: float, band: Sequence[float], rms: float,
                    seed: int | None = None) -> np.ndarray:
    """Band-limited Gaussian random noise.

    White Gaussian noise is shaped in the frequency domain (every rfft bin outside ``band``
    set to zero), so the record has no power outside the band; it is scaled to the exact
    sample rms.

    Parameters
    ----------
    n : int
        Number of samples.
    fs : float
        Sample rate, Hz.
    band : (float, float)
        Pass band, Hz.
    rms : float
        Root-mean-square value of the record.
    seed : int, optional
        Random seed.

    Returns
    -------
    ndarray, shape (n,)
    """
    _check_common(n, fs, rms)
    bins = _band_bins(n, fs, band)
    spec = np.fft.rfft(np.random.default_rng(seed).standard_normal(n))
    mask = np.zeros(spec.size, dtype=bool)
    mask[bins] = True
    spec[~mask] = 0.0
    return _scale(np.fft.irfft(spec, n), rms)


def multisine(n_period: int, fs: float, band: Sequence[float], rms: float,
              seed: int | None = None, phases: str = "random") -> np.ndarray:
    """One period of a multisine (periodic random) with a flat amplitude spectrum in ``band``.

    Parameters
    ----------
    n_period : int
        Samples per period; the lines are at multiples of ``fs / n_period``.
    fs : float
        Sample rate, Hz.
    band : (float, float)
        Band of excited lines, Hz.
    rms : float
        Root-mean-square value.
    seed : int, optional
        Seed of the random phases (ignored for Schroeder phases).
    phases : {"random", "schroeder"}
        Uniform random phases, or Schroeder phases (low crest factor).

    Returns
    -------
    ndarray, shape (n_period,)
        Use `periodic` to repeat it.
    """
    _check_common(n_period, fs, rms)
    bins = _band_bins(n_period, fs, band)
    k = np.arange(1, bins.size + 1)
    if phases == "random":
        phi = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, bins.size)
    elif phases == "schroeder":
        phi = -np.pi * k * (k - 1) / bins.size
    else:
        raise ExcitationError(f"phases '{phases}' is not 'random' or 'schroeder'")
    spec = np.zeros(n_period // 2 + 1, dtype=complex)
    spec[bins] = np.exp(1j * phi)
    return _scale(np.fft.irfft(spec, n_period), rms)


def periodic(signal: np.ndarray, n_periods: int) -> np.ndarray:
    """Repeat one period ``n_periods`` times along the first axis."""
    if not (isinstance(n_periods, (int, np.integer)) and n_periods >= 1):
        raise ExcitationError(f"n_periods must be an integer >= 1, got {n_periods!r}")
    signal = np.asarray(signal, dtype=float)
    return np.tile(signal, (n_periods,) + (1,) * (signal.ndim - 1))


def burst_random(n: int, fs: float, band: Sequence[float], rms: float,
                 burst_fraction: float, seed: int | None = None) -> np.ndarray:
    """Burst random: band-limited Gaussian noise for the first part of the record, then zero.

    The burst (``round(burst_fraction * n)`` samples) has rms ``rms``; its first and last 5 %
    are tapered with half-cosines so the switch-on/off adds little out-of-band power. The
    quiet tail lets the response decay inside the record (no leakage in the FRF estimate).

    Parameters
    ----------
    n : int
        Record length, samples.
    fs : float
        Sample rate, Hz.
    band : (float, float)
        Pass band, Hz.
    rms : float
        Rms of the burst part.
    burst_fraction : float
        Fraction of the record driven, in (0, 1].
    seed : int, optional
        Random seed.

    Returns
    -------
    ndarray, shape (n,)
    """
    _check_common(n, fs, rms)
    if not (0 < burst_fraction <= 1):
        raise ExcitationError(f"burst_fraction must be in (0, 1], got {burst_fraction!r}")
    n_burst = int(round(burst_fraction * n))
    if n_burst < 2:
        raise ExcitationError(f"burst of {n_burst} samples is too short; raise "
                              "burst_fraction or the record length")
    burst = random_gaussian(n_burst, fs, band, 1.0, seed) * _signal.windows.tukey(n_burst, 0.1)
    out = np.zeros(n)
    out[:n_burst] = _scale(burst, rms)
    return out


def stepped_sine_plan(freqs: Sequence[float] | tuple[float, float, int, str],
                      direction: str = "up", settle_cycles: float = 20.0,
                      measure_cycles: float = 20.0,
                      fs: float | None = None) -> list[SineStep]:
    """Steps of a stepped-sine test.

    Parameters
    ----------
    freqs : sequence of float or (f_start, f_stop, n_steps, spacing)
        Explicit drive frequencies (Hz), or a range with ``spacing`` "linear" or "log".
    direction : {"up", "down"}
        Order of the steps: increasing or decreasing frequency.
    settle_cycles, measure_cycles : float
        Cycles at each frequency before measuring (transient decay) and measured.
    fs : float
        Sample rate, Hz (required).

    Returns
    -------
    list of SineStep
        ``(freq, n_settle, n_measure)``; sample counts are rounded up to cover the cycles.
    """
    if fs is None or not (math.isfinite(fs) and fs > 0):
        raise ExcitationError(f"stepped_sine_plan needs the sample rate fs > 0, got {fs!r}")
    if isinstance(freqs, tuple) and len(freqs) == 4 and isinstance(freqs[3], str):
        f_start, f_stop, n_steps, spacing = freqs
        if not (isinstance(n_steps, (int, np.integer)) and n_steps >= 1):
            raise ExcitationError(f"n_steps must be an integer >= 1, got {n_steps!r}")
        if spacing not in ("linear", "log"):
            raise ExcitationError(f"spacing '{spacing}' is not 'linear' or 'log'")
        if spacing == "log" and min(f_start, f_stop) <= 0:
            raise ExcitationError("log spacing needs f_start and f_stop > 0")
        make = np.geomspace if spacing == "log" else np.linspace
        values = make(float(f_start), float(f_stop), int(n_steps))
    else:
        try:
            values = np.atleast_1d(np.asarray(freqs, dtype=float))
        except (TypeError, ValueError):
            raise ExcitationError("freqs must be a list of frequencies in Hz or "
                                  "(f_start, f_stop, n_steps, 'linear'|'log')") from None
    if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
        raise ExcitationError("freqs must be a non-empty list of finite frequencies in Hz")
    if np.any(values <= 0) or np.any(values >= fs / 2):
        raise ExcitationError(f"stepped-sine frequencies must lie in (0, fs/2 = {fs / 2}) Hz")
    if direction not in ("up", "down"):
        raise ExcitationError(f"direction '{direction}' is not 'up' or 'down'")
    if not (settle_cycles >= 0 and measure_cycles > 0):
        raise ExcitationError("settle_cycles must be >= 0 and measure_cycles > 0")
    values = np.sort(values)
    if direction == "down":
        values = values[::-1]
    return [SineStep(float(f), math.ceil(settle_cycles * fs / f - 1e-9),
                     max(1, math.ceil(measure_cycles * fs / f - 1e-9))) for f in values]


def sine_block(freq: float, amplitude: float, n: int, fs: float,
               phase: float = 0.0) -> np.ndarray:
    """``amplitude * sin(2 pi freq k / fs + phase)`` for ``k = 0 .. n-1``."""
    if not (math.isfinite(fs) and fs > 0 and 0 < freq < fs / 2):
        raise ExcitationError(f"sine frequency {freq!r} Hz must lie in (0, fs/2) with fs > 0")
    return amplitude * np.sin(2 * np.pi * freq * np.arange(n) / fs + phase)


def swept_sine(f0: float, f1: float, duration: float, fs: float, amplitude: float,
               method: str = "logarithmic") -> np.ndarray:
    """Swept sine (chirp) from ``f0`` to ``f1`` Hz over ``duration`` s (`scipy.signal.chirp`).

    ``method`` is any `scipy.signal.chirp` method ("logarithmic", "linear", "quadratic",
    "hyperbolic"). Returns ``round(duration * fs)`` samples starting at phase -90 degrees
    (a sine, so the drive starts at zero).
    """
    n = int(round(duration * fs))
    _check_common(n, fs)
    if not (0 < f0 < fs / 2 and 0 < f1 < fs / 2):
        raise ExcitationError(f"sweep limits {f0}, {f1} Hz must lie in (0, fs/2 = {fs / 2})")
    if method not in ("logarithmic", "linear", "quadratic", "hyperbolic"):
        raise ExcitationError(f"sweep method '{method}' is not logarithmic, linear, quadratic "
                              "or hyperbolic")
    t = np.arange(n) / fs
    return amplitude * _signal.chirp(t, f0, duration, f1, method=method, phi=-90)
