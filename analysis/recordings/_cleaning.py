"""A random record as an export gives it, made ready as ``nlid-lab import`` would.

An export (a MAT or NPZ file handed straight to an analysis) may carry lead-in and trailing
zeros (the acquisition ran before the drive started and after it stopped) and, for a
periodic multisine, no layout and a last period cut short. ``nlid-lab import`` drops the
padding and finds the period; `clean_export` does the same for a `Recording` that did not
come through it (the diagnosis' records), with the same functions (`flat_ends`,
`find_period`, `whole_periods`), and says what it did.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ._periodicity import find_period, whole_periods
from ._recording import PeriodicLayout, Recording
from ._signals import flat_ends


@dataclass(frozen=True)
class CleanedExport:
    """A record without its export's padding, with the periodic layout its force shows.

    Attributes
    ----------
    recording : Recording
    lead_in, trailing : int
        Samples of padding dropped at each end (0: none).
    layout_found : bool
        Whether the layout was read off the force (the record had none and is periodic);
        the samples after the last whole period are then dropped.
    """

    recording: Recording
    lead_in: int = 0
    trailing: int = 0
    layout_found: bool = False

    def notes(self, label: str) -> list[str]:
        """What was done, one line each, for a summary naming the record ``label``."""
        out = []
        if self.lead_in or self.trailing:
            out.append(f"{label}: {self.lead_in} lead-in and {self.trailing} trailing samples "
                       "at which no channel moves (export padding) dropped")
        lay = self.recording.layout
        if self.layout_found and lay is not None:
            out.append(f"{label}: periodic, {lay.period}-sample period found in the force "
                       f"({lay.transient_periods} transient + {lay.periods} steady periods, "
                       f"{lay.realizations} realization(s)); give the period to override")
        return out


def clean_export(rec: Recording) -> CleanedExport:
    """``rec`` without its lead-in and trailing zeros and, when it has no layout and its force
    is periodic, cut to whole periods with the layout found.

    Only continuous random records without a layout are changed (a layout states where the
    periods lie, so its record is left as it is); stepped and swept records are returned as
    they are.

    Parameters
    ----------
    rec : Recording

    Returns
    -------
    CleanedExport
    """
    if rec.excitation != "random" or rec.layout is not None or rec.force.ndim != 2:
        return CleanedExport(rec)
    lead, tail = flat_ends(rec.force, rec.response)
    if lead or tail:
        n = rec.force.shape[0]
        rec = _cut(rec, lambda x: x[lead:n - tail])
    p = find_period(rec.force, settle=rec.response)
    if p is None:
        return CleanedExport(rec, lead, tail)
    layout = PeriodicLayout(p.period, p.transient_periods, p.whole - p.transient_periods,
                            p.realizations)
    if p.remainder or p.short:
        rec = _cut(rec, lambda x: whole_periods(x, p))
    return CleanedExport(replace(rec, layout=layout), lead, tail, True)


def _cut(rec: Recording, cut: Callable[[np.ndarray], np.ndarray]) -> Recording:
    """``rec`` with ``cut`` applied along time to every per-sample channel."""
    return replace(rec, force=cut(rec.force), response=cut(rec.response),
                   monitors={k: cut(v) for k, v in rec.monitors.items()})
