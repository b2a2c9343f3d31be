"""A model through the same stepped-sine test: every level's steps simulated by harmonic
balance at the force each step measured, as tables of the same layout (so that the same
backbone estimator reads the model as it read the test: `nlid-lab backbone --model`)."""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from ..hbm import HBMSystem
from ..models import Model
from ..recordings import KIND_ORDER, StepTable


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
        Per level: the same steps, force amplitudes, control and response kind; the
        response phasors the model gives (fundamental, phase referenced to the force).
    """
    out = []
    for t in tables:
        system = HBMSystem(model, [int(t.force_dofs[0])], harmonics)
        F = np.abs(t.force_phasor[:, 0])
        x = system.sweep(t.freqs, F[:, None]).X[:, list(system.harmonics).index(1)]
        order = np.array([KIND_ORDER[k] for k in (t.sensors.response_kinds if t.sensors
                                                  else (t.response_kind,) * x.shape[1])])
        resp = x * (2j * np.pi * t.freqs[:, None]) ** order[None, :]
        out.append(replace(t, force_phasor=F[:, None].astype(complex), response_phasor=resp,
                           harmonics=(), force_harmonics=None, response_harmonics=None))
    return out
