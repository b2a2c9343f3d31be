"""Clipped samples: a channel held at its converter's limit, found as a test engineer does.

A channel driven past its range records its limit instead of the signal: the same extreme
value repeated where a continuous signal reaches its maximum once. Read as physics, a clipped
accelerometer looks like a hard nonlinearity (the zoo row ``sdof-cubic-acc-random-clipping``:
5 clipped acceleration samples of 32768 per level turned a cubic spring into a gap), so the
samples are found on import and detect and kept out of the diagnosis.

The rule reads the histogram's edge (the classic clipping test): an extreme value held by
two or more samples (bit for bit: one converter code), and by more than twice as many as any
of the next values inward (`PILE_UP`). A continuous signal
holds each value once; a quantised one thins towards its extremes; a noise-free periodic one
holds every value once per period, its extreme included. A pile-up at the edge is none of
these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._recording import CHANNEL_UNITS, Excitation, Recording


@dataclass(frozen=True)
class ClippedChannel:
    """One channel's samples at its limits.

    Attributes
    ----------
    kind : str
        ``"force"`` or the response kind of the channel.
    channel : int
        Index among the force or the response channels.
    samples : ndarray of int
        Indices of the samples held at a limit (into the record's samples), ascending.
    low, high : float or None
        The limits held (None: that side is not clipped).
    """

    kind: str
    channel: int
    samples: np.ndarray
    low: float | None
    high: float | None

    def limits(self) -> str:
        """``+-8.1 m/s²`` for a symmetric range, else the held limits."""
        unit = CHANNEL_UNITS.get(self.kind, "")
        if self.low is not None and self.high is not None and np.isclose(-self.low, self.high):
            return f"+-{self.high:.3g} {unit}"
        return " and ".join(f"{v:+.3g} {unit}" for v in (self.low, self.high) if v is not None)


@dataclass(frozen=True)
class ClippingCaveat:
    """The clipped channels of one level: the one source of the clipping warning every
    command prints (import, detect, diagnose).

    Attributes
    ----------
    level : str
        The level as people read it (``12.4 N rms``).
    channels : tuple of ClippedChannel
    """

    level: str
    channels: tuple[ClippedChannel, ...]

    @property
    def samples(self) -> np.ndarray:
        """Every clipped sample of the level (any channel), ascending."""
        return np.unique(np.concatenate([c.samples for c in self.channels]))

    def text(self, consequence: str = "") -> str:
        """One line per level: where, how many, at which limits, ``consequence`` (what the
        command did about it or what it means there), what to do."""
        parts = [f"{c.kind} channel {c.channel}: {c.samples.size} clipped sample"
                 f"{'s' * (c.samples.size != 1)} at {self.level}, {c.limits()}"
                 for c in self.channels]
        return ("; ".join(parts) + " (the same extreme value repeated: the channel's range)"
                + (f"; {consequence}" if consequence else "")
                + "; raise the channel's range and record again")


INWARD = 5
PILE_UP = 2
"""A pile-up: the extreme value held by more than `PILE_UP` times as many samples as any of
the `INWARD` values next inward. A quantised random record's tail holds a few samples per
step, and its extreme step by chance more than the next one (measured, Gaussian noise of
32768 samples, 300 records each: with "more than the next value" alone 0.7-9 % of
unclipped channels read as clipped at 16 and 12 bits using 1/8-1/64 of the range; with this
rule 0-0.3 %, and 5 clipped samples still found in every record)."""

TIE = 1e-9
"""Relative tolerance within which a noise-free periodic record's periods repeat a value (to
its last few digits, not bit for bit). Clipped samples themselves hold one converter code,
the same value bit for bit: within this tolerance instead, a noise-free sweep computed in
floating point comes that close to its crest at many samples (11 at 8 N in the
``detect-sweep`` golden) and would read as clipped."""


def _side(a: np.ndarray, sign: float, period: int | None) -> tuple[np.ndarray, float] | None:
    """Samples held at ``a``'s maximum (``sign`` +1) or minimum (-1), with the value, when
    they pile up at the edge (module docstring); else None."""
    b = sign * a
    top = b.max()
    at = np.flatnonzero(b == top)
    if at.size < 2 or _repeats(b, at, period, TIE * max(float(np.abs(a).max()), 1e-300)):
        return None
    inner = b[b < top]
    if inner.size == 0:                     # a constant channel: nothing to clip
        return None
    if at.size <= PILE_UP * _inward_counts(inner).max():
        return None
    return at, float(sign * top)


def _inward_counts(inner: np.ndarray) -> np.ndarray:
    """Samples holding each of the `INWARD` largest values of ``inner``."""
    top = np.sort(inner)[::-1][:INWARD * 64]
    return np.bincount(np.concatenate([[0], np.cumsum(np.diff(top) < 0)]))[:INWARD]


def _repeats(b: np.ndarray, at: np.ndarray, period: int | None, tol: float) -> bool:
    """Whether the extreme's samples are a noise-free periodic record's one peak, once a
    period: whole periods apart, their neighbours repeating too (measured on the zoo's GVT
    rows: a start-up period that differs elsewhere put the next value inward once, the
    extreme seven times)."""
    if period is None or np.any(np.diff(at) % period):
        return False
    i, j = at[0], at[1]
    near = [k for k in (-1, 1) if 0 <= i + k and j + k < b.size]
    return bool(near) and all(abs(b[i + k] - b[j + k]) <= tol for k in near)


def clipped_channel(a: np.ndarray, kind: str, channel: int, period: int | None = None
                    ) -> ClippedChannel | None:
    """The clipped samples of one channel ``a`` (1-D), or None when it holds none; ``period``
    (samples, when known) tells a noise-free periodic record's repeated peak from a clip."""
    hi, lo = _side(a, 1.0, period), _side(a, -1.0, period)
    if hi is None and lo is None:
        return None
    found = [s[0] for s in (lo, hi) if s is not None]
    return ClippedChannel(kind, channel, np.unique(np.concatenate(found)),
                          None if lo is None else lo[1], None if hi is None else hi[1])


def clipping(force: np.ndarray, response: np.ndarray, response_kinds: list[str] | tuple[str, ...],
             level: str, period: int | None = None) -> ClippingCaveat | None:
    """The clipped channels of one continuous record.

    Parameters
    ----------
    force : ndarray, shape (n, n_in)
    response : ndarray, shape (n, n_dof)
    response_kinds : sequence of str
        The kind of each response channel.
    level : str
        The level's name on the warning line.
    period : int, optional
        Samples per period of a periodic record (its layout's).

    Returns
    -------
    ClippingCaveat or None
        None when no channel is clipped.
    """
    found = [clipped_channel(force[:, j], "force", j, period) for j in range(force.shape[1])]
    found += [clipped_channel(response[:, j], response_kinds[j], j, period)
              for j in range(response.shape[1])]
    chans = tuple(c for c in found if c is not None)
    return ClippingCaveat(level, chans) if chans else None


def recording_clipping(rec: Recording, level: str) -> ClippingCaveat | None:
    """`clipping` of a continuous `Recording` (random, multisine, swept sine); None for a
    stepped sine, whose steps are not read: a sine sampled at a multiple of its frequency
    holds its amplitude exactly at every peak it samples (measured on the zoo's noise-free
    stepped rows: 185-376 force samples at the amplitude), and its steps are fitted as sines,
    not read sample by sample. A swept sine's force is not read either: a drive generated
    at its amplitude holds it bit for bit at the crests it samples (10 of each sign in the
    ``detect-sweep`` golden's 8 N sweep), and a sweep's force dips rather than peaks."""
    if rec.force.ndim != 2:
        return None
    kinds = (rec.sensors.response_kinds if rec.sensors is not None
             else (rec.response_kind,) * rec.n_dof)
    force = rec.force[:, :0] if rec.excitation == Excitation.SWEPT_SINE else rec.force
    return clipping(force, rec.response, kinds, level,
                    None if rec.layout is None else rec.layout.period)
