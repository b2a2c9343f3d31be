"""The excited lines of a periodic drive, picked as a test engineer picks them.

A multisine excites one or a few designed bands: runs of DFT lines of the period (every line,
every other line, or with some lines left out) whose force is steady from period to period. A
measured force also holds lines nobody designed: mains pick-up at 50 or 60 Hz and its
harmonics, a pump, a fan. Such a line is steady too, but stands alone, far from the band, or
off the band's grid of lines. It is left out (an FRF there is the interference's, not the
structure's) and named, so that the engineer sees what was dropped.

Rule, in order:

1. ``band`` (the user's ``--band``), when given, first;
2. candidates: lines whose force power exceeds `FLOOR` of the strongest line and is steady
   over the periods (power above `STEADY` times the variance of the period average);
3. runs: candidates closer than `GAP` times their typical spacing belong to one run; a run of
   at least `BAND_LINES` lines is a designed band (with none, the largest run is), shorter
   runs are interference; a drift's leakage (lines contiguous from the period's first,
   power falling, then a gap) is split off the band first and named a slow drift;
4. within a band whose lines sit on a coarser grid (odd lines, every third line), a line off
   that grid more than `OFF_GRID_DB` below the band's median power is interference;
5. with two or more realizations (random phases, the same amplitudes: a random-phase
   multisine), an excited line whose force amplitude varies across the realizations beyond
   its noise (`SPREAD_CHI2`) and `SPREAD_RATIO` times its neighbours' variation holds
   interference on the drive line: a mains line keeps its phase from realization to
   realization (a whole number of its cycles per period) while the drive's turns, so their
   sum's amplitude changes. It is left out and named with its level relative to the line's
   drive (the variation's ``sqrt(2) std``: a rough figure with few realizations, with 3 of
   them within -18..+4 dB of the true level in 95 % of phase draws). Where the variation
   stays within the noise (a line 60 dB under the drive line with 0.5 % force noise and 3
   realizations; at 38 dB under it is told) nothing is said: the data cannot tell, and the
   line is as good as its neighbours.
6. with one realization the drive lines are as steady as a mains line, so rule 5 has nothing
   to compare. Two things still tell mains on a drive line: mains is not locked to the DAQ's
   clock (the grid wanders by a few 0.01 Hz), so its phase drifts from period to period
   while the drive's repeats: an excited line whose period-to-period variance exceeds
   `SPREAD_RATIO` times its neighbours' holds interference (any frequency); and a
   multisine's force amplitudes are smooth over the lines while mains adds to one line: a
   line on a mains multiple whose amplitude stands `OUTLIER` robust deviations (and its
   noise) off its neighbours' median is mains. The level named is then a lower bound (the
   part of the mains line that moves the amplitude or drifts). Measured on the artifact
   twin's force (one realization, 3 steady periods, 0.5 % noise, catalogue mains at -40 dB
   of the rms, 20 phase draws): locked to the period (50.000 Hz) the 50 Hz line stands
   0.15-1.1 dB (median 0.60 dB) off its neighbours, whose scatter is 0.01 dB; at 50.02 Hz
   its period variance is 71-141 times its neighbours'. A mains line whose phase leaves the
   drive line's amplitude unchanged (in quadrature with it) and that stays locked to the
   period is not told from the drive: the warning of `MainsCaveat` says so.
7. a drive line left out by rule 5 or 6 whose period-to-period variance exceeds
   `SPREAD_RATIO` times its neighbours' holds a source off the period's grid (mains not
   locked to the DAQ's clock: 50.02 Hz): it leaks into the adjacent lines (-28 dB of it at
   0.04 line off), where the response's share of it can outweigh the drive's response. Its
   two neighbours are left out with it (named with it). Before, the artifact twin with
   mains at 50.02 Hz gave fit-linear a third mode at 49.4 Hz (0.08 % damping) and detect
   "NONLINEAR" at the lowest level (6.6 % of the lines, 2.9 % with locked mains).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FLOOR = 1e-4
"""Force power, relative to the strongest line, below which a line is not excited."""
STEADY = 10.0
"""A line's power over the variance of its period average above which it is steady (a line
of noise alone exceeds it with probability ``exp(-10)``)."""
GAP = 8
"""Candidates further apart than this many times their median spacing start a new run."""
BAND_LINES = 5
"""Fewest lines of a designed band; shorter runs are interference."""
OFF_GRID_DB = -20.0
"""An off-grid line of a band this far (dB) below the band's median power is interference."""
SPREAD_CHI2 = 30.0
"""Variance of a line's amplitude across realizations over its noise's radial variance
(half the period average's) above which the line varies beyond its noise (chi-square with
``M - 1`` degrees of freedom over them: exceeded by noise alone with probability ``3e-7`` at
``M = 2``, less with more)."""
SPREAD_RATIO = 30.0
"""The same variance over the median of its `SPREAD_NEIGHBOURS` neighbours' above which it
is the line's own (not the drive's, nor the structure's, which change smoothly)."""
SPREAD_NEIGHBOURS = 8
OUTLIER = 10.0
"""Robust deviations (1.4826 MAD of its neighbours' log amplitudes about their median, or its
own noise when larger) by which a single realization's line on a mains multiple stands off
its neighbours to be mains (rule 6)."""
DRIFT_LINES = 2
"""Interference on the period's lowest lines (1 and 2) is named a drift (an offset or a slow
drift of the sensor leaks there, docs/daq-artifacts.md)."""
MAINS_HZ = (50.0, 60.0)
#: rule 7 reads a line's period variance as a drifting source only above this share of its
#: power (a drifting line some 70-80 dB under its drive line; noise-free records drift by
#: rounding)
DRIFT_FLOOR = 1e-8
"""Mains frequencies: interference on a multiple of one (within 0.05 Hz) is named mains."""


@dataclass(frozen=True)
class Interference:
    """A steady line left out of the excited set.

    Attributes
    ----------
    freq_hz : float
    level_db : float
        Its force power relative to the median of the excited lines, dB.
    on_drive_line : bool
        On an excited line (rules 5 and 6).
    drift : bool
        On one of the period's `DRIFT_LINES` lowest lines: a slow drift or an offset's
        leakage, not a source at that frequency.
    unlocked_hz : float, optional
        The source's own frequency when it drifts off the line (rule 7) and was fitted and
        taken out of the periods (`analysis.spectral._unlocked`).
    """

    freq_hz: float
    level_db: float
    on_drive_line: bool = False
    drift: bool = False
    unlocked_hz: float | None = None

    def text(self) -> str:
        """``interference at 50.0 Hz, -40 dB``; on a drive line ``mains at 50.0 Hz on a drive
        line, -17 dB`` (``mains`` on a multiple of 50 or 60 Hz); on the lowest lines
        ``slow drift at 0.1 Hz, -28 dB``."""
        if self.drift:
            return f"slow drift at {self.freq_hz:.2g} Hz, {self.level_db:.0f} dB"
        if self.unlocked_hz is not None:
            return (f"{self.source} at {self.unlocked_hz:.2f} Hz on a drive line, not locked to "
                    f"the period (fitted and taken out), {self.level_db:.0f} dB")
        if not self.on_drive_line:
            return f"interference at {self.freq_hz:.1f} Hz, {self.level_db:.0f} dB"
        return f"{self.source} at {self.freq_hz:.1f} Hz on a drive line, {self.level_db:.0f} dB"

    @property
    def source(self) -> str:
        """``mains`` on a multiple of 50 or 60 Hz (within 0.05 Hz), else ``interference``."""
        return "mains" if _on_mains(self.freq_hz) else "interference"


def _lowest(f: np.ndarray, i: int) -> bool:
    """Line ``i`` of the grid ``f`` (from 0 Hz) is one of its `DRIFT_LINES` lowest above 0."""
    return bool(f.size > 1 and f[0] == 0 and 0 < i <= DRIFT_LINES)


def _on_mains(freq_hz: float) -> bool:
    """On a multiple of a `MAINS_HZ` frequency, within 0.05 Hz."""
    return freq_hz > 1 and any(abs(freq_hz - m * round(freq_hz / m)) < 0.05 for m in MAINS_HZ)


@dataclass(frozen=True)
class MainsCaveat:
    """Mains multiples on kept drive lines of a single realization (rule 6): mains locked to
    the period and in quadrature with the drive cannot be told from it there. The one source
    of the warning every command prints (BLA, reverse path, fit-linear, detect).

    Attributes
    ----------
    freqs_hz : tuple of float
        The mains multiples on kept drive lines, Hz, ascending.
    """

    freqs_hz: tuple[float, ...]

    def text(self) -> str:
        """One warning line naming the lines and what to record to check them."""
        at = ", ".join(f"{f:g}" for f in self.freqs_hz)
        return (f"one realization: mains on the drive line(s) at {at} Hz is told only when "
                "it drifts from period to period or moves the line's amplitude off its "
                "neighbours'; record two or more realizations (random phases) to check")


@dataclass(frozen=True)
class ExcitedLines:
    """Excited lines of a periodic drive and the interference left out.

    Attributes
    ----------
    lines : ndarray of int
        Indices of the excited DFT lines of one period, ascending.
    interference : tuple of Interference
        Ascending in frequency.
    """

    lines: np.ndarray
    interference: tuple[Interference, ...] = ()
    unchecked_mains: tuple[float, ...] = ()
    """Mains multiples (Hz) on kept drive lines of a single realization (rule 6)."""
    drifting: tuple[float, ...] = ()
    """Lines (Hz) left out whose source drifts in phase over the periods (rule 7)."""

    def caveat(self) -> MainsCaveat | None:
        """The caveat when mains multiples sit on kept drive lines of a single realization
        (`MainsCaveat`), else None."""
        return MainsCaveat(self.unchecked_mains) if self.unchecked_mains else None

    def note(self) -> str | None:
        """One summary phrase naming the interference left out, or None."""
        if not self.interference:
            return None
        return ", ".join(i.text() for i in self.interference) + ", left out"


def excited_lines(freqs: np.ndarray, power: np.ndarray, noise: np.ndarray | None = None, *,
                  band: tuple[float, float] | None = None,
                  amplitudes: np.ndarray | None = None,
                  amplitude_noise: np.ndarray | None = None) -> ExcitedLines:
    """Excited lines of a periodic drive (module docstring).

    Parameters
    ----------
    freqs : ndarray, shape (n_lines,)
        DFT lines of one period, Hz.
    power : ndarray, shape (n_lines,)
        Power of the period-averaged force per line.
    noise : ndarray, shape (n_lines,), optional
        Variance of that average from the spread over the periods (omitted: every line is
        steady).
    band : (lo, hi), optional
        Lines outside it are not considered.
    amplitudes : ndarray, shape (n_realizations, n_lines), optional
        Force amplitude of each realization's period average per line (rule 5; needs two or
        more realizations).
    amplitude_noise : ndarray, shape (n_lines,), optional
        Variance of one realization's period average per line (default ``noise``).

    Returns
    -------
    ExcitedLines
        No lines when nothing exceeds the floor.
    """
    f = np.asarray(freqs, dtype=float)
    p = np.asarray(power, dtype=float)
    ok = f > 0
    if band is not None:
        ok &= (f >= band[0]) & (f <= band[1])
    if not np.any(p[ok] > 0):
        return ExcitedLines(np.zeros(0, dtype=int))
    cand = ok & (p > FLOOR * p[ok].max())
    if noise is not None:
        cand &= p > STEADY * np.asarray(noise, dtype=float)
    idx = np.flatnonzero(cand)
    if idx.size == 0:
        return ExcitedLines(idx)
    runs = _drift_head(_runs(idx), p)
    bands = [r for r in runs if r.size >= BAND_LINES] or [max(runs, key=len)]
    kept = np.concatenate(bands)
    ref = float(np.median(p[kept]))
    stray = [r for r in runs if not any(r is b for b in bands)]
    left = np.concatenate([np.zeros(0, dtype=int)] + stray
                          + [_off_grid(b, p, ref) for b in bands])
    left = np.sort(left)
    named = [Interference(float(f[i]), float(10 * np.log10(p[i] / ref)),
                          drift=_lowest(f, i))
             for i in _peaks(left, p)]
    kept = np.setdiff1d(kept, left)
    a_noise = noise if amplitude_noise is None else amplitude_noise
    unchecked: tuple[float, ...] = ()
    if amplitudes is not None and a_noise is not None and len(amplitudes) >= 2:
        on, level = _on_drive_lines(kept, np.asarray(amplitudes, dtype=float),
                                    np.asarray(a_noise, dtype=float))
    elif noise is not None:
        on, level = _single_realization(kept, f, p, np.asarray(noise, dtype=float))
        rest = np.setdiff1d(kept, on)
        unchecked = tuple(float(x) for x in f[rest] if _on_mains(float(x)))
    else:
        on, level = kept[:0], np.zeros(0)
    named += [Interference(float(f[i]), float(db), True) for i, db in zip(on, level)]
    drifting: tuple[float, ...] = ()
    if noise is not None:
        leak, src = _leakage(on, kept, np.asarray(noise, dtype=float), p)
        on, drifting = np.union1d(on, leak), tuple(float(f[i]) for i in src)
    kept = np.setdiff1d(kept, on)
    return ExcitedLines(kept, tuple(sorted(named, key=lambda i: i.freq_hz)), unchecked,
                        drifting)


def _neighbours(values: np.ndarray, stat=np.median) -> np.ndarray:
    """``stat`` of each entry's `SPREAD_NEIGHBOURS` neighbours either side (itself left
    out; reflected at the ends)."""
    k = SPREAD_NEIGHBOURS
    padded = np.pad(values, k, mode="reflect")
    return np.array([stat(np.r_[padded[i:i + k], padded[i + k + 1:i + 2 * k + 1]])
                     for i in range(values.size)])


def _single_realization(kept: np.ndarray, f: np.ndarray, p: np.ndarray, noise: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Excited lines holding interference in one realization (rule 6) and a lower bound of
    its level, dB re the line's drive."""
    if kept.size <= 2 * SPREAD_NEIGHBOURS:
        return kept[:0], np.zeros(0)
    var, amp = noise[kept], np.sqrt(p[kept])
    drift = var > SPREAD_RATIO * _neighbours(var)
    log_amp = np.log(np.maximum(amp, 1e-300))
    dev = log_amp - _neighbours(log_amp)
    spread = 1.4826 * _neighbours(log_amp, lambda x: np.median(np.abs(x - np.median(x))))
    own = np.sqrt(var / 2) / np.maximum(amp, 1e-300)
    mains = np.array([_on_mains(float(x)) for x in f[kept]])
    outlier = mains & (np.abs(dev) > OUTLIER * np.maximum(spread, own))
    hit = drift | outlier
    level = 20 * np.log10(np.maximum(np.abs(np.expm1(dev[hit])),
                                     np.sqrt(var[hit]) / np.maximum(amp[hit], 1e-300)))
    return kept[hit], level


def _on_drive_lines(kept: np.ndarray, amp: np.ndarray, noise: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Excited lines holding interference (rule 5) and its level, dB re the line's drive."""
    if kept.size <= 2 * SPREAD_NEIGHBOURS:
        return kept[:0], np.zeros(0)
    a = amp[:, kept]
    var = a.var(axis=0, ddof=1)
    own = var > SPREAD_CHI2 * 0.5 * noise[kept]
    hit = own & (var > SPREAD_RATIO * _neighbours(var))
    level = 10 * np.log10(2 * var[hit] / np.maximum(a.mean(axis=0)[hit] ** 2, 1e-300))
    return kept[hit], level


def _leakage(on: np.ndarray, kept: np.ndarray, noise: np.ndarray, power: np.ndarray
             ) -> tuple[np.ndarray, list[int]]:
    """The kept neighbours of the lines ``on`` (left out as interference) whose source drifts
    in phase from period to period (rule 7: off the grid, it leaks into them), and those
    lines. A drift below `DRIFT_FLOOR` of the line's power is rounding, not a source."""
    out, src = [], []
    for i in on:
        near = kept[(np.abs(kept - i) > 1) & (np.abs(kept - i) <= SPREAD_NEIGHBOURS + 1)]
        if near.size and noise[i] > max(SPREAD_RATIO * np.median(noise[near]),
                                        DRIFT_FLOOR * power[i]):
            out += [j for j in (i - 1, i + 1) if j in kept]
            src.append(int(i))
    return np.array(out, dtype=int), src


def _drift_head(runs: list[np.ndarray], power: np.ndarray) -> list[np.ndarray]:
    """The first run split where a drift's leakage joins a band: lines contiguous from one of
    the period's `DRIFT_LINES` lowest, power falling line by line (an offset change or a
    slow drift leaks as ``1/k``), then a gap wider than the rest's spacing before the band.
    Within `GAP` the band's run took them in: the artifact twin's drift (lines 1-4 at 0.5 Hz,
    the band from line 10) widened the fit to 0.5-100 Hz with 12 % FRF error."""
    first = runs[0]
    if first.size < 2 or not 0 < first[0] <= DRIFT_LINES:
        return runs
    head = 1 + int(np.argmax(np.diff(first) > 1)) if np.any(np.diff(first) > 1) else first.size
    rest = first[head:]
    if rest.size < 2 or rest[0] - first[head - 1] <= np.median(np.diff(rest)):
        return runs
    if np.any(np.diff(power[first[:head]]) > 0):
        return runs
    return [first[:head], rest, *runs[1:]]


def _runs(idx: np.ndarray) -> list[np.ndarray]:
    """Split sorted line indices where a gap exceeds `GAP` times their median spacing."""
    if idx.size == 1:
        return [idx]
    gaps = np.diff(idx)
    cut = np.flatnonzero(gaps > GAP * np.median(gaps)) + 1
    return np.split(idx, cut)


def _off_grid(run: np.ndarray, power: np.ndarray, ref: float) -> np.ndarray:
    """Lines of ``run`` off its grid (the most common spacing and offset) and weak."""
    if run.size < BAND_LINES:
        return np.zeros(0, dtype=int)
    gaps = np.diff(run)
    step = int(np.bincount(gaps).argmax())
    if step <= 1:
        return np.zeros(0, dtype=int)
    phase = int(np.bincount(run % step).argmax())
    return run[(run % step != phase) & (power[run] < ref * 10 ** (OFF_GRID_DB / 10))]


def _peaks(lines: np.ndarray, power: np.ndarray) -> list[int]:
    """The strongest line of each group of adjacent lines (a leaking interference spreads
    over its neighbours: named once)."""
    if lines.size == 0:
        return []
    groups = np.split(lines, np.flatnonzero(np.diff(lines) > 1) + 1)
    return [int(g[np.argmax(power[g])]) for g in groups]
