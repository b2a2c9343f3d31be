"""The responses' delay behind the force: read off the start model's lowest levels, taken out.

A DAQ whose anti-alias filters differ between the force and the response channels records the
responses a sample or so behind the force (the real F-16 GVT export: about one sample). That
is a measurement fact, not physics: every measured FRF carries ``exp(-i 2 pi f d / fs)`` at
every level, and a diagnosis that reads it as the structure names effects that are not there
(zoo row ``twin-gvt-none-acc-multisine-catalogue``: a false alarm, the start model missing
every level by 0.10 against a floor of 0.010).

A level-dependent effect moves the FRF's phase too (a slider's dissipation; on
``chain-hysteresis01-acc-multisine`` a one-sample shift lowers the start model's misfit at
every level, 1.28 -> 1.16 against a floor of 0.011), and at the highest levels the start model
misses by the nonlinearity the diagnosis is to find (``chain-cubic01-disp-random-delay``: the
true shift raises the top level's misfit, 0.30 -> 0.35). So the delay is read where the start
model is meant to hold, at the lowest amplitude: a whole-sample shift is taken out when it
brings the start model *within its floor* at the lowest level, which it missed beyond it as
recorded (decided there), and lowers the misfit of the next level (or of the lowest level's
held-back segment, for one level) by more than that level's noise (confirmed out of sample).
A delay-free record whose start model holds at the lowest level is never shifted: there the
misfit is already within the floor.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ._leakage import Floor
from ._prepare import Prepared, split_segment

MAX_SHIFT = 3
"""Largest whole-sample shift tried each way (anti-alias group delays differ by a few samples
at most)."""

Misfit = Callable[[Prepared], tuple[float, Floor]]
"""The start model's misfit at one prepared level (`compare.weighted_error`) and its floor."""


@dataclass(frozen=True)
class ResponseDelay:
    """Whole samples by which the responses lagged the force, taken out before the diagnosis.

    Attributes
    ----------
    samples : int
        Lag of the responses behind the force (negative: they led it); every record was
        aligned by moving its responses this many samples earlier.
    decided_on, confirmed_on : str
        The level at which the shift brought the start model within its floor, and the
        level (or held-back segment) at which it confirmed it.
    misfit_before, misfit_after : tuple of float
        The start model's misfit at those two levels, as recorded and aligned.
    limit : float
        The deciding level's floor (`Floor.limit`) after the shift.
    noise : float
        The confirming level's noise (`Floor.noise`), the drop its misfit had to exceed.
    """

    samples: int
    decided_on: str
    confirmed_on: str
    misfit_before: tuple[float, float]
    misfit_after: tuple[float, float]
    limit: float
    noise: float

    def note(self) -> str:
        """The warnings line: what was found, the numbers that decided it, what to do."""
        n = abs(self.samples)
        way = "lag" if self.samples > 0 else "lead"
        return (f"the responses {way} the force by {n} sample{'s' * (n != 1)}: taken out "
                f"(start model misfit {self.misfit_before[0]:.3g} -> {self.misfit_after[0]:.3g} "
                f"at {self.decided_on}, floor {self.limit:.3g}; {self.misfit_before[1]:.3g} -> "
                f"{self.misfit_after[1]:.3g} at {self.confirmed_on}); store the run aligned with "
                f"`nlid-lab import ... response_delay={self.samples}`")

    def to_json(self) -> dict[str, object]:
        return {"samples": self.samples, "decided_on": self.decided_on,
                "confirmed_on": self.confirmed_on, "misfit_before": list(self.misfit_before),
                "misfit_after": list(self.misfit_after), "limit": self.limit,
                "noise": self.noise}

    @classmethod
    def from_json(cls, data: dict) -> ResponseDelay:
        return cls(int(data["samples"]), data["decided_on"], data["confirmed_on"],
                   tuple(data["misfit_before"]), tuple(data["misfit_after"]),
                   float(data["limit"]), float(data["noise"]))


def shifted(p: Prepared, d: int) -> Prepared:
    """``p`` with its motion moved ``d`` samples earlier against its force.

    A periodic record (steady whole periods) is rolled within each period, exact for a
    steady response; a random one drops ``|d|`` samples at one end.
    """
    if d == 0:
        return p
    if p.period is not None:
        def roll(a: np.ndarray) -> np.ndarray:
            return np.roll(a.reshape(-1, p.period, a.shape[1]), -d, axis=1).reshape(a.shape)
        return replace(p, x=roll(p.x), v=roll(p.v))
    n = p.x.shape[0]
    motion, force = (slice(d, n), slice(0, n - d)) if d > 0 else (slice(0, n + d), slice(-d, n))
    hit = None if p.clipped is None else p.clipped[motion] | p.clipped[force]
    return replace(p, x=p.x[motion], v=p.v[motion], force=p.force[force], clipped=hit)


def aligned(preps: list[Prepared], misfit: Misfit
            ) -> tuple[list[Prepared], ResponseDelay | None]:
    """``preps`` (ascending levels) with the responses' delay taken out, when the lowest level
    decides it and the next confirms it (module docstring); the delay found, or None.

    Parameters
    ----------
    preps : list of Prepared
        Every level, lowest first.
    misfit : callable
        The start model's misfit and floor at one prepared level.

    Returns
    -------
    preps : list of Prepared
        Shifted by the delay found (the same list when none).
    delay : ResponseDelay or None
    """
    low, nxt = (preps[0], preps[1]) if len(preps) > 1 else split_segment(preps[0])
    m0, floor0 = misfit(low)
    if m0 <= floor0.limit:
        return preps, None
    found = _best_shift(low, misfit, m0)
    if found is None or found[1] > found[2].limit:
        return preps, None
    best, m_best, floor_best = found
    c0, floor_c = misfit(nxt)
    c1, _ = misfit(shifted(nxt, best))
    if c0 - c1 <= floor_c.noise:
        return preps, None
    delay = ResponseDelay(best, low.label, nxt.label, (m0, c0), (m_best, c1),
                          floor_best.limit, floor_c.noise)
    return [shifted(p, best) for p in preps], delay


def _best_shift(p: Prepared, misfit: Misfit, m0: float) -> tuple[int, float, Floor] | None:
    """The whole-sample shift (within `MAX_SHIFT`) that leaves the least misfit at ``p``:
    one sample each way, then further in the better direction while the misfit falls (a
    delay's misfit grows with the distance from it); None when neither lowers it."""
    tried = {d: misfit(shifted(p, d)) for d in (1, -1)}
    best = min(tried, key=lambda d: tried[d][0])
    if tried[best][0] >= m0:
        return None
    step = best
    while abs(best) < MAX_SHIFT:
        nxt = misfit(shifted(p, best + step))
        if nxt[0] >= tried[best][0]:
            break
        best += step
        tried[best] = nxt
    return best, *tried[best]
