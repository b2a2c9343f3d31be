"""Periodic-random (multisine) records: period averaging with split-period instruments.

The test engineer's route (Pintelon & Schoukens): ``M`` realizations of a random-phase
multisine, each applied for transient + ``P`` steady periods. Averaging periods divides the
noise variance by ``P``; one DFT per period at the exact lines (rectangular window, no
leakage) gives independent frequency lines; the variance across periods is a nonparametric
noise estimate. The steady periods are split into two interleaved halves A and B: the
regressors ``R`` and outputs ``X`` of one half are paired with the instruments ``Z`` =
regressors of the other half, whose noise is independent of both (``H = sum X Z^H (sum R
Z^H)^-1`` over realizations and both pairings, per line). Each half's bases are debiased with
that half's measured noise variance; the instruments are formed from a Wiener-smoothed half
average (per-line gain from the measured signal and noise spectra), which strengthens them
without biasing anything. Needs more realizations than inputs (forces + bases) at every line.
The lines themselves (forming the inputs, the per-line IV, the jackknife) are in
`._periodic_lines`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..models import Model
from ..errors import InputError
from ..recordings import DEFAULT_TRANSIENT_PERIODS, Recording, excitation_band, steady_periods
from ..spectral import Spectra, excited_lines
from ._core import ReversePathResult, _estimate, _Processing
from ._periodic_lines import _jackknife, _lines_iv, _periodic_inputs

WEAK_F = 10.0            # first-stage F below which an instrument is weak (Staiger-Stock)
BURIED = 0.5             # deformation noise std per period / its rms that biases the estimate


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
    blocks = _blocks(recs, layouts)
    n = layouts[0].period
    rec0 = recs[0][0]
    fs, fdofs = float(rec0.fs), rec0.force_dofs
    freqs = np.fft.rfftfreq(n, 1 / fs)
    (lo, hi), idx = _lines(blocks, freqs, band, fs, warnings)
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


def _blocks(recs: list[tuple[Recording, str]], layouts: list[Layout | None]) -> list:
    """Per record ``(rec, kind, force periods, response periods)``, the steady periods as
    ``(realizations, periods, n, channels)``; refuses mixed or differing layouts."""
    if any(lay is None for lay in layouts):
        raise InputError("some records are periodic (a period layout) and some are not; "
                         "analyse them separately")
    if any(lay.period != layouts[0].period for lay in layouts):
        raise InputError("the periodic records differ in period length; analyse them "
                         "separately")
    return [(rec, kind, *(steady_periods(a, lay.period, transient_periods=lay.transient,
                                         realizations=lay.realizations)
                          for a in (rec.force, rec.response)))
            for (rec, kind), lay in zip(recs, layouts)]


def _lines(blocks: list, freqs: np.ndarray, band: tuple[float, float] | None, fs: float,
           warnings: list[str]) -> tuple[tuple[float, float], np.ndarray]:
    """The analysis band (the force's excited band unless given) and the excited lines in
    it (`analysis.spectral.excited_lines`, its note and caveat added to ``warnings``)."""
    fpow, fvar, amp, amp_var = _force_lines(blocks)
    if band is None:
        band = excitation_band(freqs, fpow)
    lo, hi = float(band[0]), float(band[1])
    n = blocks[0][2].shape[2]
    if not 0 <= lo < hi <= fs / 2:
        raise InputError(f"band {lo:g}-{hi:g} Hz must satisfy 0 <= lo < hi <= fs/2 = "
                         f"{fs / 2:g}")
    if not ((freqs >= lo) & (freqs <= hi) & (freqs > 0)).any():
        raise InputError(f"band {lo:g}-{hi:g} Hz holds no line of the {n}-sample period")
    picked = excited_lines(freqs, fpow, fvar, band=(lo, hi), amplitudes=amp,
                           amplitude_noise=amp_var)
    if picked.lines.size == 0:
        raise InputError(f"the force excites no line of the {n}-sample period in "
                         f"{lo:g}-{hi:g} Hz; check the band")
    caveat = picked.caveat()
    warnings += [w for w in (picked.note(), None if caveat is None else caveat.text()) if w]
    return (lo, hi), picked.lines


def _force_lines(blocks: list) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None,
                                        np.ndarray | None]:
    """Force power of the period averages per line, summed over records, realizations and
    forces, and the variance of that average from the spread over the periods (None with a
    single steady period); the amplitude of each realization's period average per line and
    its noise variance, of the record with the most realizations (None with one): the
    inputs of `analysis.spectral.excited_lines`."""
    power, var = 0.0, 0.0
    amp, amp_var = None, None
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
        if fp.shape[0] >= 2 and (amp is None or fp.shape[0] > amp.shape[0]):
            amp = np.sqrt((np.abs(mean) ** 2).sum(axis=2))
            amp_var = dev.sum(axis=(1, 3)).mean(axis=0) / ((n_p - 1) * n_p)
    return power, var, (amp if var is not None else None), amp_var


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


def _worst(rel: list[list[float] | None]) -> list[float] | None:
    known_rel = [r for r in rel if r is not None]
    return np.max(known_rel, axis=0).tolist() if known_rel else None
