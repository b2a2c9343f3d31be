"""Is the structure nonlinear? Statistical tests on the measured data alone (no model).

Random levels (Welch)
    A linear structure has one FRF at every level. The H1 estimates of the lowest and the
    highest level are compared line by line against their random error (MIMO H1 variance
    ``sigma_y^2 [G_FF^-1]_aa / n_eff`` with ``sigma_y^2 = (1 - gamma_y^2) G_yy``, Bendat &
    Piersol): ``z = |H_lo - H_hi|^2 / (var_lo + var_hi)`` is exponential with unit mean for a
    linear structure, so lines above its 99 % quantile are flagged.
Periodic-random levels
    The robust BLA's total against its noise variance (`analysis.spectral._bla`).
Swept-sine levels
    Harmonic distortion of each sweep, sweep-direction hysteresis of an up/down pair, level
    dependence of one direction (`analysis.detection._detect_sweep`).
Stepped-sine levels
    The fundamental FRF of the lowest and the highest level at their common frequencies; the
    error of each step's estimate is read off the difference of the fits to the two halves of
    its block (relative to the FRF, a median over the steps: one step's halves alone give a
    two-degree-of-freedom variance).

Each way about 1 % of the lines are flagged by chance; a share above 1 % plus four binomial
standard deviations (widened by the window's bin correlation for Welch lines) detects a
nonlinearity. The flagged band says where in frequency (which elements and where on the
structure: `analysis.reverse_path.screen_candidates`, `analysis.diagnose`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import scipy.stats

from ..spectral import (BLA, DETECT_QUANTILE, best_linear_approximation, default_nperseg, h1,
                        hold_gain, level_name, multiple_coherence, sine_fit, spectral_matrix)
from ..backbone import frf_noise
from ..errors import InputError
from ..recordings import (KIND_ORDER, Recording, StepTable, excitation_band, record_level,
                          recording_clipping)
from ._detect_sweep import sweep_tests
from ._result import Detection, DetectionTest, TestMethod


def detect(recordings: Sequence[Recording], *, nperseg: int | None = None) -> Detection:
    """Run every test the recordings allow.

    Parameters
    ----------
    recordings : sequence of Recording
        Levels of one structure: random, periodic-random, stepped-sine and/or swept-sine.
    nperseg : int, optional
        Welch segment length for random levels (default: a power of two <= n/16, <= 8192).

    Returns
    -------
    Detection
        The verdict, one `DetectionTest` per test and the notes (what could not be tested,
        interference lines left out).
    """
    recs = list(recordings)
    periodic = [r for r in recs if r.excitation == "random" and r.layout is not None]
    random = [r for r in recs if r.excitation == "random" and r.layout is None]
    stepped = [r for r in recs if r.excitation == "stepped-sine"]
    swept = [r for r in recs if r.excitation == "swept-sine"]
    notes = []
    single = [r for r in periodic if r.layout.realizations == 1]
    tests = [_bla_test(r, notes) for r in periodic
             if r.layout.realizations >= 2 and r.layout.periods >= 2]
    notes += [f"{level_name(r)}: {r.layout.realizations} realizations of one period each: the "
              "BLA distortion test needs two or more periods per realization (the noise read "
              "off their spread)" for r in periodic if r.layout.periods < 2
              and r.layout.realizations >= 2]
    if len(single) >= 2:
        tests.append(periodic_level_dependence(single, notes))
    elif single:
        notes.append("one periodic level of one realization: the BLA distortion test needs "
                     "two or more realizations, the level-dependence test two or more levels")
    for name, group, test in (("random", random, lambda g: level_dependence(g, nperseg=nperseg)),
                              ("stepped-sine", stepped, stepped_level_dependence)):
        if len(group) >= 2:
            tests.append(test(group))
        elif group:
            notes.append(f"one {name} level: the level-dependence test needs two or more")
    if swept:
        more, said = sweep_tests(swept, _summary)
        tests += more
        notes += said
    if not tests:
        raise InputError("no level to test: " + ("; ".join(notes) if notes else
                         "give random or stepped-sine runs at two or more levels, or "
                         "periodic-random or swept-sine runs"))
    notes += [c.text("a clipped channel looks like a hard nonlinearity to these tests")
              for r in recs if isinstance(r, Recording)
              and (c := recording_clipping(r, level_name(r))) is not None]
    unknown = sum(r.level is None for r in random + stepped)
    if unknown:
        notes.append(f"{unknown} level(s) carry no nominal level (e.g. a CSV imported without "
                     "--level): levels ordered by their measured force (rms, or amplitude "
                     "for sines)")
    return Detection(tuple(tests), tuple(notes))


@dataclass
class LevelChange:
    """Line-by-line change of the FRF between the lowest and the highest random level.

    Attributes
    ----------
    freqs : ndarray, shape (n_f,)
        Lines of the common excited band, Hz.
    z : ndarray, shape (n_f, n_out)
        ``|H_lo - H_hi|^2 / (var_lo + var_hi)``, largest over the inputs.
    threshold : float
        Value a linear structure exceeds on 1 % of the lines.
    summary : DetectionTest
        The test's entry of `detect` (``method`` "level-dependence").
    """

    freqs: np.ndarray
    z: np.ndarray
    threshold: float
    summary: DetectionTest


def level_dependence(recordings: Sequence[Recording], *, nperseg: int | None = None
                     ) -> DetectionTest:
    """Compare the H1 of the lowest and the highest random level (module docstring)."""
    return level_change(recordings, nperseg=nperseg).summary


def level_change(recordings: Sequence[Recording], *, nperseg: int | None = None
                 ) -> LevelChange:
    """`level_dependence` with its per-line statistic."""
    recs = sorted(recordings, key=record_level)
    lo, hi = recs[0], recs[-1]
    if lo.fs != hi.fs or list(lo.force_dofs) != list(hi.force_dofs) or lo.n_dof != hi.n_dof:
        raise InputError("the levels differ in sample rate, forces or responses; test runs of "
                         "one set-up together")
    n = min(lo.force.shape[0], hi.force.shape[0])
    nps = nperseg if nperseg is not None else default_nperseg(n)
    est = [_h1(r, nps) for r in (lo, hi)]
    band = (max(e[3][0] for e in est), min(e[3][1] for e in est))
    if band[0] >= band[1]:
        raise InputError("the levels excite no common band")
    f = est[0][0]
    keep = (f >= band[0]) & (f <= band[1])
    (H0, v0), (H1, v1) = [(e[1][keep], e[2][keep]) for e in est]
    z = (np.abs(H0 - H1) ** 2 / np.maximum(v0 + v1, 1e-300)).max(axis=2)   # (n_f, n_out)
    threshold = float(-np.log(1 - DETECT_QUANTILE) + np.log(H0.shape[2]))
    out = _summary(f[keep], z > threshold, est[0][4], TestMethod.LEVEL_DEPENDENCE).with_(
        levels=[lo.level, hi.level], labels=_labels(lo, hi), resolution_hz=lo.fs / nps,
        median_change_db=_median_db(z))
    return LevelChange(f[keep], z, threshold, out)


def stepped_level_dependence(recordings: Sequence[Recording]) -> DetectionTest:
    """Compare the fundamental FRFs of the lowest and the highest stepped-sine level at the
    frequencies both hold (module docstring)."""
    recs = sorted(recordings, key=record_level)
    lo, hi = recs[0], recs[-1]
    common = np.intersect1d(np.round(lo.freqs, 9), np.round(hi.freqs, 9))
    if common.size == 0:
        raise InputError("the stepped-sine levels share no drive frequency")
    (H0, v0), (H1, v1) = [_step_frf(r, common) for r in (lo, hi)]
    z = (np.abs(H0 - H1) ** 2 / np.maximum(v0 + v1, 1e-300)).max(axis=2)     # (n_f, n_out)
    threshold = float(-np.log(1 - DETECT_QUANTILE) + np.log(H0.shape[2]))
    return _summary(common, z > threshold, 1.0, TestMethod.STEPPED_LEVEL_DEPENDENCE).with_(
        levels=[lo.level, hi.level], labels=_labels(lo, hi), median_change_db=_median_db(z))


def periodic_level_dependence(recordings: Sequence[Recording],
                              notes: list[str] | None = None) -> DetectionTest:
    """Compare the period-averaged FRFs (`analysis.spectral._bla`, one realization each) of the lowest
    and the highest periodic level on the lines both excite.

    ``|G_lo - G_hi|^2 / (var_lo + var_hi)``, the variances from the spread over the periods,
    is F(2, 2 (P - 1))-distributed for a linear structure (``P`` the fewer steady periods);
    lines beyond its 99 % quantile are flagged. Interference lines left out of either level
    are said in ``notes``.
    """
    recs = sorted(recordings, key=record_level)
    lo, hi = (_bla(r, notes) for r in (recs[0], recs[-1]))
    common, i0, i1 = np.intersect1d(np.round(lo.freqs, 9), np.round(hi.freqs, 9),
                                    return_indices=True)
    if common.size == 0:
        raise InputError("the periodic levels excite no common line; check their periods")
    z = (np.abs(lo.G[i0] - hi.G[i1]) ** 2
         / np.maximum(lo.var_noise[i0] + hi.var_noise[i1], 1e-300))
    p = min(lo.periods, hi.periods)
    threshold = float(scipy.stats.f.ppf(DETECT_QUANTILE, 2, 2 * (p - 1)))
    return _summary(common, z > threshold, 1.0, TestMethod.LEVEL_DEPENDENCE).with_(
        levels=[recs[0].level, recs[-1].level], labels=_labels(recs[0], recs[-1]),
        resolution_hz=float(recs[0].fs / recs[0].layout.period), median_change_db=_median_db(z))


def _bla(rec: Recording, notes: list[str] | None) -> BLA:
    """The period-averaged FRF of a periodic level; interference it left out and the mains
    caveat (`analysis.spectral.MainsCaveat`) said in ``notes``."""
    b = best_linear_approximation(rec.force, rec.response, rec.fs, rec.layout.period,
                                  transient_periods=rec.layout.transient_periods,
                                  realizations=rec.layout.realizations,
                                  force_hold=rec.force_hold)
    if notes is not None and b.interference:
        notes.append(f"{level_name(rec)}: " + ", ".join(i.text() for i in b.interference)
                     + ", left out")
    if notes is not None and b.caveat is not None:
        notes.append(f"{level_name(rec)}: {b.caveat.text()}")
    return b


def _labels(*recs: Recording) -> tuple[str, ...]:
    return tuple(level_name(r) for r in recs)


def _median_db(z: np.ndarray) -> list[float]:
    """Median per output of a per-line ratio, dB."""
    return [float(10 * np.log10(np.median(z[:, q]))) for q in range(z.shape[1])]


def _step_frf(rec: Recording | StepTable, freqs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fundamental FRF X1/F1 at ``freqs`` (first step at each), shape (n_f, n_out, n_in), and
    its variance from the two halves of each block, pooled as a median relative variance (a
    table: its phasor ratios, the variance from the scatter about a single mode,
    `analysis.backbone.frf_noise`)."""
    if isinstance(rec, StepTable):
        idx = [int(np.flatnonzero(np.isclose(rec.freqs, f))[0]) for f in freqs]
        H = rec.frf()
        var = frf_noise(rec.freqs, H[:, :, 0], KIND_ORDER[rec.response_kind])
        return H[idx], np.broadcast_to(var[None, :, None], H[idx].shape).copy()
    n = rec.response.shape[1]
    parts = (slice(0, n), slice(0, n // 2), slice(n - n // 2, n))
    H, rel = [], []
    for f in freqs:
        i = int(np.flatnonzero(np.isclose(rec.freqs, f))[0])
        whole, a, b = [sine_fit(rec.response[i][p], rec.fs, f)[0][:, None]
                       / sine_fit(rec.force[i][p], rec.fs, f)[0][None, :] for p in parts]
        H.append(whole)
        rel.append(np.abs(a - b) ** 2 / 4 / np.maximum(np.abs(whole) ** 2, 1e-300))
    H = np.array(H)
    return H, np.median(np.array(rel), axis=0) * np.abs(H) ** 2


def _h1(rec: Recording, nps: int):
    """H1, its variance, the excited band and the bin correlation factor of one level."""
    n_in = rec.n_in
    spec = spectral_matrix(np.concatenate([rec.force, rec.response], axis=1), rec.fs,
                           nperseg=nps)
    auto = spec.auto()
    S = spec.S
    S_ff, S_xf = S[:, :n_in, :n_in], S[:, n_in:, :n_in]
    gain = hold_gain(spec.freqs, rec.fs, rec.force_hold)[:, None, None]
    H = h1(S_xf, S_ff) / gain
    coh = multiple_coherence(auto[:, n_in:], S_xf, S_ff)
    sigma2 = np.maximum(1 - coh, 0.0) * auto[:, n_in:] / max(spec.n_eff - n_in, 1.0)
    inv = np.linalg.inv(S_ff).diagonal(axis1=1, axis2=2).real                 # (n_f, n_in)
    var = sigma2[:, :, None] * inv[:, None, :] / gain**2
    band = excitation_band(spec.freqs, auto[:, :n_in])
    return spec.freqs, H, var, band, spec.bin_factor


def _bla_test(rec: Recording, notes: list[str]) -> DetectionTest:
    if rec.n_in != 1:
        raise InputError("the BLA test takes one force channel")
    return bla_summary(_bla(rec, notes), rec.level).with_(labels=_labels(rec))


def bla_summary(b: BLA, level: float | None = None) -> DetectionTest:
    """The BLA test's entry of `detect`: lines whose total variance exceeds the noise beyond
    the linear-system quantile (`analysis.spectral.BLA.threshold`), per response and overall."""
    ratio = b.var_total / np.maximum(b.var_noise, 1e-300)
    return _summary(b.freqs, ratio > b.threshold(), 1.0, TestMethod.BLA).with_(
        levels=[level], realizations=b.realizations, periods=b.periods,
        median_change_db=_median_db(ratio))


def _summary(freqs: np.ndarray, flagged: np.ndarray, bin_factor: float,
             method: TestMethod) -> DetectionTest:
    """Share of flagged lines against the chance share, band and share per output."""
    p = 1 - DETECT_QUANTILE
    limit = p + 4 * np.sqrt(p * (1 - p) * bin_factor / freqs.size)
    any_line = flagged.any(axis=1)
    share = float(flagged.mean())
    lines = freqs[any_line]
    by_out = flagged.mean(axis=0)
    return DetectionTest(method, bool(share > limit), share, float(limit),
                         (float(lines.min()), float(lines.max())) if lines.size else None,
                         tuple(float(s) for s in by_out))
