"""A model through the same stepped-sine test: every level's steps simulated by harmonic
balance, as tables of the same layout (so that the same backbone estimator reads the model as
it read the test: `nlid-lab backbone --model`). A force-controlled level is simulated at the
force each step measured; a response-controlled one holds what the test held: each step is
solved with the response amplitude at the held channel fixed and the force amplitude unknown
(`analysis.hbm.sweep_held`), so a stiffening model's middle branch (three responses at one
force) is held like any other."""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from ..hbm import HBMSystem, sweep_held
from ..models import Model
from ..recordings import KIND_ORDER, Control, StepTable


def model_tables(model: Model, tables: Sequence[StepTable],
                 harmonics: Sequence[int] = (1, 3, 5, 7)) -> list[StepTable]:
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
    list of StepTable
        Per level: the same steps, control and response kind; the force amplitudes (held
        response: the ones that hold it on the model) and the response phasors the model
        gives (fundamental, phase referenced to the force).
    """
    out = []
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
        out.append(replace(t, force_phasor=F.astype(complex), response_phasor=x * iw ** order,
                           harmonics=(), force_harmonics=None, response_harmonics=None))
    return out
