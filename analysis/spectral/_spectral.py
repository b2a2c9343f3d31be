"""Welch spectral matrices for many channels, MIMO H1, coherences and conditioned inputs.

Convention (pinned by ``tests/analysis/spectral/test_spectral.py``)
-------------------------------------------------
``S[f, a, b] = E[Z_a(f) Z_b(f)^*]`` (one-sided, density scaling), i.e. *row times conjugate
column*. With outputs ``X`` and inputs ``R`` the H1 estimator is then
``H = S_XR S_RR^-1`` (paper eq 15), and ``scipy.signal.csd(x, y)`` (which is ``E[X^* Y]``)
equals ``S[:, y, x]``. A pure delay ``y(t) = x(t - tau)`` gives ``H = exp(-i 2 pi f tau)``.

All channel pairs come from one FFT per channel per segment (segments windowed and
transformed in cache-sized chunks, read in place from the caller's arrays) and one pass of
a compiled kernel that accumulates the upper triangle of ``Z Z^H`` over the analysis band
only, so the cost grows with the number of channels and in-band bins, not with the number
of pairs. On 10 channels x 2^20 samples it costs about as much as one bare ``rfft`` of the
whole record (`benchmarks/bench_reverse_path.py`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numba
import numpy as np
import scipy.fft
import scipy.signal

from ..errors import InputError

_CHUNK_BYTES = 1 << 21  # segments are transformed in cache-sized chunks of this many bytes
_BIN_BLOCK = 128        # frequency bins per block of the spectral-matrix product
_WDFT_FLOOR = 1e-13     # window DFT bins below this fraction of its DC value count as zero


@dataclass
class Spectra:
    """Spectral matrix of ``n_ch`` channels on a frequency grid.

    Attributes
    ----------
    freqs : ndarray, shape (n_f,)
        Frequencies, Hz (only the requested band is kept).
    S : ndarray, shape (n_f, n_ch, n_ch), complex
        ``S[f, a, b] = E[Z_a Z_b^*]``, one-sided power/cross spectral density (unit^2/Hz).
    n_avg : int
        Number of segments averaged.
    n_eff : float
        Equivalent number of independent averages (overlap-corrected, Welch 1967).
    bin_factor : float
        Variance inflation of a mean over adjacent bins caused by the window's spectral
        correlation, ``1 + 2 sum_k rho_k^2``.
    fs : float
    nperseg : int
    window : str or None
        Window of the Welch segments; None for exact-line (leakage-free) DFTs of whole
        periods.
    """

    freqs: np.ndarray
    S: np.ndarray
    n_avg: int
    n_eff: float
    bin_factor: float
    fs: float
    nperseg: int
    window: str | None = "hann"

    def block(self, rows: slice | list[int], cols: slice | list[int]) -> np.ndarray:
        """Sub-matrix ``S[:, rows, cols]`` (lists select channels in the given order)."""
        return self.S[:, rows][:, :, cols]

    def auto(self) -> np.ndarray:
        """Auto-spectra of every channel, shape (n_f, n_ch), real."""
        return np.einsum("fii->fi", self.S).real

    @staticmethod
    def pool(parts: list["Spectra"]) -> "Spectra":
        """Average spectra of several records (same fs, nperseg, band) by segment count."""
        first = parts[0]
        for p in parts[1:]:
            if p.fs != first.fs or p.nperseg != first.nperseg or p.S.shape != first.S.shape \
                    or p.window != first.window:
                raise InputError("records to pool differ in sample rate, segment length, "
                                 "window or channels; analyse them separately or resample "
                                 "first")
        total = sum(p.n_avg for p in parts)
        S = sum(p.S * (p.n_avg / total) for p in parts)
        return Spectra(first.freqs, S, total, sum(p.n_eff for p in parts), first.bin_factor,
                       first.fs, first.nperseg, first.window)


def _segments(n: int, nperseg: int, step: int) -> int:
    if nperseg > n:
        raise InputError(f"segment length {nperseg} exceeds the record length {n}; "
                         "use a shorter --nperseg or a longer record")
    return 1 + (n - nperseg) // step


def effective_averages(window: np.ndarray, step: int, n_avg: int) -> float:
    """Equivalent number of independent averages of overlapped Welch segments.

    Uses Welch's (1967) correlation of overlapping windowed segments,
    ``n_eff = K / (1 + 2 sum_k (1 - k/K) c(k)^2)``.
    """
    w2 = window**2
    total = w2.sum()
    corr = 0.0
    k = 1
    while k < n_avg and k * step < window.size:
        c = np.dot(window[k * step:], window[: window.size - k * step]) / total
        corr += (1 - k / n_avg) * c**2
        k += 1
    return n_avg / (1 + 2 * corr)


def _bin_factor(window: np.ndarray) -> float:
    """``1 + 2 sum_k rho_k^2`` with ``rho_k`` the correlation of DFT bins k apart."""
    w2 = window**2
    spec = np.abs(np.fft.rfft(w2)) / w2.sum()
    rho = spec[1:9]
    return float(1 + 2 * np.sum(rho**2))


def spectral_matrix(data: np.ndarray | Sequence[np.ndarray], fs: float, *, nperseg: int,
                    window: str = "hann", overlap: float = 0.5,
                    band: tuple[float, float] | None = None, detrend: bool = True,
                    workers: int | None = None) -> Spectra:
    """Welch spectral matrix of all channel pairs in one pass.

    Parameters
    ----------
    data : ndarray, shape (n, n_ch), or sequence of n_ch arrays of shape (n,)
        Real time series, one column per channel. A sequence of (possibly strided) 1-D
        channels is read in place, without first stacking it into one array.
    fs : float
        Sample rate, Hz.
    nperseg : int
        Segment length, samples.
    window : str
        Window name for `scipy.signal.get_window` (periodic form).
    overlap : float
        Fraction of segment overlap, 0 <= overlap < 1.
    band : (lo, hi), optional
        Keep only bins with ``lo <= f <= hi`` (saves the matrix products outside it).
    detrend : bool
        Remove each segment's mean (done in the frequency domain, exactly, on the few bins
        the window's own spectrum reaches).
    workers : int, optional
        Passed to `scipy.fft.rfft`.

    Returns
    -------
    Spectra
    """
    chans = _channels(data)
    if isinstance(nperseg, bool) or not isinstance(nperseg, (int, np.integer)) or nperseg < 8:
        raise InputError(f"segment length (nperseg) must be an integer >= 8 samples, got "
                         f"{nperseg!r}")
    if not 0 <= overlap < 1:
        raise InputError(f"overlap must be in [0, 1), got {overlap}")
    n, n_ch = chans[0].shape[0], len(chans)
    step = max(1, int(round(nperseg * (1 - overlap))))
    n_avg = _segments(n, nperseg, step)
    win = scipy.signal.get_window(window, nperseg)
    freqs = np.fft.rfftfreq(nperseg, 1 / fs)
    lo, hi = (0.0, fs / 2) if band is None else band
    keep = np.flatnonzero((freqs >= lo) & (freqs <= hi))
    if keep.size == 0:
        raise InputError(f"band {lo:g}-{hi:g} Hz holds no frequency bin at resolution "
                         f"{fs / nperseg:g} Hz; widen the band or lengthen the segments")
    k0, k1 = int(keep[0]), int(keep[-1]) + 1
    # Mean removal in the frequency domain: DFT(w * (x - m)) = DFT(w x) - m DFT(w), needed
    # only on the bins where DFT(w) is not round-off (0 and 1 for a Hann window).
    wdft = np.fft.rfft(win)
    fix = np.flatnonzero(np.abs(wdft) > _WDFT_FLOOR * np.abs(wdft[0]))
    fix = fix[(fix >= k0) & (fix < k1)] if detrend else fix[:0]
    views = [np.lib.stride_tricks.sliding_window_view(c, nperseg)[::step] for c in chans]
    chunk = int(np.clip(_CHUNK_BYTES // (8 * nperseg * n_ch), 1, n_avg))
    seg = np.empty((chunk, n_ch, nperseg))
    s_re = np.zeros((n_ch, n_ch, k1 - k0))
    s_im = np.zeros_like(s_re)
    for s0 in range(0, n_avg, chunk):
        c = min(chunk, n_avg - s0)
        for j, v in enumerate(views):
            np.multiply(v[s0:s0 + c], win, out=seg[:c, j])
        z = scipy.fft.rfft(seg[:c], axis=-1, workers=workers)
        if fix.size:
            means = np.stack([v[s0:s0 + c].mean(axis=-1) for v in views], axis=1)
            z[..., fix] -= means[..., None] * wdft[fix]
        _accumulate(z, k0, k1, s_re, s_im)
    S = np.ascontiguousarray((s_re + 1j * s_im).transpose(2, 0, 1))
    lower = np.tril_indices(n_ch, -1)
    S[:, lower[0], lower[1]] = S[:, lower[1], lower[0]].conj()    # Hermitian
    S *= 2.0 / (fs * np.sum(win**2) * n_avg)
    if k0 == 0:
        S[0] /= 2
    if nperseg % 2 == 0 and k1 == freqs.size:
        S[-1] /= 2
    return Spectra(freqs[k0:k1], S, n_avg, effective_averages(win, step, n_avg),
                   _bin_factor(win), float(fs), nperseg, window)


def _channels(data: np.ndarray | Sequence[np.ndarray]) -> list[np.ndarray]:
    """Channels of ``data`` as 1-D float views (no copy of float64 input).

    A list or tuple of ndarrays is a list of channels; anything else is an (n, n_ch) array.
    """
    if isinstance(data, (list, tuple)) and data and all(isinstance(c, np.ndarray)
                                                        for c in data):
        chans = [np.asarray(c, dtype=float) for c in data]
        if any(c.ndim != 1 or c.shape != chans[0].shape for c in chans):
            raise InputError("spectral channels must be 1-D arrays of one common length")
        return chans
    arr = np.asarray(data, dtype=float)
    if arr.ndim != 2:
        raise InputError(f"spectral data must have shape (n, channels), got {arr.shape}")
    return [arr[:, j] for j in range(arr.shape[1])]


@numba.njit(cache=True, fastmath={"contract", "reassoc"})
def _accumulate(z: np.ndarray, k0: int, k1: int, s_re: np.ndarray, s_im: np.ndarray) -> None:
    """Add ``sum_s Z[s, a, f] Z[s, b, f]^*`` for ``b >= a``, ``k0 <= f < k1`` to ``s_re/s_im``.

    Hand-written because batched BLAS on (n_ch x n_seg) matrices, one call per frequency, is
    dominated by call overhead for the few channels and thousands of bins of a Welch estimate;
    this loop works on blocks of bins (contiguous, vectorised, fused multiply-adds straight
    into the totals) and only the upper triangle.
    """
    n_s, n_ch, _ = z.shape
    re = np.empty((n_s, n_ch, _BIN_BLOCK))
    im = np.empty((n_s, n_ch, _BIN_BLOCK))
    for f0 in range(k0, k1, _BIN_BLOCK):
        m = min(_BIN_BLOCK, k1 - f0)
        for s in range(n_s):
            for a in range(n_ch):
                for j in range(m):
                    re[s, a, j] = z[s, a, f0 + j].real
                    im[s, a, j] = z[s, a, f0 + j].imag
        o = f0 - k0
        for a in range(n_ch):
            for b in range(a, n_ch):
                acc_re = s_re[a, b, o:o + m]
                acc_im = s_im[a, b, o:o + m]
                for s in range(n_s):
                    for j in range(m):
                        acc_re[j] += re[s, a, j] * re[s, b, j] + im[s, a, j] * im[s, b, j]
                        acc_im[j] += im[s, a, j] * re[s, b, j] - re[s, a, j] * im[s, b, j]


def h1(S_xr: np.ndarray, S_rr: np.ndarray) -> np.ndarray:
    """MIMO H1 estimate ``H = S_xr S_rr^-1`` per frequency (paper eq 3, 15).

    Parameters
    ----------
    S_xr : ndarray, shape (n_f, n_out, n_in)
    S_rr : ndarray, shape (n_f, n_in, n_in)

    Returns
    -------
    ndarray, shape (n_f, n_out, n_in)
    """
    # H S_rr = S_xr  <=>  S_rr^H H^H = S_xr^H, and S_rr is Hermitian.
    try:
        hh = np.linalg.solve(S_rr, S_xr.conj().transpose(0, 2, 1))
    except np.linalg.LinAlgError:
        raise InputError("input spectral matrix is singular: two inputs are fully coherent "
                         "(a duplicate channel or a basis function repeated); remove one") from None
    return hh.conj().transpose(0, 2, 1)


def ordinary_coherence(S: np.ndarray, a: int, b: int) -> np.ndarray:
    """Ordinary coherence ``|S_ab|^2 / (S_aa S_bb)`` (paper eq 4), shape (n_f,)."""
    num = np.abs(S[:, a, b]) ** 2
    den = S[:, a, a].real * S[:, b, b].real
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def multiple_coherence(S_xx: np.ndarray, S_xr: np.ndarray, S_rr: np.ndarray) -> np.ndarray:
    """Multiple coherence of each output with all inputs (paper eq 5).

    Parameters
    ----------
    S_xx : ndarray, shape (n_f, n_out)
        Output auto-spectra.
    S_xr : ndarray, shape (n_f, n_out, n_in)
    S_rr : ndarray, shape (n_f, n_in, n_in)

    Returns
    -------
    ndarray, shape (n_f, n_out)
    """
    h = h1(S_xr, S_rr)
    explained = np.einsum("foi,foi->fo", h, S_xr.conj()).real
    return np.divide(explained, S_xx, out=np.zeros_like(explained), where=S_xx > 0)


@dataclass
class Conditioned:
    """Inputs made mutually uncorrelated by ``U = Phi R`` (paper eq 17-19, Bendat).

    Attributes
    ----------
    phi : ndarray, shape (n_f, n_in, n_in)
        Unit lower-triangular transformation, in the order of the inputs given.
    S_uu : ndarray, shape (n_f, n_in)
        Auto-spectra of the conditioned inputs (``Phi S_rr Phi^H`` is diagonal).
    S_xu : ndarray, shape (n_f, n_out, n_in)
        Cross-spectra outputs x conditioned inputs, ``S_xr Phi^H``.
    coherence : ndarray, shape (n_f, n_out, n_in)
        Ordinary coherence of each output with each conditioned input; summed over inputs it
        equals the multiple coherence.
    """

    phi: np.ndarray
    S_uu: np.ndarray
    S_xu: np.ndarray
    coherence: np.ndarray

    def transfer(self) -> np.ndarray:
        """H1 from the conditioned inputs mapped back to the original ones, ``H_U Phi``."""
        h_u = self.S_xu / self.S_uu[:, None, :]
        return h_u @ self.phi


def conditioned_inputs(S_xx: np.ndarray, S_xr: np.ndarray, S_rr: np.ndarray) -> Conditioned:
    """Condition the inputs sequentially, each on all before it (Bendat 1990).

    ``S_rr = L D L^H`` with ``L`` unit lower triangular; ``Phi = L^-1`` makes
    ``S_uu = Phi S_rr Phi^H = D`` diagonal.
    """
    try:
        c = np.linalg.cholesky(S_rr)
    except np.linalg.LinAlgError:
        raise InputError("input spectral matrix is not positive definite: an input is a linear "
                         "combination of others; remove the redundant basis function") from None
    diag = np.einsum("fii->fi", c).real
    unit_l = c / diag[:, None, :]
    eye = np.broadcast_to(np.eye(S_rr.shape[1]), S_rr.shape)
    phi = np.linalg.solve(unit_l, eye)
    S_uu = diag**2
    S_xu = S_xr @ phi.conj().transpose(0, 2, 1)
    coh = np.abs(S_xu) ** 2 / (S_uu[:, None, :] * S_xx[:, :, None])
    return Conditioned(phi, S_uu, S_xu, coh)
