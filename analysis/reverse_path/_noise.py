"""Sensor noise on a random record's response: its white floor, the treatment chosen and
what it leaves in the bases.

Noise on the measured response enters the basis functions (errors in variables) and biases
H1 low. The white floor of the response spectrum above the band gives the noise level; with
it the estimator chooses the instrumental variables of `._iv` (``noise="auto"``), debiases
each basis (`basis.Basis.debias`) with the noise variance carried through the integration,
and warns when a deformation is buried in the noise.
"""

from __future__ import annotations


import numpy as np

from ..recordings import KIND_ORDER, Recording
from ..spectral import spectral_matrix
from ._core import _Processing
from ._documents import NoiseInfo

BURIED_RANDOM = 0.1      # deformation noise std (whole record) / its noise-free rms that biases
NOISE_THRESHOLD = 5e-3   # relative sensor-noise std above which noise="auto" uses "iv"
FLOOR_SEGMENTS = 128     # Welch segments averaged at most for the sensor-noise floor


def noise_floor(response: np.ndarray, fs: float, band_hi: float,
                cutoff: bool = True) -> tuple[np.ndarray | None, float, np.ndarray | None]:
    """White sensor-noise density per channel (one-sided, unit^2/Hz) or None; cut-off, Hz;
    the response's standard deviation over the samples read (None with no floor).

    The floor is read off the response spectrum between ``max(1.2 band_hi, 0.55 fs/2)`` and
    ``0.9 fs/2``, where the structure's own response has rolled off: the smaller median of
    the two halves of that range (corrected to a mean), None unless both agree within 1.5x
    (white). The spectrum averages at most `FLOOR_SEGMENTS` segments spread over the record.
    The cut-off is the highest frequency where some channel still exceeds twice its floor:
    above it the record holds noise only. ``cutoff=False`` skips it (returns ``fs/2``) and
    accumulates the spectrum on the floor's range only.
    """
    lo_f, hi_f = max(1.2 * band_hi, 0.55 * fs / 2), 0.9 * fs / 2
    n = response.shape[0]
    nps = min(4096, n)
    f = np.fft.rfftfreq(nps, 1 / fs)
    if np.count_nonzero((f >= lo_f) & (f <= hi_f)) < 8:
        return None, fs / 2, None
    band = None if cutoff else (lo_f, hi_f)
    if n < (FLOOR_SEGMENTS + 1) * nps // 2:
        read = response
        spec = spectral_matrix(read, fs, nperseg=nps, band=band)  # = scipy.signal.welch
    else:
        # a median over hundreds of lines of FLOOR_SEGMENTS averages is good to about 1 %;
        # whole-record Welch would transform every sample for nothing better
        starts = np.linspace(0, n - nps, FLOOR_SEGMENTS).astype(int)
        read = np.concatenate([response[i:i + nps] for i in starts])
        spec = spectral_matrix(read, fs, nperseg=nps, overlap=0.0, band=band)
    f, p = spec.freqs, spec.auto()
    idx = np.flatnonzero((f >= lo_f) & (f <= hi_f))
    half = idx.size // 2
    m1, m2 = np.median(p[idx[:half]], axis=0), np.median(p[idx[half:]], axis=0)
    if np.any(np.maximum(m1, m2) > 1.5 * np.minimum(m1, m2)):
        return None, fs / 2, None   # not a flat (white) floor: structural or aliased content
    # a line of white noise is chi^2 with nu = 2 n_eff degrees of freedom over nu: its
    # median lies (1 - 2 / (9 nu))^3 below its mean (Wilson-Hilferty)
    floor = np.minimum(m1, m2) / (1 - 2 / (9 * 2 * spec.n_eff)) ** 3
    if not cutoff:
        return floor, fs / 2, _std(read)
    above = np.flatnonzero(np.any(p > 2 * floor, axis=1))
    top = float(min(fs / 2, max(f[above[-1]] if above.size else 0.0, band_hi)))
    return floor, top, _std(read)


def noise_info(recs: list[Recording], fs: float, band_hi: float, mode: str,
               warnings: list[str]) -> tuple[NoiseInfo, list[np.ndarray | None]]:
    """Noise floors of the records and the noise treatment chosen."""
    # the cut-off only sets the "iv" low-pass: not needed when the mode rules "iv" out
    found = [noise_floor(r.response, fs, band_hi, cutoff=mode != "none") for r in recs]
    floors = [f for f, _, _ in found]
    rel = None
    if all(f is not None for f in floors):
        rel = np.max([np.sqrt(f * fs / 2) / np.maximum(std, 1e-300) for f, _, std in found],
                     axis=0)
    noisy = rel is not None and rel.max() > NOISE_THRESHOLD
    chosen = ("iv" if noisy else "none") if mode == "auto" else mode
    if chosen == "none" and noisy:
        warnings.append(f"the response carries about {100 * rel.max():.2g} % white sensor "
                        "noise (std / rms); the basis functions inherit it and the estimates "
                        "are biased low: use noise='iv' (--noise iv)")
    if chosen == "iv" and rel is None:
        warnings.append("no white noise floor above the band to read the noise level from: "
                        "basis functions are not debiased; record with fs > 2.5x the band")
    return NoiseInfo(method=chosen, relative_std=None if rel is None else rel.tolist(),
                     lowpass_hz=min(c for _, c, _ in found) if chosen == "iv" else None), floors


def _std(x: np.ndarray) -> np.ndarray:
    """Column standard deviations of an (n, n_ch) record.

    ``E[x^2] - mean^2`` in streaming BLAS passes (``np.std`` over columns is several times
    slower); the exact two-pass form when a large mean would cancel the digits of the variance.
    """
    n = x.shape[0]
    mean = np.ones(n) @ x / n
    sq = np.einsum("ij,ij->j", x, x) / n
    var = sq - mean**2
    if np.any(var < 1e-6 * sq):
        d = x - mean
        var = np.einsum("ij,ij->j", d, d) / n
    return np.sqrt(np.maximum(var, 0.0))


def noise_variances(proc: _Processing, floor: np.ndarray | None
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-DOF noise variance of the formed displacement and velocity.

    White noise of density ``floor`` in the recorded kind (order ``k``) becomes
    ``floor (2 pi f)^(2 (j - k))`` in the kind of order ``j``, integrated over the band
    kept by the high-pass and (velocity only) the low-pass.
    """
    if floor is None:
        return None
    k = KIND_ORDER[proc.kind]
    f0 = max(proc.band[0] / 2, proc.highpass) if k else 0.0
    out = []
    for j in (0, 1):
        f1 = proc.lowpass if j == 1 and proc.lowpass else proc.fs / 2
        a = 2 * (j - k)
        out.append(floor * (2 * np.pi) ** a * (f1 ** (a + 1) - f0 ** (a + 1)) / (a + 1))
    return out[0], out[1]


def buried_random(buried: list[float], unknown, warnings: list[str]) -> None:
    """Warn for each basis of a random record whose deformation is buried in sensor noise:
    its noise std (from the white floor above the band, `noise_variances`, carried through
    the integration) above `BURIED_RANDOM` of the rms of what is not noise.

    The random-record IV forms the basis from every (unaveraged) sample, so it tolerates less
    noise than the periodic route. Measured (`noise="iv"`, 2^18 samples, cubic stiffness):
    ratios up to 0.06 left every interval covering the truth (SDOF and 3-DOF, displacement
    and acceleration sensors); at 0.09-0.15 the SDOF cubic term missed in 5 of 6 seeds
    (-4 to -15 %), at 0.27 the 3-DOF one in 1 of 2 (-1.6 %), from 0.58 on every one (-98 %).
    """
    for ratio, (i, el, _, fn) in zip(buried, unknown):
        if ratio > BURIED_RANDOM:
            warnings.append(
                f"element {i} ({el.kind}): deformation buried in sensor noise (noise "
                f"{100 * ratio:.0f} % of its rms, read off the noise floor above the band; "
                f"basis {fn.name}): the estimate may be biased towards zero beyond its "
                "interval (integrated accelerometer noise grows as 1/f^2); use quieter or "
                "displacement sensors at the element's ends, or a periodic excitation "
                "(periods averaged)")
