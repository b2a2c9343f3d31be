"""The level of a recording: the force it applied, nominal or measured."""

from __future__ import annotations

import numpy as np

from ._recording import Recording


def measured_level(rec: Recording) -> float:
    """The force a level applied: rms of the DC-free force (random, multisine), largest
    amplitude (sines), largest over the force channels, N."""
    f = rec.force.reshape(-1, rec.n_in)
    if rec.excitation == "random":
        f = f - f.mean(axis=0)
        return float(np.sqrt(np.mean(f**2, axis=0)).max())
    return float(np.abs(f).max())


def record_level(rec: Recording) -> float:
    """Nominal level: the recording's own, else the rms (random) or amplitude (sine) force."""
    return float(rec.level) if rec.level is not None else measured_level(rec)
