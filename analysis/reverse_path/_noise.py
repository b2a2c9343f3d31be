"""Sensor noise on the response: instrumental variables and periodic-random estimation.

Noise on the measured response enters the basis functions (errors in variables) and biases
H1 low. Two treatments:

Random records (`iv_passes`)
    ``H = G_XZ G_RZ^-1`` with instruments ``Z``: the same basis functions evaluated on the
    response *simulated* from the measured force through the candidate model with the
    current estimates, so they are independent of the sensor noise at every lag (a delayed
    copy of the measured response is not: a delay only multiplies its spectrum by a phase).
    The noise variance, read off the white floor of the response spectrum above the band,
    removes the conditional bias of each basis (`basis.Basis.debias`), and the velocity is
    low-passed where its spectrum sinks into that floor.

Periodic-random records (`periodic_reverse_path`)
    The test engineer's route (Pintelon & Schoukens): ``M`` realizations of a random-phase
    multisine, each applied for transient + ``P`` steady periods. Averaging periods divides
    the noise variance by ``P``; one DFT per period at the exact lines (rectangular window,
    no leakage) gives independent frequency lines; the variance across periods is a
    nonparametric noise estimate. The steady periods are split into two interleaved halves
    A and B: the regressors ``R`` and outputs ``X`` of one half are paired with the
    instruments ``Z`` = regressors of the other half, whose noise is independent of both
    (``H = sum X Z^H (sum R Z^H)^-1`` over realizations and both pairings, per line). Each
    half's bases are debiased with that half's measured noise variance; the instruments are
    formed from a Wiener-smoothed half average (per-line gain from the measured signal and
    noise spectra), which strengthens them without biasing anything. Needs more
    realizations than inputs (forces + bases) at every line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.ndimage
import scipy.signal
import scipy.stats

from .. import models as bas    # the reverse-path basis functions of a kind
from ..models import Model, restoring_force
from ..errors import InputError, ModelError
from ..plant import Plant, PlantError
from ..recordings import (DEFAULT_TRANSIENT_PERIODS, KIND_ORDER, Recording, excitation_band,
                          period_spectra, periodic_kinematics, steady_periods)
from ._core import (EDGE_CAP, EDGE_RUN, EDGE_SNR, Z95, ReversePathResult, _alias_upsampling,
                    _channels, _coefficients, _estimate, _force_span, _Processing)
from ..spectral import Spectra, excited_lines, spectral_matrix

WEAK_F = 10.0            # first-stage F below which an instrument is weak (Staiger-Stock)
BURIED = 0.5             # deformation noise std per period / its rms that biases the estimate
BURIED_RANDOM = 0.1      # the same for random records (whole-record noise std / noise-free rms)
NOISE_THRESHOLD = 5e-3   # relative sensor-noise std above which noise="auto" uses "iv"
IV_PASSES = 2            # instrument refinements (each re-simulates with the latest estimate)
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
               warnings: list[str]) -> tuple[dict[str, Any], list[np.ndarray | None]]:
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
    return {"method": chosen, "relative_std": None if rel is None else rel.tolist(),
            "lowpass_hz": min(c for _, c, _ in found) if chosen == "iv" else None}, floors


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


def iv_passes(result: ReversePathResult, model: Model, built, unknown, known,
              welch: dict[str, Any], info: dict[str, Any],
              warnings: list[str]) -> ReversePathResult:
    """Instrumental-variable refinements: simulate, form instruments, re-estimate."""
    n_dof = model.n_dof
    for _ in range(IV_PASSES):
        try:
            current = result.estimated_model(model)
            parts = []
            for rec, proc, channels in built:
                out = Plant(current, rec.fs, rec.force_dofs).run(rec.force)
                sim = {"displacement": out.displacement, "velocity": out.velocity,
                       "acceleration": out.acceleration}[proc.kind]
                z, _ = _channels(sim, rec.force, rec.force_dofs, proc, unknown, known, [],
                                 None)
                parts.append(spectral_matrix([*channels, *z[n_dof:]], rec.fs, **welch))
        except (PlantError, ModelError) as exc:
            warnings.append(f"noise correction skipped: the candidate with the current "
                            f"estimates cannot be simulated ({exc}); estimates biased low")
            info["method"] = "none"
            return result
        scratch: list[str] = []
        spec = Spectra.pool(parts)
        solved = _iv_solution(spec, n_dof, result.force_dofs.size, len(result.inputs))
        result = _estimate(spec, n_dof, result.force_dofs, unknown, result.inputs,
                           result.band, "direct", scratch, solved)
    warnings.extend(scratch)
    coh = result.noise.get("instrument_coherence", [])
    info["instrument_coherence"] = coh
    if coh and min(coh) < 0.3:
        warnings.append(f"weak instruments (median coherence with the regressors "
                        f"{min(coh):.2f}): wide intervals; check the candidate's linear part "
                        "or record longer")
    return result


def _iv_solution(spec: Spectra, n_dof: int, n_in: int, n_r: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """IV transfer matrix, row covariance and residual variance from ``[X, R, Z]`` spectra."""
    S = spec.S
    xs, rs, zs = slice(0, n_dof), slice(n_dof, n_dof + n_r), slice(n_dof + n_r, None)
    H, cov, resid = _iv(S, xs, rs, zs)
    S_xx = np.einsum("fii->fi", S[:, xs, xs]).real
    sigma2 = np.maximum(resid, 1e-15 * S_xx) / max(spec.n_eff - n_r, 1.0)
    auto = np.einsum("fii->fi", S).real
    coh = [float(np.median(np.abs(S[:, n_dof + k, n_dof + n_r + k]) ** 2
                           / (auto[:, n_dof + k] * auto[:, n_dof + n_r + k])))
           for k in range(n_in, n_r)]
    return H, cov, sigma2, {"instrument_coherence": coh}


def _iv(S: np.ndarray, xs: slice, rs: slice, zs: slice
        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Instrumental-variable ``H = S_XZ S_RZ^-1``, its row covariance matrix, residual PSD.

    With ``A = S_RZ^-1`` the row error ``dh = s_EZ A`` has covariance
    ``sigma^2 A^H S_ZZ A / n`` (in the index order `_form_covariance` expects); ``sigma^2``
    is the auto-spectrum of the residual ``X - H R``.
    """
    S_xz, S_rz, S_zz = S[:, xs, zs], S[:, rs, zs], S[:, zs, zs]
    S_xx, S_xr, S_rr = S[:, xs, xs], S[:, xs, rs], S[:, rs, rs]
    try:
        a = np.linalg.inv(S_rz)
    except np.linalg.LinAlgError:
        raise InputError("the instruments do not span the inputs (singular G_RZ): an input "
                         "is repeated or not excited; remove it or use noise='none'") from None
    H = S_xz @ a
    cov = a.conj().transpose(0, 2, 1) @ S_zz @ a
    hs = H @ S_xr.conj().transpose(0, 2, 1)
    resid = (np.einsum("fii->fi", S_xx).real - 2 * np.einsum("fii->fi", hs).real
             + np.einsum("fya,fab,fyb->fy", H, S_rr, H.conj()).real)
    return H, cov, resid


# --- periodic-random (multisine) records ---------------------------------------------------

TRANSIENT_LEVEL = 1e-3  # rms of a left-over transient, relative to the response, that warns


@dataclass(frozen=True)
class Layout:
    """Split of a periodic-random record: samples per period, transient periods and
    realizations (consecutive blocks, each with its own random phases)."""

    period: int
    transient: int
    realizations: int


def periodic_layout(rec: Recording, period: int | None, transient: int | None,
                    realizations: int | None) -> Layout | None:
    """The record's layout from the arguments, else its ``layout``; None for random data."""
    own = rec.layout
    p = period if period is not None else (own.period if own else None)
    if p is None:
        return None
    t = transient if transient is not None else (own.transient_periods if own
                                                 else DEFAULT_TRANSIENT_PERIODS)
    m = realizations if realizations is not None else (own.realizations if own else 1)
    return Layout(int(p), int(t), int(m))


@dataclass
class _Formed:
    """Lines of one set of period averages: outputs ``X`` (M, n_f, n_dof), inputs ``R``."""

    X: np.ndarray
    R: np.ndarray


def periodic_reverse_path(recs: list[tuple[Recording, str]], layouts: list[Layout | None],
                          model: Model, unknown, known, band: tuple[float, float] | None,
                          antialias: str, force_hold: str | None, noise: str,
                          warnings: list[str]) -> ReversePathResult:
    """Reverse path on periodic-random records (module docstring); pools all realizations.

    Raises
    ------
    InputError
        Mixed periodic and random records, differing periods, too few realizations for the
        number of inputs, or ``noise="iv"`` with a single steady period.
    """
    if any(lay is None for lay in layouts):
        raise InputError("some records are periodic (a period layout) and some are not; "
                         "analyse them separately")
    n = layouts[0].period
    rec0 = recs[0][0]
    fs, fdofs = float(rec0.fs), rec0.force_dofs
    if any(lay.period != n for lay in layouts):
        raise InputError("the periodic records differ in period length; analyse them "
                         "separately")
    blocks = [(rec, kind, steady_periods(rec.force, n, transient_periods=lay.transient,
                                         realizations=lay.realizations),
               steady_periods(rec.response, n, transient_periods=lay.transient,
                              realizations=lay.realizations))
              for (rec, kind), lay in zip(recs, layouts)]
    freqs = np.fft.rfftfreq(n, 1 / fs)
    fpow, fvar = _force_lines(blocks)
    if band is None:
        band = excitation_band(freqs, fpow)
    lo, hi = float(band[0]), float(band[1])
    if not 0 <= lo < hi <= fs / 2:
        raise InputError(f"band {lo:g}-{hi:g} Hz must satisfy 0 <= lo < hi <= fs/2 = "
                         f"{fs / 2:g}")
    inband = (freqs >= lo) & (freqs <= hi) & (freqs > 0)
    if not inband.any():
        raise InputError(f"band {lo:g}-{hi:g} Hz holds no line of the {n}-sample period")
    picked = excited_lines(freqs, fpow, fvar, band=(lo, hi))
    idx = picked.lines
    if idx.size == 0:
        raise InputError(f"the force excites no line of the {n}-sample period in "
                         f"{lo:g}-{hi:g} Hz; check the band")
    if picked.note():
        warnings.append(picked.note())
    n_per = min(yp.shape[1] for *_, yp in blocks)
    split = noise == "iv" or (noise == "auto" and n_per >= 2)
    if split and n_per < 2:
        raise InputError("noise='iv' on periodic records needs 2 or more steady periods per "
                         "realization; record more periods")
    halves, fulls, info = [], [], []
    for rec, kind, fp, yp in blocks:
        proc = _Processing(fs, kind, (lo, hi), antialias,
                           force_hold or rec.force_hold, None)
        h, full, stats = _periodic_inputs(proc, fp, yp, idx, unknown, known, fdofs,
                                          split, warnings)
        halves.append(h)
        fulls.append(full)
        info.append(stats)
    labels = stats["labels"]
    inputs = [f"force@{d}" for d in fdofs] + labels
    n_r, n_real = len(inputs), sum(f.X.shape[0] for f in fulls)
    if n_real <= n_r:
        raise InputError(f"{n_real} realization(s) for {n_r} inputs (forces and bases): "
                         f"periodic reverse path needs at least {n_r + 1} realizations with "
                         "different random phases")
    if split:
        a = [h[0] for h in halves]
        b = [h[1] for h in halves]
        X = np.concatenate([f.X for f, _ in a + b])
        R = np.concatenate([f.R for f, _ in a + b])
        Z = np.concatenate([z for _, z in b + a])
    else:
        X = np.concatenate([f.X for f in fulls])
        R = Z = np.concatenate([f.R for f in fulls])
    H, cov, sigma2, coh = _lines_iv(X, R, Z)
    if split:
        _weak_instruments(coh[fdofs.size:], np.max([s["buried"] for s in info], axis=0),
                          X.shape[0], n_r, unknown, warnings)
    C = np.concatenate([np.concatenate([f.X, f.R], axis=2) for f in fulls])
    S = np.einsum("ofa,ofb->fab", C, C.conj()) * (2 / (fs * n * n_real))
    spec = Spectra(freqs[idx], S, n_real, float(n_real), 1.0, fs, n, window=None)
    first: list[str] = []
    result = _estimate(spec, model.n_dof, fdofs, unknown, inputs, (lo, hi), "direct",
                       first, (H, cov, sigma2, {}))
    warnings.extend(first)
    _jackknife(result, X, R, Z, n_real, fdofs, unknown)
    result.noise = {"method": "periodic-iv" if split else "periodic",
                    "periods": n_per, "realizations": n_real,
                    "relative_std": _worst([s["relative_std"] for s in info]),
                    "instrument_coherence": coh[fdofs.size:] if split else []}
    result.warnings = sorted(set(warnings), key=warnings.index)
    return result


def _force_lines(blocks: list) -> tuple[np.ndarray, np.ndarray | None]:
    """Force power of the period averages per line, summed over records, realizations and
    forces, and the variance of that average from the spread over the periods (None with a
    single steady period): the inputs of `analysis.spectral.excited_lines`."""
    power, var = 0.0, 0.0
    for _, _, fp, _ in blocks:                 # fp: (realizations, periods, n, forces)
        spec = np.fft.rfft(fp, axis=2)
        mean = spec.mean(axis=1)
        power = power + (np.abs(mean) ** 2).sum(axis=(0, 2))
        n_p = fp.shape[1]
        if n_p < 2 or var is None:
            var = None
            continue
        dev = np.abs(spec - mean[:, None]) ** 2
        var = var + dev.sum(axis=(0, 1, 3)) / ((n_p - 1) * n_p)
    return power, var


def _weak_instruments(coh: list[float], buried: np.ndarray, n_obs: int, n_r: int, unknown,
                      warnings: list[str]) -> None:
    """Warn for each basis whose deformation is buried in sensor noise: its noise std per
    period above `BURIED` of its rms, or a weak instrument, first-stage
    ``F = (n_obs - n_r) c / (1 - c)`` below `WEAK_F` (``c`` its median coherence with its
    instrument over the lines, ``n_obs`` observations per line).

    There the per-line IV keeps a bias towards H1 (towards zero) that neither the jackknife
    correction nor the interval covers. Measured (cubic joint p = 2e9, 4 realizations of 2
    steady periods): intervals covered the truth up to a deformation noise ratio of 0.3 (3-DOF
    chain, FE beam at 3 of 21 DOFs); at 0.56 (chain, accelerometers with 3 % noise: 1.06e9
    [0.42e9, 1.71e9], F = 31) and 1.0 (beam, accelerometers with 1 % noise, whose noise grows
    as 1/f^2 once integrated: 0.16e9 [-0.23e9, 0.55e9], F = 2.4) they did not.
    """
    for c, ratio, (i, el, _, fn) in zip(coh, buried, unknown):
        f_stat = (n_obs - n_r) * c / max(1.0 - c, 1e-12)
        if f_stat < WEAK_F or ratio > BURIED:
            warnings.append(
                f"element {i} ({el.kind}): deformation buried in sensor noise (noise "
                f"{100 * ratio:.0f} % of its rms per period; the instrument of basis "
                f"{fn.name}: coherence {c:.2f}, F = {f_stat:.1f} over {n_obs} observations "
                "per line): the estimate may be biased towards zero beyond its interval "
                "(integrated accelerometer noise grows as 1/f^2); record more periods or "
                "realizations, or use quieter or displacement sensors at the element's ends")


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


def _jackknife(result: ReversePathResult, X: np.ndarray, R: np.ndarray, Z: np.ndarray,
               n_real: int, fdofs: np.ndarray, unknown) -> None:
    """Delete-one-realization jackknife of every coefficient (in place).

    Realizations are independent replicates, so the jackknife sees every error source,
    including the correlation between lines that the noise on the bases causes (the
    line-based variance misses it). The interval is the wider of the line-based one and
    ``t_(M-1) x`` the jackknife standard error. The value is corrected for the leading
    ``1/M`` bias of the per-line IV (few realizations per line: weak-instrument bias towards
    H1, several percent for a deformation buried in noise), ``M p - (M-1) mean(p_-m)``.
    """
    if n_real - 1 <= R.shape[2] * n_real // X.shape[0]:
        return                                    # no residual degrees of freedom left
    vals = []
    for r in range(n_real):
        keep = np.ones(X.shape[0], dtype=bool)
        keep[r::n_real] = False                   # both halves of realization r
        H, cov, s2, _ = _lines_iv(X[keep], R[keep], Z[keep])
        vals.append([c.value for c in _coefficients(H, cov, s2, fdofs, unknown, 1.0)])
    vals = np.array(vals)
    mean = vals.mean(axis=0)
    std_j = np.sqrt((n_real - 1) / n_real * ((vals - mean) ** 2).sum(axis=0))
    t = float(scipy.stats.t.ppf(0.975, n_real - 1))
    for c, m, sj in zip(result.coefficients, mean, std_j):
        c.value = float(n_real * c.value - (n_real - 1) * m)
        half = max(Z95 * c.std, t * sj)
        c.std = float(max(c.std, sj))
        c.ci95 = (c.value - half, c.value + half)


def _worst(rel: list[list[float] | None]) -> list[float] | None:
    known_rel = [r for r in rel if r is not None]
    return np.max(known_rel, axis=0).tolist() if known_rel else None


def _lines_iv(X: np.ndarray, R: np.ndarray, Z: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """Per-line IV over observations (axis 0): transfer, row covariance, residual variance.

    ``H = S_XZ S_RZ^-1`` with sums over observations; the row covariance is
    ``sigma^2 A^H S_ZZ A`` (``A = S_RZ^-1``, `_form_covariance` order) with ``sigma^2`` the
    residual variance per observation. Also the median coherence of each input with its
    instrument.
    """
    S_xz = np.einsum("ofy,ofa->fya", X, Z.conj())
    S_rz = np.einsum("ofa,ofb->fab", R, Z.conj())
    S_zz = np.einsum("ofa,ofb->fab", Z, Z.conj())
    try:
        a = np.linalg.inv(S_rz)
    except np.linalg.LinAlgError:
        raise InputError("the inputs are linearly dependent over the realizations at some "
                         "line (a repeated basis or an unexcited force); remove it") from None
    H = S_xz @ a
    resid = X - np.einsum("fya,ofa->ofy", H, R)
    dof = X.shape[0] - R.shape[2]
    sigma2 = (np.abs(resid) ** 2).sum(axis=0) / dof
    cov = a.conj().transpose(0, 2, 1) @ S_zz @ a
    s_rr = np.einsum("ofa,ofa->fa", R, R.conj()).real
    s_zz = np.einsum("faa->fa", S_zz).real
    coh = np.abs(np.einsum("faa->fa", S_rz)) ** 2 / (s_rr * s_zz)
    return H, cov, sigma2, np.median(coh, axis=0).tolist()


def _periodic_edge(sig: np.ndarray, noi: np.ndarray, fs: float, period: int,
                   band: tuple[float, float]) -> float:
    """Integration high-pass of a periodic record from its lines' signal over noise (the
    period spread): the lowest line of ``band`` from which every channel stands `EDGE_SNR`
    above its noise over `EDGE_RUN` lines, at most `EDGE_CAP` of the band's top."""
    f = np.fft.rfftfreq(period, 1 / fs)
    inband = (f >= band[0]) & (f <= band[1])
    ok = (sig >= EDGE_SNR * np.maximum(noi, 1e-300)).all(axis=1)[inband]
    run = np.convolve(ok, np.ones(EDGE_RUN), "valid") == EDGE_RUN
    first = f[inband][int(np.argmax(run))] if run.any() else band[1]
    return float(min(first, EDGE_CAP * band[1]))


def _periodic_inputs(proc: _Processing, fp: np.ndarray, yp: np.ndarray, idx: np.ndarray,
                     unknown, known, fdofs: np.ndarray, split: bool, warnings: list[str]
                     ) -> tuple[list[tuple[_Formed, np.ndarray]], _Formed, dict[str, Any]]:
    """Lines of the half averages (A, B; with their smoothed instruments) and of the full
    average of one record.

    ``fp``, ``yp``: steady periods (M, P, N, ch) of force and response.
    """
    fs, n_p = proc.fs, yp.shape[1]
    rel, wiener = None, None
    if n_p >= 2:
        sig, noi = period_spectra(yp)
        # smoothed over ~1 % of the lines: single noise lines must not pass as signal
        width = max(9, sig.shape[0] // 100)
        sig, noi = (scipy.ndimage.uniform_filter1d(a, width, axis=0) for a in (sig, noi))
        # Wiener gain for a half average (noise P / (P // 2) times that of the full one);
        # it shapes the instruments only, so it biases nothing
        noi_half = noi * n_p / (n_p // 2)
        sig_half = sig + noi_half - noi
        wiener = np.maximum(sig_half - noi_half, 0.0) / np.maximum(sig_half, 1e-300)
        noise_std = np.sqrt(yp.var(axis=1, ddof=1).mean(axis=(0, 1)))
        rel = (noise_std / np.maximum(yp.std(axis=(0, 1, 2)), 1e-300)).tolist()
        _transient_check(yp, warnings)
    # as the Welch route does: integrated records lose the lines below half the band, and
    # those where the averaged record is under 10x its noise (`_core.noise_edge`)
    hp = proc.band[0] / 2 if proc.kind != "displacement" else 0.0
    if hp and n_p >= 2:
        hp = max(hp, _periodic_edge(sig, noi, fs, yp.shape[2], proc.band))
    x_p, v_p = periodic_kinematics(yp, fs, proc.kind, highpass=hp)
    sets = [slice(0, None, 2), slice(1, None, 2)] if split else []
    # basis noise variance per period, per unknown element (variance across periods)
    var_p = [(x_p if fn.variable == "x" else v_p) @ el.w for _, el, _, fn in unknown]
    # noise std of each deformation per period over its rms (for `_weak_instruments`)
    buried = [float(np.sqrt(u.var(axis=1, ddof=1).mean()) / max(u.mean(axis=1).std(), 1e-300))
              if n_p >= 2 else 0.0 for u in var_p]
    var_p = [float(u.var(axis=1, ddof=1).mean()) if n_p >= 2 else 0.0 for u in var_p]
    x_m, v_m = x_p[0].mean(axis=0), v_p[0].mean(axis=0)
    upsample = [_alias_upsampling(fn, (x_m if fn.variable == "x" else v_m) @ el.w, i, proc,
                                  warnings, periodic=True) for i, el, _, fn in unknown]
    gain = np.ones(idx.size) if proc.hold == "none" else np.sinc(idx / yp.shape[2]) ** 2
    labels: list[str] = []

    def formed(sel: slice, debias: bool, smooth: np.ndarray | None = None) -> _Formed:
        count = len(range(n_p)[sel])
        if smooth is None:
            x, v = x_p[:, sel].mean(axis=1), v_p[:, sel].mean(axis=1)
        else:
            x, v = periodic_kinematics(yp[:, sel].mean(axis=1), fs, proc.kind,
                                       weights=smooth, highpass=hp)
        force = np.fft.rfft(fp[:, sel].mean(axis=1), axis=1)[:, idx] * gain[:, None]
        cols = []
        labels.clear()
        for i, el in known:
            g = _periodic_force(el, x @ el.w, v @ el.w)[:, idx, None]
            a = _force_span(el.w, fdofs)
            if a is not None:
                force = force - g * a     # a known force on forced DOFs: subtract it
            else:
                cols.append(-g)
                labels.append(f"-{el.kind}@{i}(known)")
        for (i, el, _, fn), s2, up in zip(unknown, var_p, upsample):
            u = (x if fn.variable == "x" else v) @ el.w
            if debias and fn.debias is None and s2 / count > (0.05 * u.std()) ** 2:
                warnings.append(f"basis {fn.name} of element {i} has no noise correction: "
                                "its estimate stays biased by the noise")
            b = bas.evaluate(fn, u, up, s2 / count if debias else 0.0, periodic=True)
            cols.append(-np.fft.rfft(b, axis=1)[:, idx, None])
            labels.append(f"-{fn.name}@{i}")
        X = np.fft.rfft(x, axis=1)[:, idx]
        return _Formed(X, np.concatenate([force] + cols, axis=2))

    halves = [(formed(s, True), formed(s, False, wiener).R) for s in sets]
    full = formed(slice(None), split)
    return halves, full, {"labels": list(labels), "relative_std": rel, "buried": buried}


def _periodic_force(el, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Lines (all of them) of a known element's steady-state force, per realization."""
    n = u.shape[1]
    out = []
    for um, vm in zip(u, v):
        # two periods: memory elements settle on their periodic loop during the first
        g = restoring_force(el.kind, el.params, np.tile(um, 2), np.tile(vm, 2))[0][n:]
        out.append(np.fft.rfft(g))
    return np.array(out)


def _transient_check(yp: np.ndarray, warnings: list[str]) -> None:
    """Warn when the first steady period still differs from the last beyond the noise.

    The mean square of their difference is ``2 sigma^2`` for a settled response; the excess
    over that (allowing five standard errors of the estimate) is the transient's power.
    """
    if yp.shape[1] < 3:
        return
    d2 = ((yp[:, 0] - yp[:, -1]) ** 2).mean(axis=(0, 1))
    s2 = yp.var(axis=1, ddof=1).mean(axis=(0, 1))
    power = (yp ** 2).mean(axis=(0, 1, 2))
    tol = 5 * 2 * s2 * np.sqrt(2 / (yp.shape[0] * yp.shape[2]))
    ratio = np.sqrt(np.maximum(d2 - 2 * s2 - tol, 0.0) / np.maximum(power, 1e-300))
    if ratio.max() > TRANSIENT_LEVEL:
        warnings.append(f"the response has not settled: the first steady period differs from "
                        f"the last by {100 * ratio.max():.2g} % of the rms beyond the noise; "
                        "drop more transient periods (transient_periods)")
