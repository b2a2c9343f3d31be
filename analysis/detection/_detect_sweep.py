"""Nonlinearity tests of swept-sine levels (part of `analysis.detection.detect`).

Single sweep
    Response harmonics the force's own harmonics and the noise do not explain
    (`analysis.spectral.harmonic_distortion`).
Up/down pair at one level
    Sweep-direction hysteresis: where each direction jumps (the largest change of ``|H|``
    between neighbouring analysis points: a drop off the resonant branch or a rise onto it)
    and whether both do jump — a change more than `JUMP_FACTOR` times the steepest a
    linear mode of the measured half-power bandwidth allows between the points — and their
    jump frequencies differ by more than
    the sweep's own delay explains (a mode answers a sweep one time constant ``tau = 1 /
    (2 pi zeta fn)`` late, so a linear mode's peaks sit ``2 r tau`` apart, plus two point
    spacings).
Levels of one direction
    The tracked fundamental FRFs of the lowest and the highest level on non-overlapping
    windows of their common band: ``|H_lo - H_hi|^2 / (var_lo + var_hi)``, the variances from
    the fractional-order noise of each window, is exponential with unit mean for a linear
    structure (the sweep-rate bias is the same at every level and cancels); lines beyond its
    99 % quantile are flagged as in the other level tests.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from ..spectral import (DETECT_QUANTILE, NOISE_ORDERS, SweepFRF, harmonic_distortion,
                        independent_windows, level_name, recording_sweep_frf)
from ..recordings import KIND_ORDER, Recording
from ._result import DetectionTest, Jumps, SweepJump, TestMethod

#: a jump changes |H| by more than this many times the steepest linear step between points
JUMP_FACTOR = 4.0
#: levels within this relative difference form an up/down pair
PAIR_TOLERANCE = 0.1


def sweep_tests(recordings: Sequence[Recording], summary: Callable[..., DetectionTest]
                ) -> tuple[list[DetectionTest], list[str]]:
    """Every sweep test the swept-sine ``recordings`` allow, and notes.

    ``summary`` is `analysis.detection._detect._summary` (share of flagged lines against chance), the
    one summary of every line-by-line test.

    Returns
    -------
    tests : list of DetectionTest
        `analysis.detection.detect` entries (``method`` "sweep-harmonics", "sweep-hysteresis",
        "sweep-level-dependence"), each with ``levels`` and ``direction`` (or
        ``directions``).
    notes : list of str
    """
    frfs = [(rec, recording_sweep_frf(rec)) for rec in recordings]
    tests, notes = [], []
    for rec, frf in frfs:
        out = harmonic_distortion(frf)
        tests.append(DetectionTest(
            TestMethod.SWEEP_HARMONICS, out["nonlinear"], out["share_flagged"],
            out["share_limit"], None if out["band_hz"] is None else tuple(out["band_hz"]),
            levels=(frf.level,), direction=_name(frf.direction), tests=out["tests"],
            labels=(level_name(rec),)))
    ups = [p for p in frfs if p[1].direction > 0]
    downs = [p for p in frfs if p[1].direction < 0]
    for up in ups:
        match = [d for d in downs
                 if abs(d[1].level - up[1].level) <= PAIR_TOLERANCE * max(d[1].level,
                                                                          up[1].level)]
        if match:
            tests.append(hysteresis(up[0], up[1], match[0][0], match[0][1]))
    for group in (ups, downs):
        if len(group) >= 2:
            tests.append(level_dependence([f for _, f in group], group[0][0].response_kind,
                                          summary, [r for r, _ in group]))
    if len(frfs) == 1:
        notes.append("one sweep: the up/down hysteresis test needs the other direction at the "
                     "same level, the level test a second level")
    return tests, notes


def _name(direction: int) -> str:
    return "up" if direction > 0 else "down"


def hysteresis(rec_up: Recording, up: SweepFRF, rec_down: Recording, down: SweepFRF
               ) -> DetectionTest:
    """The sweep-direction hysteresis test of an up/down pair (module docstring)."""
    jumps = {}
    for name, rec, frf in (("up", rec_up, up), ("down", rec_down, down)):
        mag = np.abs(frf.frf).max(axis=1)                 # sweep order
        drop = np.abs(np.diff(np.log(np.maximum(mag, 1e-300))))
        j = int(np.argmax(drop))
        half_width = _half_width(frf.freqs, mag)
        spacing = float(np.median(np.abs(np.diff(frf.freqs))))
        linear_step = spacing / (2 * half_width)          # steepest d ln|H| of a linear mode
        rate = _rate_at(rec, frf.freqs[j])
        jumps[name] = SweepJump(float(0.5 * (frf.freqs[j] + frf.freqs[j + 1])),
                                float(mag[j + 1] / mag[j]),
                                bool(drop[j] > JUMP_FACTOR * linear_step),
                                float(rate / (2 * np.pi * half_width)), spacing)
    pair = Jumps(jumps["up"], jumps["down"])
    sep = pair.up.freq_hz - pair.down.freq_hz
    allowed = pair.up.delay_hz + pair.down.delay_hz + pair.up.spacing_hz + pair.down.spacing_hz
    nonlinear = bool(pair.up.jump and pair.down.jump and abs(sep) > allowed)
    return DetectionTest(TestMethod.SWEEP_HYSTERESIS, nonlinear,
                         band_hz=tuple(sorted([pair.up.freq_hz, pair.down.freq_hz]))
                         if nonlinear else None, levels=(up.level, down.level),
                         separation_hz=float(sep), allowed_hz=float(allowed), jumps=pair,
                         directions=("up", "down"),
                         labels=(level_name(rec_up), level_name(rec_down)))


def _half_width(freqs: np.ndarray, mag: np.ndarray) -> float:
    """Half-power half-width ``zeta fn`` of the highest peak of ``|H|``, Hz (at least a
    point spacing)."""
    order = np.argsort(freqs)
    f, m = freqs[order], mag[order]
    k = int(np.argmax(m))
    above = m >= m[k] / np.sqrt(2)
    lo = k
    while lo > 0 and above[lo - 1]:
        lo -= 1
    hi = k
    while hi < f.size - 1 and above[hi + 1]:
        hi += 1
    spacing = float(np.median(np.diff(f)))
    return max(0.5 * (f[hi] - f[lo]), spacing)


def _rate_at(rec: Recording, freq: float) -> float:
    """Sweep rate at ``freq``, Hz/s."""
    law = rec.sweep.law
    return law.rate if law.law == "linear" else law.rate / 60 * np.log(2) * freq


def level_dependence(frfs: Sequence[SweepFRF], response_kind: str,
                     summary: Callable[..., DetectionTest],
                     recordings: Sequence[Recording]) -> DetectionTest:
    """Tracked fundamental FRFs of the lowest and the highest level of one sweep direction
    compared on independent windows (module docstring; ``summary`` as in `sweep_tests`;
    ``recordings`` those of ``frfs``, for the levels' names)."""
    order = sorted(range(len(frfs)), key=lambda i: frfs[i].level)
    lo, hi = frfs[order[0]], frfs[order[-1]]
    labels = (level_name(recordings[order[0]]), level_name(recordings[order[-1]]))
    keep = independent_windows(lo.times, lo.window_s)
    f = lo.freqs[keep]
    inside = (f >= hi.freqs.min()) & (f <= hi.freqs.max())
    f = f[inside]
    H0 = lo.frf[keep][inside]
    v0 = _frf_variance(lo, response_kind)[keep][inside]
    order = np.argsort(hi.freqs)
    H1 = np.stack([np.interp(f, hi.freqs[order], hi.frf[order, c].real)
                   + 1j * np.interp(f, hi.freqs[order], hi.frf[order, c].imag)
                   for c in range(hi.frf.shape[1])], axis=1)
    v1 = np.stack([np.interp(f, hi.freqs[order], _frf_variance(hi, response_kind)[order, c])
                   for c in range(hi.frf.shape[1])], axis=1)
    z = np.abs(H0 - H1) ** 2 / np.maximum(v0 + v1, 1e-300)
    threshold = float(-np.log(1 - DETECT_QUANTILE))
    return summary(f, z > threshold, 1.0, TestMethod.SWEEP_LEVEL_DEPENDENCE).with_(
        levels=[lo.level, hi.level], direction=_name(lo.direction), labels=labels,
        median_change_db=[float(10 * np.log10(np.median(z[:, q])))
                          for q in range(z.shape[1])])


def _frf_variance(frf: SweepFRF, response_kind: str, smooth: int = 5) -> np.ndarray:
    """Variance of the tracked receptance in each window, from the fractional-order noise
    (converted to the fundamental: the noise is white over the window's few harmonics in the
    recorded kind) pooled over ``2 smooth + 1`` neighbouring windows."""
    p = KIND_ORDER[response_kind]
    scale = 1 / np.mean(np.asarray(NOISE_ORDERS, float) ** (-2 * p))
    power = frf.noise ** 2 * scale
    n = power.shape[0]
    pooled = np.array([power[max(0, i - smooth):i + smooth + 1].mean(axis=0)
                       for i in range(n)])
    return pooled / frf.force[:, None] ** 2
