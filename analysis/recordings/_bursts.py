"""Realizations recorded as bursts: equal-length stretches of drive between quiet gaps.

Some exports hold several random-phase multisine realizations one after the other with a
short stretch of zeros (or of sensor noise) between them, and perhaps another record after
them (the Silverbox's ten 8192-sample realizations followed by a Gaussian-noise "arrow" of
growing amplitude). Such a record repeats nowhere, so `find_period` finds nothing;
`find_bursts` reads the bursts off the force: stretches separated by gaps in which the force
stays below `QUIET_FRACTION` of its peak for at least `MIN_GAP` samples, the realizations
being the bursts of one length (two or more).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a sample is quiet when the force is below this fraction of its peak
QUIET_FRACTION = 1e-3
#: a gap holds at least this many quiet samples in a row
MIN_GAP = 20
#: bursts whose lengths differ by at most this share of the realizations' length are one
#: length (a gap's edge read a few samples off where the drive starts or ends softly)
LENGTH_TOLERANCE = 0.005


@dataclass(frozen=True)
class Bursts:
    """Equal-length bursts of a record: the realizations, and what else it holds.

    Attributes
    ----------
    length : int
        Samples per realization (the most frequent burst length).
    starts : tuple of int
        First sample of each realization, in record order.
    others : tuple of (int, int)
        ``(start, length)`` of every other burst (not a realization) of `MIN_GAP` samples or
        more, left out.
    """

    length: int
    starts: tuple[int, ...]
    others: tuple[tuple[int, int], ...]

    def cut(self, x: np.ndarray) -> np.ndarray:
        """The realizations of ``x`` (samples along axis 0) back to back."""
        return np.concatenate([x[s:s + self.length] for s in self.starts])


def find_bursts(force: np.ndarray) -> Bursts | None:
    """The realizations recorded as bursts in a force record, or None.

    Parameters
    ----------
    force : ndarray, shape (n,) or (n, n_in)
        Time along axis 0.

    Returns
    -------
    Bursts or None
        None when the record holds fewer than two bursts of one length (within
        `LENGTH_TOLERANCE`), or when one burst is the whole record.
    """
    f = np.abs(np.asarray(force, dtype=float).reshape(len(force), -1)).max(axis=1)
    peak = f.max() if f.size else 0.0
    if not np.isfinite(peak) or peak <= 0:
        return None                        # the recording's own checks name bad samples
    loud = np.r_[False, f > QUIET_FRACTION * peak, False]
    edges = np.flatnonzero(np.diff(loud.astype(np.int8)))
    starts, stops = edges[::2], edges[1::2]
    if starts.size < 2:
        return None
    keep = np.r_[True, starts[1:] - stops[:-1] >= MIN_GAP]      # short gaps: one burst
    starts, stops = starts[keep], np.r_[stops[np.flatnonzero(keep)[1:] - 1], stops[-1]]
    lengths = stops - starts
    if lengths.size < 2:
        return None
    values, counts = np.unique(lengths, return_counts=True)
    mode = int(values[np.argmax(counts)])
    same = np.abs(lengths - mode) <= LENGTH_TOLERANCE * mode
    if same.sum() < 2:
        return None
    length = int(lengths[same].max())
    ok = same & (starts + length <= len(f))
    rest = ~ok & (lengths >= MIN_GAP)                  # shorter: a blip in a gap, not a record
    return Bursts(length, tuple(int(s) for s in starts[ok]),
                  tuple((int(s), int(n)) for s, n in zip(starts[rest], lengths[rest])))
