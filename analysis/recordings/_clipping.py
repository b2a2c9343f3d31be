"""Clipped samples: a channel held at its converter's limit, found as a test engineer does.

A channel driven past its range records its limit instead of the signal: the same extreme
value repeated where a continuous signal reaches its maximum once. Read as physics, a clipped
accelerometer looks like a hard nonlinearity (the zoo row ``sdof-cubic-acc-random-clipping``:
5 clipped acceleration samples of 32768 per level turned a cubic spring into a gap), so the
samples are found on import and detect and kept out of the diagnosis.

The rule reads the histogram's edge (the classic clipping test): an extreme value held by
two or more samples, and by more samples than the next value inward. A continuous signal
holds each value once; a quantised one thins towards its extremes; a noise-free periodic one
holds every value once per period, its extreme included. A pile-up at the edge is none of
these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._recording import Recording

UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
"""Unit of each channel kind on the summary lines."""


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
        """``+-8.1 m/s^2`` for a symmetric range, else the held limits."""
        unit = UNITS.get(self.kind, "")
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


def _side(a: np.ndarray, sign: float) -> tuple[np.ndarray, float] | None:
    """Samples held at ``a``'s maximum (``sign`` +1) or minimum (-1), with the value, when
    they pile up at the edge (module docstring); else None."""
    b = sign * a
    top = b.max()
    at = np.flatnonzero(b == top)
    if at.size < 2:
        return None
    inner = b[b < top]
    if inner.size == 0:                     # a constant channel: nothing to clip
        return None
    if at.size <= np.count_nonzero(b == inner.max()):
        return None
    return at, float(sign * top)


def clipped_channel(a: np.ndarray, kind: str, channel: int) -> ClippedChannel | None:
    """The clipped samples of one channel ``a`` (1-D), or None when it holds none."""
    hi, lo = _side(a, 1.0), _side(a, -1.0)
    if hi is None and lo is None:
        return None
    found = [s[0] for s in (lo, hi) if s is not None]
    return ClippedChannel(kind, channel, np.unique(np.concatenate(found)),
                          None if lo is None else lo[1], None if hi is None else hi[1])


def clipping(force: np.ndarray, response: np.ndarray, response_kinds: list[str] | tuple[str, ...],
             level: str) -> ClippingCaveat | None:
    """The clipped channels of one continuous record.

    Parameters
    ----------
    force : ndarray, shape (n, n_in)
    response : ndarray, shape (n, n_dof)
    response_kinds : sequence of str
        The kind of each response channel.
    level : str
        The level's name on the warning line.

    Returns
    -------
    ClippingCaveat or None
        None when no channel is clipped.
    """
    found = [clipped_channel(force[:, j], "force", j) for j in range(force.shape[1])]
    found += [clipped_channel(response[:, j], response_kinds[j], j)
              for j in range(response.shape[1])]
    chans = tuple(c for c in found if c is not None)
    return ClippingCaveat(level, chans) if chans else None


def recording_clipping(rec: Recording, level: str) -> ClippingCaveat | None:
    """`clipping` of a `Recording` (continuous records; a stepped sine's steps are read as
    one record per channel: the limits are the channel's, whatever the step)."""
    kinds = (rec.sensors.response_kinds if rec.sensors is not None
             else (rec.response_kind,) * rec.n_dof)
    n_in, n_dof = rec.force.shape[-1], rec.response.shape[-1]
    return clipping(rec.force.reshape(-1, n_in), rec.response.reshape(-1, n_dof), kinds,
                    level)
