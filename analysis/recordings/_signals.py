"""Signal hygiene: frequency-domain integration/differentiation, DC removal, band selection.

Differentiation and integration are done by multiplying the spectrum by ``(i w)^k``: exact
for band-limited data, where finite differences bias a velocity by ``1 - sinc`` (several
percent near the band edge). The record is mirrored before the FFT (even extension) so that
the periodic continuation has no jump at the ends; the remaining end effect is confined to a
few hundred samples, which `EDGE_SECONDS`-style trimming in the estimators removes.
"""

from __future__ import annotations

import functools
from typing import Sequence
import math

import numpy as np
import scipy.fft
import scipy.signal
import scipy.special

from ..errors import InputError

KIND_ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
# Lookahead (samples) of the hold-image filters and the band (fraction of fs) they are
# designed for: drive content above HOLD_IMAGE_BAND * fs is not corrected.
HOLD_IMAGE_LOOKAHEAD = 64
HOLD_IMAGE_BAND = 0.45


def change_kind(signal: np.ndarray, fs: float, order: int, *, highpass: float = 0.0,
                lowpass: float | None = None) -> np.ndarray:
    """Differentiate (``order > 0``) or integrate (``order < 0``) along axis 0.

    Parameters
    ----------
    signal : ndarray, shape (n, ...)
        Real time series, time along axis 0.
    fs : float
        Sample rate, Hz.
    order : int
        Number of differentiations; negative for integrations (acceleration -> displacement
        is ``-2``).
    highpass : float
        Bins below this frequency are zeroed (needed for integration: the DC and drift of an
        integrated signal are not determined by the data). Integration always zeroes DC.
    lowpass : float, optional
        Bins above this frequency are zeroed.

    Returns
    -------
    ndarray, same shape as ``signal``
    """
    x = np.asarray(signal, dtype=float)
    n = x.shape[0]
    if n < 4:
        raise InputError(f"a record of {n} samples is too short to integrate/differentiate")
    f = np.fft.rfftfreq(2 * n, 1 / fs)
    keep = f >= highpass
    if lowpass is not None:
        keep &= f <= lowpass
    if order == 0:
        return _filtered(np.concatenate([x, x[::-1]], axis=0), keep)[:n]
    step = 1 if order > 0 else -1
    for _ in range(abs(order)):
        # Differentiate the even extension (continuous); integrate the odd one, whose
        # integral is the continuous even extension and whose mean is exactly zero.
        ext = np.concatenate([x, x[::-1] if step > 0 else -x[::-1]], axis=0)
        gain = np.zeros(f.size, dtype=complex)
        gain[1:] = (2j * np.pi * f[1:]) ** step
        gain[-1] = 0.0  # Nyquist bin of an odd derivative is not real: drop it
        x = _filtered(ext, keep if step > 0 else np.ones_like(keep), gain)[:n]
    if step < 0:
        # Integration constants are not in the data; after two integrations they leave a
        # linear trend. Remove it, then band-limit.
        x = scipy.signal.detrend(x, axis=0, type="linear")
        x = _filtered(np.concatenate([x, x[::-1]], axis=0), keep)[:n]
    return x


def _filtered(ext: np.ndarray, keep: np.ndarray, gain: np.ndarray | None = None) -> np.ndarray:
    spec = scipy.fft.rfft(ext, axis=0)
    g = keep.astype(complex) if gain is None else gain * keep
    spec *= g.reshape((-1,) + (1,) * (ext.ndim - 1))
    return scipy.fft.irfft(spec, ext.shape[0], axis=0)


def to_kinematics(response: np.ndarray, fs: float, kind: str, *, highpass: float = 0.0,
                  lowpass: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and velocity from a response recorded as ``kind``.

    Parameters
    ----------
    response : ndarray, shape (n, n_dof)
    fs : float
    kind : {"displacement", "velocity", "acceleration"}
    highpass, lowpass : float
        See `change_kind`. A velocity or acceleration record needs ``highpass > 0`` for a
        meaningful displacement (the integration constant is not in the data).

    Returns
    -------
    x, v : ndarray, shape (n, n_dof)
    """
    if kind not in KIND_ORDER:
        raise InputError(f"response kind '{kind}' is not one of {', '.join(KIND_ORDER)}")
    k = KIND_ORDER[kind]
    if k > 0 and highpass <= 0:
        raise InputError(f"integrating a {kind} record needs a high-pass frequency > 0; give "
                         "the lower edge of the analysis band")
    x = change_kind(response, fs, -k, highpass=highpass, lowpass=lowpass)
    v = change_kind(response, fs, 1 - k, highpass=highpass, lowpass=lowpass)
    return x, v


def flat_ends(*channels: np.ndarray) -> tuple[int, int]:
    """Leading and trailing runs of two or more samples at which every channel holds exactly
    its first (last) value: the lead-in and trailing zeros of an export, recorded before the
    drive started and after it stopped. (0, 0) when none or when every sample is flat.

    Parameters
    ----------
    *channels : ndarray, shape (n,) or (n, n_ch)
        Time along axis 0, the same ``n`` for each.

    Returns
    -------
    lead, tail : int
    """
    x = np.concatenate([np.asarray(c, dtype=float).reshape(len(c), -1) for c in channels],
                       axis=1)
    moving = np.flatnonzero(np.any(np.diff(x, axis=0) != 0, axis=1))
    if moving.size == 0:
        return 0, 0
    lead, tail = int(moving[0]) + 1, int(x.shape[0] - 1 - moving[-1])
    return (lead if lead >= 2 else 0), (tail if tail >= 2 else 0)


def remove_dc(signal: np.ndarray) -> np.ndarray:
    """Subtract each channel's mean (time along axis 0)."""
    x = np.asarray(signal, dtype=float)
    return x - x.mean(axis=0)


INTEGRATION_FLOOR_DB = -10.0
"""Force level, relative to the median of the excited bins, above which a bin counts for the
lower band edge of a record that is integrated (velocity, acceleration): that edge is the
integration's high-pass, and below the drive band the residual force (-18 dB on a simulated
shaker) leaves a response that double integration of the sensor noise swamps (1/omega^4).
Measured on examples/campaign-sim-sensors.toml: a 0.25 Hz edge made the true model misfit
up to 300x its floor in `diagnose`; the drive band's 3.5 Hz edge fits it within the floor."""


def excitation_band(freqs: np.ndarray, force_psd: np.ndarray, *,
                    floor_db: float = -20.0, kind: str = "displacement"
                    ) -> tuple[float, float]:
    """Contiguous band around the force spectrum's bulk where it is within ``floor_db`` of it.

    Gaps narrower than the excited runs on both sides (the dips a measured force shows at the
    structure's resonances) are bridged. For a response ``kind`` that must be integrated the
    lower edge (the integration's high-pass) is where the force is within
    `INTEGRATION_FLOOR_DB` of its median.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
    force_psd : ndarray, shape (n_f,) or (n_f, n_in)
        Force auto-spectra; several inputs are summed.
    floor_db : float
        Level, relative to the median of the excited bins, below which a bin counts as not
        excited.
    kind : {"displacement", "velocity", "acceleration"}
        Response kind of the record the band is for.

    Returns
    -------
    (lo, hi) : float
        The widest contiguous run of excited bins, Hz.
    """
    p = np.asarray(force_psd, dtype=float)
    if p.ndim == 2:
        p = p.sum(axis=1)
    if not np.any(p > 0):
        raise InputError("the force channels carry no power; check the force signal")
    ref = np.median(p[p >= 1e-3 * p.max()])
    ok = p >= ref * 10 ** (floor_db / 10)
    ok[freqs <= 0] = False
    runs, start = [], None
    for i, flag in enumerate(np.append(ok, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            runs.append([start, i - 1])
            start = None
    # A measured force dips at the structure's resonances (the shaker cannot push a structure
    # that moves freely): a gap narrower than the excited runs on both sides is such a dip,
    # not a band edge.
    merged: list[list[int]] = []
    for r in runs:
        if merged and r[0] - merged[-1][1] - 1 < min(merged[-1][1] - merged[-1][0],
                                                     r[1] - r[0]) + 1:
            merged[-1][1] = r[1]
        else:
            merged.append(r)
    best = max(merged, key=lambda r: r[1] - r[0], default=(0, -1))
    run = best[1] - best[0] + 1
    if run < 3:
        raise InputError("the force spectrum has no excited band of 3 or more bins; use a "
                         "broadband random excitation or give --band")
    lo, hi = float(freqs[best[0]]), float(freqs[best[1]])
    if KIND_ORDER.get(kind, 0) > 0 and floor_db < INTEGRATION_FLOOR_DB:
        lo = max(lo, excitation_band(freqs, p, floor_db=INTEGRATION_FLOOR_DB)[0])
    return lo, hi


def signal_bandwidth(signal: np.ndarray, fs: float, *, fraction: float = 1 - 1e-6) -> float:
    """Frequency below which ``fraction`` of the signal power lies, Hz (max over channels)."""
    x = np.atleast_2d(np.asarray(signal, dtype=float).T).T
    p = np.abs(scipy.fft.rfft(x - x.mean(axis=0), axis=0)) ** 2
    cum = np.cumsum(p, axis=0)
    f = np.fft.rfftfreq(x.shape[0], 1 / fs)
    total = cum[-1]
    out = 0.0
    for j in range(x.shape[1]):
        if total[j] > 0:
            out = max(out, float(f[np.searchsorted(cum[:, j], fraction * total[j])
                                   .clip(max=f.size - 1)]))
    return out


def steady_periods(signal: np.ndarray, period: int, *, transient_periods: int = 1,
                   realizations: int = 1) -> np.ndarray:
    """Steady-state periods of a periodic-drive record, shape (realizations, P, period, ...).

    The record (time along axis 0) holds ``realizations`` consecutive blocks of equal length,
    each a whole number of periods of ``period`` samples; the first ``transient_periods`` of
    every block (the response settling after a change of drive) are dropped.

    Raises
    ------
    InputError
        When the record does not split into whole periods or no steady period remains.
    """
    x = np.asarray(signal, dtype=float)
    n = x.shape[0]
    if period < 2 or realizations < 1 or transient_periods < 0:
        raise InputError(f"period ({period}) must be >= 2 samples, realizations "
                         f"({realizations}) >= 1 and transient periods ({transient_periods}) "
                         ">= 0")
    block = n // realizations
    if block * realizations != n or block % period:
        raise InputError(f"a record of {n} samples does not split into {realizations} "
                         f"realization(s) of whole {period}-sample periods; check the period "
                         "and realization count")
    n_per = block // period
    if n_per <= transient_periods:
        raise InputError(f"each realization holds {n_per} period(s), none left after "
                         f"{transient_periods} transient period(s); record more periods")
    return x.reshape((realizations, n_per, period) + x.shape[1:])[:, transient_periods:]


def periodic_kinematics(periods: np.ndarray, fs: float, kind: str, *,
                        lowpass: float | None = None, highpass: float = 0.0,
                        weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and velocity of exactly periodic records (one period along axis -2).

    Each period is transformed once and multiplied by ``(i 2 pi f)^k`` at its exact DFT
    lines: no extension, no end effect, no leakage. Integration sets the mean (DC line) to
    zero, odd orders drop the Nyquist line; ``lowpass`` zeroes the lines above it and
    ``highpass`` those below it (integrated sensor noise grows as ``f^-k`` towards DC: below
    the excited band it would swamp the displacement).

    Parameters
    ----------
    periods : ndarray, shape (..., period, n_ch)
    fs : float
    kind : {"displacement", "velocity", "acceleration"}
    lowpass, highpass : float, optional
        Hz.
    weights : ndarray, shape (period // 2 + 1,) or (period // 2 + 1, n_ch), optional
        Further per-line gains (a smoothing filter, for example).

    Returns
    -------
    x, v : ndarray, same shape as ``periods``
    """
    if kind not in KIND_ORDER:
        raise InputError(f"response kind '{kind}' is not one of {', '.join(KIND_ORDER)}")
    k = KIND_ORDER[kind]
    n = periods.shape[-2]
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = scipy.fft.rfft(periods, axis=-2)
    if weights is not None:
        spec = spec * (weights if np.ndim(weights) == 2 else weights[:, None])
    out = []
    for j in (0, 1):
        gain = np.zeros(f.size, dtype=complex)
        gain[1:] = (2j * np.pi * f[1:]) ** (j - k)
        gain[0] = 1.0 if j == k == 0 else 0.0
        if (j - k) % 2 and n % 2 == 0:
            gain[-1] = 0.0                  # the Nyquist line of an odd derivative is not real
        if lowpass is not None:
            gain[f > lowpass] = 0.0
        gain[f < highpass] = 0.0
        out.append(scipy.fft.irfft(spec * gain[:, None], n, axis=-2))
    return out[0], out[1]


def period_spectra(periods: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signal power of the period average and its noise power, per DFT line and channel.

    Parameters
    ----------
    periods : ndarray, shape (M, P, period, n_ch)
        Steady-state periods of ``M`` realizations (`steady_periods`), ``P >= 2``.

    Returns
    -------
    signal, noise : ndarray, shape (period // 2 + 1, n_ch)
        ``|DFT|^2`` of the mean over periods and the noise variance of that mean (the
        variance across periods / P, Pintelon & Schoukens' nonparametric noise estimate),
        both averaged over the realizations.
    """
    n_p = periods.shape[1]
    if n_p < 2:
        raise InputError("a noise estimate needs at least 2 steady-state periods")
    spec = scipy.fft.rfft(periods, axis=2)
    mean = spec.mean(axis=1)
    noise = (np.abs(spec - mean[:, None]) ** 2).sum(axis=1) / ((n_p - 1) * n_p)
    return (np.abs(mean) ** 2).mean(axis=0), noise.mean(axis=0)


def hold_image_gain(nu: np.ndarray, order: int) -> np.ndarray:
    """Folded images of a first-order-hold drive seen through the mass line, per sample rate.

    A force applied as the first-order hold of its samples ``F`` has spectral images at
    ``f + m fs`` weighted by ``sinc^2(f/fs + m)``. A structure passes them to its
    ``order``-th derivative (0 displacement, 1 velocity, 2 acceleration) with its
    high-frequency asymptote ``M^-1 B (i w)^(order - 2)``, and sampling folds them back onto
    ``f``. The folded sum, without the ``M^-1 B`` factor and with ``fs = 1``, is::

        E(nu) = sum_{m != 0} sinc^2(nu + m) (2 pi i (nu + m))^(order - 2)

    (``1 - sinc^2(nu)`` for acceleration: the sampled acceleration carries the drive sample
    itself, not its baseband part). Multiply by ``fs^(order - 2)`` for physical units.

    Parameters
    ----------
    nu : ndarray
        Frequency / fs, in (-1, 1).
    order : int <= 2
        Power ``order - 2`` of ``i w``; orders below 0 give the higher terms of the
        asymptotic expansion of the structure's response (`analysis.plant.Plant.image_gains`).

    Returns
    -------
    ndarray, complex
    """
    nu = np.asarray(nu, dtype=float)
    if order == 2:
        return (1.0 - np.sinc(nu) ** 2).astype(complex)
    p = 4 - order    # sum_{m != 0} (nu + m)^-p by polygamma functions
    s = ((-1) ** p * scipy.special.polygamma(p - 1, 1 + nu)
         + scipy.special.polygamma(p - 1, 1 - nu)) / math.factorial(p - 1)
    return np.sin(np.pi * nu) ** 2 / np.pi ** 2 * s * (2j * np.pi) ** (order - 2)


@functools.lru_cache(maxsize=None)
def hold_image_taps(order: int, lookahead: int = HOLD_IMAGE_LOOKAHEAD,
                    band: float = HOLD_IMAGE_BAND) -> np.ndarray:
    """Symmetric FIR (``2 lookahead + 1`` taps, centre at ``lookahead``) of `hold_image_gain`.

    Least-squares fit of the gain on ``0 <= nu <= band``; the band above is left free, which
    makes the fit converge exponentially in the length (relative error ~1e-9 for the
    defaults). Even orders give even taps, order 1 odd taps.
    """
    nu = np.linspace(0.0, band, 8 * lookahead + 1)
    w = 2 * np.pi * nu
    n = np.arange(1, lookahead + 1)
    gain = hold_image_gain(nu, order)
    if order % 2 == 0:   # response t0 + 2 sum t_n cos(w n)
        basis = np.column_stack([np.ones_like(w), 2 * np.cos(np.outer(w, n))])
        coef = np.linalg.lstsq(basis, gain.real, rcond=None)[0]
        taps = np.concatenate([coef[:0:-1], coef])
    else:                # taps t_{-n} = -t_n: response -2i sum t_n sin(w n) ... (t_n at lag -n)
        basis = 2 * np.sin(np.outer(w, n))
        coef = np.linalg.lstsq(basis, gain.imag, rcond=None)[0]
        taps = np.concatenate([-coef[::-1], [0.0], coef])
    taps.setflags(write=False)
    return taps


def hold_images(force: np.ndarray, fs: float, order: int) -> np.ndarray:
    """Folded hold images (`hold_image_gain`) of a force record, per force channel.

    Parameters
    ----------
    force : ndarray, shape (n + 2 L, n_in)
        Force samples with ``L = HOLD_IMAGE_LOOKAHEAD`` samples of context before and after
        the ``n`` samples wanted.
    fs : float
    order : int <= 2

    Returns
    -------
    ndarray, shape (n, n_in)
        Image term of the central samples (times a gain matrix of
        `analysis.plant.Plant.image_gains`, the response part it causes).
    """
    taps = hold_image_taps(order)
    f = np.asarray(force, dtype=float)
    # y_k = sum_j t_j f_{k+j} (j = -L..L): a correlation, i.e. convolution with reversed taps
    out = np.stack([np.convolve(f[:, i], taps[::-1], mode="valid")
                    for i in range(f.shape[1])], axis=1)
    return out * fs ** (order - 2)


def remove_hold_images(samples: np.ndarray, force: np.ndarray, fs: float, kind: str,
                       image_gains: Sequence[np.ndarray]) -> np.ndarray:
    """Anti-aliased response of a whole record from the plant's instantaneous samples.

    Subtracts the folded hold images of the drive (`analysis.plant._plant` module docstring, Sensor sampling). The
    plant is taken at rest with zero force before the record; past its end the force is
    continued by its mirror image (the last ``HOLD_IMAGE_LOOKAHEAD`` samples depend on that
    continuation).

    Parameters
    ----------
    samples : ndarray, shape (n, n_dof)
        Instantaneous ``kind`` samples (`PlantOutput` fields, noise-free or not).
    force : ndarray, shape (n, n_in)
        The drive that produced them, from rest.
    fs : float
    kind : {"displacement", "velocity", "acceleration"}
    image_gains : sequence of ndarray, shape (n_dof, n_in)
        `Plant.image_gains`.

    Returns
    -------
    ndarray, shape (n, n_dof)
    """
    f = np.asarray(force, dtype=float).reshape(len(samples), -1)
    lag = HOLD_IMAGE_LOOKAHEAD
    tail = f[::-1][:lag]
    if tail.shape[0] < lag:
        tail = np.concatenate([tail, np.zeros((lag - tail.shape[0], f.shape[1]))])
    ext = np.concatenate([np.zeros((lag, f.shape[1])), f, tail])
    return samples - hold_image_response(ext, fs, kind, image_gains)


def hold_image_response(force: np.ndarray, fs: float, kind: str,
                        image_gains: Sequence[np.ndarray]) -> np.ndarray:
    """Folded hold images in a ``kind`` response, (n, n_dof), from a force record with
    ``HOLD_IMAGE_LOOKAHEAD`` samples of context at each end (`analysis.recordings.hold_images`)."""
    k = KIND_ORDER[kind]
    return sum(hold_images(force, fs, k - j) @ g.T for j, g in enumerate(image_gains))
