"""Is a record periodic, and with which period? For exports that carry no period (a MATLAB
or CSV file of a periodic multisine test holds only the arrays and the sample rate).

A signal of period ``P`` repeated ``n`` times has, in the FFT of the whole ``n P`` samples,
energy on every ``n``-th line only; noise spreads evenly over all lines. The period is found
in two steps: candidate lags from the autocorrelation (its peaks after the main lobe), then
for each candidate the share of the record's power on the lines of period ``P``
(`periodic_share`). A random (non-periodic) record holds about ``1/n`` of its power there,
a periodic one all of it but its noise. The first period is a start-up transient when it
differs from the next one by more than the steady periods differ from each other.

Records of several realizations back to back (``R`` random-phase multisines of ``M`` periods
each, one after the other in one array) repeat only within each realization: the share on the
period's lines of the whole record is low, that of each realization high. For a candidate lag
the record is split into ``R`` equal realizations, ``R`` = 1 first, then the divisors of the
whole periods in increasing order: the first ``R`` whose every realization is clearly periodic
is the layout (a smaller ``R`` puts realization boundaries inside a part, which then fails;
a larger one would only split realizations further). Each realization's leading periods are
its transient; the layout takes the most any realization shows.

An export cut inside its last period (a record that is not a whole number of periods) is
still found: the lag's whole periods are tested, and when that fails, realizations of
``ceil`` periods whose last one is one period short and cut (`Periodicity.short`).
`whole_periods` then cuts every realization to the whole periods the last one holds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

#: least share of the (steady) record's power on the period's lines for "clearly periodic":
#: the periodic part is at least 10 dB above what is not (noise, drift, a transient left)
SHARE_MIN = 0.9
#: least normalised autocorrelation at a candidate lag (below it no lag is tried)
CORR_MIN = 0.5
#: candidate lags tried, highest autocorrelation first
MAX_CANDIDATES = 8
#: a leading period is a transient when its change to the next exceeds the later changes by
#: this many standard deviations of a noise-only change (relative std ``sqrt(2 / P)``)
TRANSIENT_SIGMAS = 4.0


@dataclass(frozen=True)
class Periodicity:
    """The period found in a record.

    Attributes
    ----------
    period : int
        Samples per period.
    periods : int
        Whole periods in the record (transient ones included).
    transient_periods : int
        Leading periods of each realization that differ from the steady ones more than these
        differ from each other (start-up transient).
    share : float
        Share of the steady part's power (DC excluded) on the period's spectral lines (the
        least of the realizations').
    remainder : int
        Samples after the last whole period (0 when the record is whole periods).
    realizations : int
        Realizations back to back, each of ``periods`` periods (transient ones included);
        ``periods`` counts the periods of one realization.
    short : int
        Whole periods the last realization lacks (the record was cut inside it): 0 or 1.
    """

    period: int
    periods: int
    transient_periods: int
    share: float
    remainder: int
    realizations: int = 1
    short: int = 0

    @property
    def whole(self) -> int:
        """Whole periods every realization holds (transient ones included)."""
        return self.periods - self.short


def find_period(signal: np.ndarray, min_period: int = 2, period: int | None = None,
                settle: np.ndarray | None = None) -> Periodicity | None:
    """The period of a clearly periodic record, else None.

    Parameters
    ----------
    signal : ndarray, shape (n,) or (n, n_channels)
        The record (e.g. the measured forces), time along axis 0.
    min_period : int
        Shortest period considered, samples.
    period : int, optional
        The period, when known (a file's ``period`` key): only this lag is tried, for the
        realizations and transient periods.
    settle : ndarray, shape (n, n_channels), optional
        Channels that must have settled too (the responses, each scaled to unit rms): a
        leading period is transient when it is so in ``signal`` or in ``settle``.

    Returns
    -------
    Periodicity or None
        None when no lag holds at least `SHARE_MIN` of the power on its lines over at least
        two whole periods of every realization (random, swept or too short records).
    """
    x = np.asarray(signal, dtype=float)
    x = x.reshape(x.shape[0], -1) - x.mean(axis=0).reshape(1, -1)
    n = x.shape[0]
    if n < 2 * max(min_period, 2) or not np.any(x):
        return None
    found = None
    lags = _candidate_lags(x, max(min_period, 2)) if period is None else \
        [int(period)] if 2 <= period <= n // 2 else []
    for lag in lags:
        if found is not None and lag >= found[0]:
            continue
        total = n // lag
        for m, each in _splits(total, n > total * lag):
            parts = _realizations(x[:total * lag], lag, m, each)
            if min(_steady_share(p, lag) for p in parts) >= SHARE_MIN:
                found = (lag, m, each)
                break
    if found is None:
        return None
    lag, m, each = found
    total = n // lag
    parts = _realizations(x[:total * lag], lag, m, each)
    transient = max(transient_periods(p, lag) for p in parts)
    if settle is not None:
        y = np.asarray(settle, dtype=float).reshape(n, -1)[:total * lag]
        y = y - y.mean(axis=0)
        y = y / np.where(y.std(axis=0) > 0, y.std(axis=0), 1.0)
        transient = max(transient, *(transient_periods(p, lag)
                                     for p in _realizations(y, lag, m, each)))
    share = min(periodic_share(p[transient * lag:], p.shape[0] // lag - transient)
                for p in parts)
    return Periodicity(lag, each, transient, float(share), n - total * lag, m,
                       m * each - total)


def whole_periods(signal: np.ndarray, found: Periodicity) -> np.ndarray:
    """``signal`` (time along axis 0) cut to `Periodicity.whole` periods per realization: the
    partial period at the end dropped, and with a realization cut short, the same number of
    trailing periods of every other one (realizations must be equal blocks)."""
    x = np.asarray(signal)
    block, keep = found.periods * found.period, found.whole * found.period
    return np.concatenate([x[i * block:i * block + keep] for i in range(found.realizations)])


def _splits(total: int, cut: bool) -> list[tuple[int, int]]:
    """(realizations, periods each) to try on ``total`` whole periods: the divisors of
    ``total``; for a record ``cut`` inside a period, also realizations of which the last is
    one period short (at least two whole periods left in it)."""
    out = [(d, total // d) for d in range(1, total // 2 + 1) if total % d == 0]
    if cut:
        out += [(d, (total + 1) // d) for d in range(2, (total + 1) // 3 + 1)
                if (total + 1) % d == 0]
    return out


def _realizations(x: np.ndarray, period: int, m: int, each: int) -> list[np.ndarray]:
    """``x`` (whole periods) cut into ``m`` realizations of ``each`` periods (the last one
    perhaps a period short)."""
    step = each * period
    return [x[i * step:(i + 1) * step] for i in range(m)]


def _steady_share(x: np.ndarray, period: int) -> float:
    """`periodic_share` of one realization's whole periods, its first left out when it has
    three or more (a possible start-up transient)."""
    total = x.shape[0] // period
    start = period if total >= 3 else 0
    return periodic_share(x[start:], total - start // period)


def _candidate_lags(x: np.ndarray, min_period: int) -> list[int]:
    """Lags of the autocorrelation's peaks (after its main lobe, at least `CORR_MIN`, up to
    half the record), the highest `MAX_CANDIDATES` of them."""
    n = x.shape[0]
    spec = np.fft.rfft(x, 2 * n, axis=0)
    acf = np.fft.irfft((np.abs(spec) ** 2).sum(axis=1), 2 * n)[:n // 2 + 1]
    r = acf / (n - np.arange(acf.size)) / (acf[0] / n)      # unbiased, r[0] = 1
    below = np.flatnonzero(r < CORR_MIN)
    if below.size == 0:
        return []
    lo = max(int(below[0]), min_period)
    mid = r[lo:-1]
    peaks = lo + np.flatnonzero((mid >= CORR_MIN) & (mid >= r[lo - 1:-2]) & (mid >= r[lo + 1:]))
    if r[-1] >= CORR_MIN and r[-1] >= r[-2]:
        peaks = np.r_[peaks, r.size - 1]
    best = peaks[np.argsort(r[peaks])[::-1][:MAX_CANDIDATES]]
    return sorted(int(p) for p in best)


def periodic_share(x: np.ndarray, periods: int) -> float:
    """Share of the power (DC excluded) of ``periods`` whole periods on the period's lines.

    Parameters
    ----------
    x : ndarray, shape (periods * P, n_channels)
    periods : int

    Returns
    -------
    float
        1 for an exactly periodic record; about ``1 / periods`` for noise.
    """
    if periods < 2:
        return 0.0
    power = (np.abs(np.fft.rfft(x - x.mean(axis=0), axis=0)) ** 2).sum(axis=1)[1:]
    whole = power.sum()
    if whole == 0:
        return 0.0
    on = power[periods - 1::periods].sum()      # lines k * periods, k >= 1
    return float(on / whole)


def transient_periods(x: np.ndarray, period: int) -> int:
    """Leading periods of ``x`` (whole periods) that are start-up transient.

    Period ``k`` counts as transient when its change to period ``k + 1`` exceeds every later
    change between consecutive periods by more than `TRANSIENT_SIGMAS` noise standard
    deviations; at least two steady periods are left. Two periods in all: none transient.
    Each period's mean and linear trend are taken out first: a sensor's slow drift moves
    them from period to period and, curved, looked like a decaying start-up (the catalogue's
    drift took 2 of a twin's 4 steady periods).

    Parameters
    ----------
    x : ndarray, shape (periods * period, n_channels)
    period : int

    Returns
    -------
    int
    """
    blocks = scipy.signal.detrend(x.reshape(-1, period, x.shape[1]), axis=1)
    change = (np.diff(blocks, axis=0) ** 2).sum(axis=(1, 2))     # period k -> k + 1
    tol = 1 + TRANSIENT_SIGMAS * np.sqrt(2 / (period * x.shape[1]))
    t = 0
    while t < change.size - 1 and change[t] > tol * change[t + 1:].max():
        t += 1
    return t
