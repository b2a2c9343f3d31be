"""A model through the same stepped-sine test: every level's steps simulated by harmonic
balance, as tables of the same layout (so that the same backbone estimator reads the model as
it read the test: `nlid-lab backbone --model`). A force-controlled level is simulated at the
force each step measured; a response-controlled one holds what the test held: each step is
solved with the response amplitude at the held channel fixed and the force amplitude unknown
(`analysis.hbm.sweep_held`), so a stiffening model's middle branch (three responses at one
force) is held like any other. A step whose balance does not converge is left out of the
model's table and reported (`ModelTables.unconverged`), not kept as its last iterate."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ..hbm import HBMSystem, sweep_held
from ..models import Model
from ..recordings import KIND_ORDER, Control, StepTable


@dataclass(frozen=True)
class ModelTables:
    """A model through the measured steps.

    Attributes
    ----------
    tables : list of StepTable
        Per level, the model's table (the converged steps).
    unconverged : tuple of (float, float)
        ``(level, frequency_hz)`` of every step whose balance did not converge (left out).
    """

    tables: list[StepTable]
    unconverged: tuple[tuple[float, float], ...] = ()

    def summary(self) -> str:
        """One line naming the steps left out (count and frequencies), '' when none."""
        if not self.unconverged:
            return ""
        steps = ", ".join(f"{f:.2f} Hz (level {lv:g})" for lv, f in self.unconverged)
        return (f"warning: {len(self.unconverged)} held step(s) of the model did not converge "
                f"and are left out of its backbone: {steps}")


def model_tables(model: Model, tables: Sequence[StepTable],
                 harmonics: Sequence[int] = (1, 3, 5, 7)) -> ModelTables:
    """``tables`` with their responses replaced by ``model``'s.

    Parameters
    ----------
    model : Model
        Complete model whose DOFs are the tables' response channels (one force input).
    tables : sequence of StepTable
        Measured levels (one force channel each).
    harmonics : sequence of int
        Harmonic orders of the balance.

    Returns
    -------
    ModelTables
        Per level: the same steps (those whose balance converged), control and response
        kind; the force amplitudes (held response: the ones that hold it on the model) and
        the response phasors the model gives (fundamental, phase referenced to the force);
        and the steps left out.
    """
    out, bad = [], []
    for t in tables:
        system = HBMSystem(model, [int(t.force_dofs[0])], harmonics)
        F = np.abs(t.force_phasor[:, :1])
        kinds = t.sensors.response_kinds if t.sensors else (t.response_kind,) * t.n_dof
        order = np.array([KIND_ORDER[k] for k in kinds])
        iw = 2j * np.pi * t.freqs[:, None]
        if t.control == Control.RESPONSE:
            j = t.control_dof
            held = np.abs(t.response_phasor[:, j] / iw[:, 0] ** order[j])   # displacement
            res, F = sweep_held(system, t.freqs, np.ones_like(F), j, held)
        else:
            res = system.sweep(t.freqs, F)
        x = res.X[:, list(system.harmonics).index(1)]
        ok = np.asarray(res.converged, dtype=bool)
        bad += [(float(t.level), float(f)) for f in t.freqs[~ok]]
        extra = {k: v[ok] for k, v in t.extra.items() if np.shape(v)[:1] == ok.shape}
        out.append(replace(t, freqs=t.freqs[ok], force_phasor=F[ok].astype(complex),
                           response_phasor=(x * iw ** order)[ok], harmonics=(),
                           force_harmonics=None, response_harmonics=None, extra=extra))
    return ModelTables(out, tuple(bad))
