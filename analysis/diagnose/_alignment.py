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
A record whose start model holds at the lowest level is shifted only by a fraction both
segments of that level read line by line at 99.9 % (`_held_fraction`). A fraction of a sample, when no whole shift serves, is
read line by line (`_line_delay`: the median delay of the lines, which the start model's
error at the resonances does not move) and decided and confirmed on the lowest level's two
segments.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..modal import DelayReading
from ._leakage import Floor
from ._prepare import Prepared, split_segment

MAX_SHIFT = 3
"""Largest whole-sample shift tried each way (anti-alias group delays differ by a few samples
at most)."""

FRACTION_EDGE = 32
"""Samples dropped at each end of a random record moved by a fraction of a sample: the phase
ramp over the whole record wraps its end onto its start."""
STRICT = 3.29
"""Normal quantile of the line-by-line reading's interval that must exclude 0 when the start
model holds the lowest level as recorded (99.9 %, fit-linear's F test level)."""
MIN_FRACTION = 0.01
"""Smallest delay taken out when the start model holds the lowest level, samples: it turns an
FRF by at most ``2 pi f / fs x 0.01`` (1.6 % of itself at fs/4, under the levels' floors), and
the simulated plant's own phase reads up to 0.003 sample line by line on delay-free zoo rows
(``chain-cubic01-acc-random``: -0.0021 +- 0.0014)."""

Misfit = Callable[[Prepared], tuple[float, Floor]]
"""The start model's misfit at one prepared level (`compare.weighted_error`) and its floor."""
Ratio = Callable[[Prepared], tuple[np.ndarray, np.ndarray, float]]
"""One prepared level's lines (Hz), its measured FRF over the start model's at them (complex,
lines first) and the correlation of adjacent lines (`compare.LevelFRF.bin_factor`)."""


@dataclass(frozen=True)
class ResponseDelay:
    """Whole samples by which the responses lagged the force, taken out before the diagnosis.

    Attributes
    ----------
    samples : float
        Lag of the responses behind the force (negative: they led it); every record was
        aligned by moving its responses this many samples earlier. Whole samples unless no
        whole-sample shift brings the deciding level within its floor.
    decided_on, confirmed_on : str
        The level at which the shift brought the start model within its floor, and the
        level (or held-back segment) at which it confirmed it.
    misfit_before, misfit_after : tuple of float
        The start model's misfit at those two levels, as recorded and aligned.
    limit : float
        The deciding level's floor (`Floor.limit`) after the shift.
    noise : float
        The confirming level's noise (`Floor.noise`), the drop its misfit had to exceed.
    resolution : float
        A fractional delay's resolution, samples: the half-width of its 95 % interval, read
        line by line (`_line_delay`); 0 for a whole-sample delay.
    """

    samples: float
    decided_on: str
    confirmed_on: str
    misfit_before: tuple[float, float]
    misfit_after: tuple[float, float]
    limit: float
    noise: float
    resolution: float = 0.0

    def note(self) -> str:
        """The warnings line: what was found, the numbers that decided it, what to do."""
        said = self.stated
        n = abs(said)
        way = "lag" if self.samples > 0 else "lead"
        size = (f"{n:g} sample{'s' * (n != 1)}" if not self.resolution else
                f"{n:g} samples (95 % interval {self.samples - self.resolution:.3f} to "
                f"{self.samples + self.resolution:.3f}, read line by line on "
                f"{self.decided_on})")
        return (f"the responses {way} the force by {size}: taken out "
                f"(start model misfit {self.misfit_before[0]:.3g} -> {self.misfit_after[0]:.3g} "
                f"at {self.decided_on}, floor {self.limit:.3g}; {self.misfit_before[1]:.3g} -> "
                f"{self.misfit_after[1]:.3g} at {self.confirmed_on}); store the run aligned with "
                f"`nlid-lab import ... response_delay={said:g}`")

    @property
    def stated(self) -> float:
        """``samples`` to the resolution the data carry (`analysis.modal.DelayReading.stated`:
        the shortest decimal within ``resolution``)."""
        return DelayReading(self.samples, self.samples - self.resolution,
                            self.samples + self.resolution).stated

    def to_json(self) -> dict[str, object]:
        return {"samples": self.samples, "decided_on": self.decided_on,
                "confirmed_on": self.confirmed_on, "misfit_before": list(self.misfit_before),
                "misfit_after": list(self.misfit_after), "limit": self.limit,
                "noise": self.noise, "resolution": self.resolution}

    @classmethod
    def from_json(cls, data: dict) -> ResponseDelay:
        samples = float(data["samples"])
        return cls(int(samples) if samples.is_integer() else samples, data["decided_on"],
                   data["confirmed_on"], tuple(data["misfit_before"]),
                   tuple(data["misfit_after"]), float(data["limit"]), float(data["noise"]),
                   float(data.get("resolution", 0.0)))


def shifted(p: Prepared, d: float) -> Prepared:
    """``p`` with its motion moved ``d`` samples earlier against its force.

    A periodic record (steady whole periods) is rolled within each period (a fraction by the
    phase ramp of each period's lines), exact for a steady response; a random one drops
    ``|d|`` samples at one end (a fraction: the ramp over the whole record, and
    `FRACTION_EDGE` samples at each end where it wraps around).
    """
    if d == 0:
        return p
    if not float(d).is_integer():
        return _fraction_shifted(p, float(d))
    d = int(d)
    if p.period is not None:
        def roll(a: np.ndarray) -> np.ndarray:
            return np.roll(a.reshape(-1, p.period, a.shape[1]), -d, axis=1).reshape(a.shape)
        return replace(p, x=roll(p.x), v=roll(p.v))
    n = p.x.shape[0]
    motion, force = (slice(d, n), slice(0, n - d)) if d > 0 else (slice(0, n + d), slice(-d, n))
    hit = None if p.clipped is None else p.clipped[motion] | p.clipped[force]
    return replace(p, x=p.x[motion], v=p.v[motion], force=p.force[force], clipped=hit)


def _fraction_shifted(p: Prepared, d: float) -> Prepared:
    """`shifted` by a delay that is not a whole number of samples."""
    n = p.x.shape[0] if p.period is None else p.period

    def move(a: np.ndarray) -> np.ndarray:
        blocks = a.reshape(-1, n, a.shape[1])
        ramp = np.exp(2j * np.pi * np.fft.rfftfreq(n) * d)[None, :, None]
        return np.fft.irfft(np.fft.rfft(blocks, axis=1) * ramp, n, axis=1).reshape(a.shape)
    if p.period is not None:
        return replace(p, x=move(p.x), v=move(p.v))
    keep = slice(FRACTION_EDGE + int(np.ceil(abs(d))), n - FRACTION_EDGE - int(np.ceil(abs(d))))
    return replace(p, x=move(p.x)[keep], v=move(p.v)[keep], force=p.force[keep],
                   clipped=None if p.clipped is None else p.clipped[keep])


def aligned(preps: list[Prepared], misfit: Misfit, ratio: Ratio
            ) -> tuple[list[Prepared], ResponseDelay | None]:
    """``preps`` (ascending levels) with the responses' delay taken out, when the lowest level
    decides it and the next confirms it (module docstring); the delay found, or None.

    Parameters
    ----------
    preps : list of Prepared
        Every level, lowest first.
    misfit : callable
        The start model's misfit and floor at one prepared level.
    ratio : callable
        The measured FRF over the start model's at one prepared level (a fraction of a
        sample is read off it, `_line_delay`).

    Returns
    -------
    preps : list of Prepared
        Shifted by the delay found (the same list when none).
    delay : ResponseDelay or None
    """
    low, nxt = (preps[0], preps[1]) if len(preps) > 1 else split_segment(preps[0])
    m0, floor0 = misfit(low)
    if m0 <= floor0.limit:
        return _held_fraction(preps, misfit, ratio)
    found = _best_shift(low, misfit, m0)
    if found is None or found[1] > found[2].limit:
        return _fraction_aligned(preps, misfit, ratio, 0 if found is None else found[0])
    best, m_best, floor_best = found
    c0, floor_c = misfit(nxt)
    c1, _ = misfit(shifted(nxt, best))
    if c0 - c1 <= floor_c.noise:
        return preps, None
    delay = ResponseDelay(best, low.label, nxt.label, (m0, c0), (m_best, c1),
                          floor_best.limit, floor_c.noise)
    return [shifted(p, best) for p in preps], delay


def _fraction_aligned(preps: list[Prepared], misfit: Misfit, ratio: Ratio, near: int
                      ) -> tuple[list[Prepared], ResponseDelay | None]:
    """`aligned` when no whole-sample shift brings the lowest level within its floor: the
    delay read line by line on the lowest level's first 70 % (`_line_delay`), taken out when
    that brings the segment within its floor and lowers its misfit by more than its noise,
    confirmed by the same reading on its last 30 % (the two within their combined 95 %
    intervals). Not on the next level, unlike the whole-sample rule: where the effect acts it
    moves the phase near the resonances too."""
    fit, held = split_segment(preps[0])
    best, resolution = _line_delay(fit, ratio, near)
    m_fit, floor_fit = misfit(fit)
    m_best, floor_best = misfit(shifted(fit, best))
    if m_best > floor_best.limit or m_fit - m_best <= floor_fit.noise:
        # within the floor but by less than the noise: a level-dependent effect's phase at
        # the lowest level (chain-quadratic12-disp-random read -0.28 sample once: 0.145 ->
        # 0.113 against a floor of 0.127 and a noise of 0.096)
        return preps, None
    check, spread = _line_delay(held, ratio, near)
    if abs(check - best) > np.hypot(resolution, spread):
        return preps, None
    c0, floor_c = misfit(held)
    delay = ResponseDelay(best, fit.label, held.label, (m_fit, c0),
                          (m_best, misfit(shifted(held, best))[0]), floor_best.limit,
                          floor_c.noise, resolution)
    return [shifted(p, best) for p in preps], delay


def _held_fraction(preps: list[Prepared], misfit: Misfit, ratio: Ratio
                   ) -> tuple[list[Prepared], ResponseDelay | None]:
    """`aligned` when the start model holds the lowest level within its floor as recorded: a
    fraction of a sample small enough for that (0.3 sample on ``chain-cubic01-disp-random``:
    misfit 0.101 against a floor of 0.105) still turns the higher levels' phase, and the
    diagnosis named a quadratic spring and a stiffness error for the cubic. Taken out only
    when both segments of the lowest level read it line by line at `STRICT` confidence
    (their intervals exclude 0, on the same side, and agree with each other) and the shift
    lowers the first segment's misfit, and it is at least `MIN_FRACTION`."""
    fit, held = split_segment(preps[0])
    (best, sure), (check, spread) = (_line_delay(q, ratio, 0, STRICT) for q in (fit, held))
    if (min(abs(best) - sure, abs(check) - spread, abs(best) - MIN_FRACTION) <= 0
            or best * check <= 0 or abs(best - check) > np.hypot(sure, spread)):
        return preps, None
    m_fit, _ = misfit(fit)
    m_best, floor_best = misfit(shifted(fit, best))
    if m_best >= m_fit:
        return preps, None
    c0, floor_c = misfit(held)
    resolution = sure * 1.96 / STRICT
    delay = ResponseDelay(best, fit.label, held.label, (m_fit, c0),
                          (m_best, misfit(shifted(held, best))[0]), floor_best.limit,
                          floor_c.noise, resolution)
    return [shifted(p, best) for p in preps], delay


def _line_delay(p: Prepared, ratio: Ratio, near: int, z: float = 1.96
                ) -> tuple[float, float]:
    """The responses' delay at ``p`` read line by line, samples, and the half-width of its
    interval (``z`` standard normal quantiles: 95 % by default).

    Each line and DOF of the measured FRF over the start model's gives a delay, its phase
    over the line's frequency (within a sample of ``near``); the reading is their median. A
    pure delay turns every line alike; the start model's own error and the level's effect
    turn the phase near the resonances only (a few lines of many), which moves a misfit- or
    modal-fit-weighted reading (dominated by those lines) but not the median (measured on
    ``chain-cubic01-disp-random-delay`` rebuilt with 0.5 sample: 0.496 line by line,
    0.446 by the start model's misfit, 0.444 by a modal fit of the level). The half-width
    is the distribution-free interval of a median (order statistics ``n/2 +- z sqrt(n)/2``)
    counted in lines, not values: the DOFs of one line share its force spectrum, and adjacent
    lines are correlated (``bin_factor``)."""
    freqs, r, bin_factor = ratio(p)
    w = (2 * np.pi * freqs / p.fs).reshape((-1,) + (1,) * (r.ndim - 1))
    lines = near - np.angle(r * np.exp(1j * w * near)) / w
    values = np.sort(lines[np.isfinite(lines)].ravel())
    n = values.size
    k = z * np.sqrt(freqs.size * max(bin_factor, 1.0)) / 2 * n / freqs.size    # ranks
    lo, hi = values[max(int(n / 2 - k), 0)], values[min(int(np.ceil(n / 2 + k)), n - 1)]
    return float(np.median(values)), float(hi - lo) / 2


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
