"""A Welch segment length that resolves the record's resonances.

`default_nperseg` sizes segments by the record length alone (>= 16 segments). A lightly
damped mode has a half-power bandwidth ``2 zeta f_n`` (0.7 Hz for 0.5 % at 71 Hz) that such
lines may not resolve; the leakage of the window then biases H1 and everything estimated from
it. `resolving_nperseg` reads the narrowest bandwidth off a first H1 and doubles the segment
until it spans `LINES_PER_BANDWIDTH` lines, as long as `MIN_SEGMENTS` segments remain.
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
        H = h1(S_xr, S_rr)
        coh = multiple_coherence(spec.auto()[:, n_in:], S_xr, S_rr)
        g2 = np.clip(coh.max(axis=1), 1e-12, 1.0)
        error = np.sqrt((1 - g2) / (2 * g2 * spec.n_avg))
        power = (np.abs(H) ** 2).sum(axis=(1, 2)) \
            / np.maximum(2 * np.pi * spec.freqs, 1e-300) ** (2 * KIND_ORDER[kind])
        peak, bw = narrowest_peak(spec.freqs, power, error <= MAX_RANDOM_ERROR)
        if np.isnan(bw):
            # fewer averages can hide a peak read before: keep that (wider) reading
            peak, bw = last
            if np.isnan(bw):
                return Resolution(nps, peak, bw, np.nan, nps, fs)
        lines = bw * nps / fs
        wanted = LINES_PER_BANDWIDTH + WINDOW_WIDENING
        needed = int(2 ** np.ceil(np.log2(max(wanted * fs / bw, nps))))
        if lines >= wanted or 2 * nps > longest_nperseg(n):
            return Resolution(nps, peak, bw, lines, needed, fs)
        last = (peak, bw)
        nps *= 2
