"""A Welch segment length that resolves the record's resonances.

`default_nperseg` sizes segments by the record length alone (>= 16 segments). A lightly
damped mode has a half-power bandwidth ``2 zeta f_n`` (0.7 Hz for 0.5 % at 71 Hz) that such
lines may not resolve; the leakage of the window then biases H1 and everything estimated from
it. `resolving_nperseg` reads the narrowest bandwidth off a first H1 and doubles the segment
until it spans `LINES_PER_BANDWIDTH` lines, as long as `MIN_SEGMENTS` segments remain.
`pole_resolution` reads the exact bandwidths of a model's linear part instead (a nonlinear
structure's measured FRF shows its modes shifted and widened).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..recordings import KIND_ORDER
from ._frf import default_nperseg
from ._spectral import h1, multiple_coherence, spectral_matrix

#: Lines a half-power bandwidth should span (Hann window: the leakage bias of a peak falls
#: below ~1 % from about 4-5 lines).
LINES_PER_BANDWIDTH = 5.0
#: Lines by which the Hann window widens a peak's half-power bandwidth as read (measured on a
#: 0.5 Hz bandwidth: 2 true lines read as 3.3, 4 as 5.1, 8 as 7.8): a bandwidth is resolved
#: when it reads LINES_PER_BANDWIDTH + WINDOW_WIDENING lines.
WINDOW_WIDENING = 1.5
#: Narrowest half-power width (lines) a peak can read through a Hann window (a sine reads
#: 1.44): narrower ones are ripples of the estimate's error.
MIN_READ_LINES = 1.2
#: Largest relative random error of |H1| at a peak, ``sqrt((1 - g^2) / (2 g^2 n_avg))``
#: (Bendat & Piersol), for its bandwidth to be read: noisier peaks are ripples.
MAX_RANDOM_ERROR = 0.2
#: Lines the exact half-power bandwidth of a model's mode should span (`pole_resolution`):
#: Welch leakage at a lightly damped mode lowers the multiple coherence by about 0.1 / lines
#: (measured on the paper's 3-DOF case at 0.28x damping, 4 N rms, 64 s: minimum coherence
#: 0.983 at 5.7 lines, 0.991 at 11.3), so 10 lines keep it near 0.99.
POLE_LINES = 10.0
#: Fewest Welch segments a record is cut into when segments are lengthened for resolution.
MIN_SEGMENTS = 4
#: Peaks more than 20 dB below the largest are not read: the H1 of a nonlinear structure
#: (its best linear approximation) ripples at ~1e-3 of its peak between the modes (measured on
#: the paper's 3-DOF case at 8 N rms, 7 averages: half-power "peaks" of 1.5-7 Hz at 286-328 Hz).
PEAK_FLOOR = 1e-2


@dataclass(frozen=True)
class Resolution:
    """The segment length chosen and the resonance that set it.

    Attributes
    ----------
    nperseg : int
        Welch segment length, samples.
    peak_hz, bandwidth_hz : float
        Narrowest resonance found and its half-power bandwidth as read at ``nperseg`` (an
        upper bound when unresolved; nan: none found).
    lines : float
        Lines its bandwidth spans at ``nperseg``, as read (the window widens a peak by about
        `WINDOW_WIDENING` lines).
    needed : int
        Segment length that would span `LINES_PER_BANDWIDTH` lines (``nperseg`` when it does).
    fs : float
        Sample rate, Hz.
    """

    nperseg: int
    peak_hz: float
    bandwidth_hz: float
    lines: float
    needed: int
    fs: float

    def at(self, nperseg: int) -> "Resolution":
        """The same resonance seen with segments of ``nperseg`` samples."""
        return replace(self, nperseg=nperseg, lines=self.bandwidth_hz * nperseg / self.fs)

    @property
    def resolved(self) -> bool:
        """False when the narrowest bandwidth reads fewer than `LINES_PER_BANDWIDTH` lines
        (the segment is lengthened further, when the record allows, up to that plus
        `WINDOW_WIDENING`); True when no peak was found."""
        return not self.lines < LINES_PER_BANDWIDTH

    def advice(self) -> str:
        """One line for a user when unresolved: the resonance and the ``--nperseg`` that would
        resolve it."""
        return (f"the resonance at {self.peak_hz:.4g} Hz (half-power bandwidth "
                f"{self.bandwidth_hz:.3g} Hz) spans {self.lines:.1f} lines at nperseg "
                f"{self.nperseg}: leakage biases the estimate; --nperseg {self.needed} would "
                f"resolve it with a record of {MIN_SEGMENTS * self.needed} samples or more")


def longest_nperseg(n: int) -> int:
    """Longest segment `resolving_nperseg` gives an ``n``-sample record: the largest power of
    two leaving `MIN_SEGMENTS` segments, never shorter than `default_nperseg`."""
    return max(default_nperseg(n), 2 ** int(np.log2(max(n // MIN_SEGMENTS, 1))))


def narrowest_peak(freqs: np.ndarray, power: np.ndarray,
                   trusted: np.ndarray | None = None) -> tuple[float, float]:
    """Frequency and half-power bandwidth of the narrowest resolved peak of ``power``.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Uniform lines, Hz.
    power : ndarray, shape (n_f,)
        ``|H|^2`` summed over the FRF's entries.
    trusted : ndarray of bool, shape (n_f,), optional
        Lines whose estimate is good enough to read a peak at (high coherence); peaks at
        other lines are ripples of the estimate's error, not resonances.

    Returns
    -------
    (peak_hz, bandwidth_hz) : float
        ``nan`` for both when no peak has both half-power points inside ``freqs``.
    """
    best = (np.nan, np.inf)
    floor = PEAK_FLOOR * power.max()
    df = freqs[1] - freqs[0]
    for i in np.flatnonzero((power[1:-1] > power[:-2]) & (power[1:-1] >= power[2:])) + 1:
        half = power[i] / 2
        if power[i] < floor or (trusted is not None and not trusted[i]):
            continue
        left, right = _crossing(power, freqs, i, half, -1), _crossing(power, freqs, i, half, 1)
        if left is None or right is None or right - left < MIN_READ_LINES * df:
            continue                     # narrower than the window's main lobe: a ripple
        if right - left < best[1]:
            best = (float(freqs[i]), right - left)
    return best if np.isfinite(best[1]) else (np.nan, np.nan)


def _crossing(power: np.ndarray, freqs: np.ndarray, i: int, half: float,
              step: int) -> float | None:
    """Where ``power`` falls through ``half`` walking from peak ``i`` (linear interpolation);
    None when it rises above the peak or leaves the lines first."""
    j = i
    while 0 <= j + step < power.size:
        j += step
        if power[j] > power[i]:
            return None
        if power[j] < half:
            t = (power[j - step] - half) / (power[j - step] - power[j])
            return float(freqs[j - step] + t * (freqs[j] - freqs[j - step]))
    return None


def resolving_nperseg(force: np.ndarray, response: np.ndarray, fs: float,
                      band: tuple[float, float] | None = None,
                      kind: str = "displacement") -> Resolution:
    """Welch segment length whose lines resolve the narrowest resonance of H1.

    Starts from `default_nperseg` and doubles while the narrowest half-power bandwidth of
    ``sum |H1|^2`` in ``band`` reads fewer than ``LINES_PER_BANDWIDTH + WINDOW_WIDENING`` lines and the record
    still holds `MIN_SEGMENTS` segments. An unresolved peak reads wider than it is, so the
    bandwidth is read again at each length.

    Parameters
    ----------
    force : ndarray, shape (n, n_in)
    response : ndarray, shape (n, n_out)
    fs : float
        Sample rate, Hz.
    band : (lo, hi), optional
        Where to look for resonances, Hz (default: 0..fs/2).
    kind : {"displacement", "velocity", "acceleration"}
        Response kind: peaks are read on the receptance (an accelerance lifts the ripples of
        a nonlinear structure's H1 at high frequencies by ``f^4``).

    Returns
    -------
    Resolution
    """
    f = np.asarray(force, dtype=float).reshape(len(force), -1)
    y = np.asarray(response, dtype=float).reshape(len(response), -1)
    n, n_in = f.shape
    nps = default_nperseg(n)
    last = (np.nan, np.nan)            # the peak read at the previous length
    while True:
        spec = spectral_matrix(np.column_stack([f, y]), fs, nperseg=nps, band=band)
        S_xr, S_rr = spec.S[:, n_in:, :n_in], spec.S[:, :n_in, :n_in]
        H = h1(S_xr, S_rr) / np.maximum(2 * np.pi * spec.freqs, 1e-300)[:, None, None] \
            ** KIND_ORDER[kind]
        coh = multiple_coherence(spec.auto()[:, n_in:], S_xr, S_rr)
        res = _frf_resolution(spec.freqs, H, coh, spec.n_avg, nps, fs, last)
        if np.isnan(res.bandwidth_hz) or res.lines >= LINES_PER_BANDWIDTH + WINDOW_WIDENING \
                or 2 * nps > longest_nperseg(n):
            return res
        last = (res.peak_hz, res.bandwidth_hz)
        nps *= 2


def _frf_resolution(freqs: np.ndarray, H: np.ndarray, coherence: np.ndarray, n_avg: float,
                   nperseg: int, fs: float,
                   last: tuple[float, float] = (np.nan, np.nan)) -> Resolution:
    """The narrowest resonance of an FRF estimate and the segment length that resolves it.

    Parameters
    ----------
    freqs : ndarray, shape (n_f,)
        Uniform lines, Hz.
    H : ndarray, shape (n_f, n_out, n_in)
        Receptance estimate (peaks are read on ``sum |H|^2``).
    coherence : ndarray, shape (n_f, n_out)
        Multiple coherence of each output: peaks whose |H| random error
        ``sqrt((1 - g^2) / (2 g^2 n_avg))`` exceeds `MAX_RANDOM_ERROR` are ripples.
    n_avg : float
        Averages behind the estimate.
    nperseg : int
        Welch segment length the estimate was made with.
    fs : float
        Sample rate, Hz.
    last : (peak_hz, bandwidth_hz), optional
        A reading at a shorter segment, kept when none is trusted at this one (fewer
        averages can hide a peak read before).

    Returns
    -------
    Resolution
        ``needed`` is the power of two whose lines span ``LINES_PER_BANDWIDTH +
        WINDOW_WIDENING`` of the bandwidth as read (never below ``nperseg``).
    """
    g2 = np.clip(coherence.max(axis=1), 1e-12, 1.0)
    error = np.sqrt((1 - g2) / (2 * g2 * n_avg))
    power = (np.abs(H) ** 2).sum(axis=(1, 2))
    peak, bw = narrowest_peak(freqs, power, error <= MAX_RANDOM_ERROR)
    if np.isnan(bw):
        peak, bw = last
        if np.isnan(bw):
            return Resolution(nperseg, peak, bw, np.nan, nperseg, fs)
    wanted = LINES_PER_BANDWIDTH + WINDOW_WIDENING
    needed = int(2 ** np.ceil(np.log2(max(wanted * fs / bw, nperseg))))
    return Resolution(nperseg, peak, bw, bw * nperseg / fs, needed, fs)


def pole_resolution(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray,
                    band: tuple[float, float], nperseg: int, fs: float) -> Resolution:
    """The narrowest mode of a linear structure in ``band`` and the segment that resolves it.

    The half-power bandwidth of a mode is ``2 |Re s| / 2 pi`` Hz (``2 zeta f_n``) for its
    pole ``s`` (eigenvalue of ``[[0, I], [-M^-1 K, -M^-1 C]]``): exact, where one read off a
    measured FRF is widened by the window and, for a nonlinear structure, by the
    nonlinearity (and one read off the reverse path's underlying linear FRF is ragged: on
    the paper's 3-DOF case at 0.28x damping, 7 averages, it read 0.26 Hz for 0.71 Hz).
    Undamped modes (no bandwidth) are not read.

    Parameters
    ----------
    mass, damping, stiffness : ndarray, shape (n, n)
    band : (lo, hi)
        Modes whose damped frequency lies in it are read, Hz.
    nperseg : int
        Segment length to report the lines at.
    fs : float
        Sample rate, Hz.

    Returns
    -------
    Resolution
        ``needed``: the power of two whose lines span `POLE_LINES` of the true bandwidth
        (never below ``nperseg``); nan bandwidth when no damped mode is in band.
    """
    n = mass.shape[0]
    minv = np.linalg.inv(mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ stiffness, -minv @ damping]])
    s = np.linalg.eigvals(a)
    f, bw = np.abs(s.imag) / (2 * np.pi), -s.real / np.pi
    ok = (f >= band[0]) & (f <= band[1]) & (bw > 0)
    if not ok.any():
        return Resolution(nperseg, np.nan, np.nan, np.nan, nperseg, fs)
    i = np.flatnonzero(ok)[np.argmin(bw[ok])]
    needed = int(2 ** np.ceil(np.log2(max(POLE_LINES * fs / bw[i], nperseg))))
    return Resolution(nperseg, float(f[i]), float(bw[i]), float(bw[i] * nperseg / fs), needed, fs)
