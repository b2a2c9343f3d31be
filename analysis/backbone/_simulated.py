"""A model through the same stepped-sine test: every level's steps simulated by harmonic
balance, as tables of the same layout (so that the same backbone estimator reads the model as
it read the test: `nlid-lab backbone --model`). A force-controlled level is simulated at the
force each step measured; a response-controlled one holds what the test held: each step's
force is scaled until the model's response at the held channel has the measured amplitude
(fixed-point iteration, `HOLD_ITERATIONS`, as a controller does)."""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from ..hbm import HBMSystem
from ..models import Model
from ..recordings import KIND_ORDER, Control, StepTable

HOLD_ITERATIONS = 30
HOLD_TOL = 1e-6
"""Relative amplitude error at which a held step is settled."""


def _response(system: HBMSystem, t: StepTable, F: np.ndarray, order: np.ndarray
              ) -> np.ndarray:
    x = system.sweep(t.freqs, F[:, None]).X[:, list(system.harmonics).index(1)]
    return x * (2j * np.pi * t.freqs[:, None]) ** order[None, :]


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
        F = np.abs(t.force_phasor[:, 0])
        kinds = t.sensors.response_kinds if t.sensors else (t.response_kind,) * t.n_dof
        order = np.array([KIND_ORDER[k] for k in kinds])
        resp = _response(system, t, F, order)
        if t.control == Control.RESPONSE:
            j = t.control_dof
            target = np.abs(t.response_phasor[:, j])
            for _ in range(HOLD_ITERATIONS):
                ratio = target / np.maximum(np.abs(resp[:, j]), 1e-300)
                if np.max(np.abs(ratio - 1)) < HOLD_TOL:
                    break
                F = F * ratio
                resp = _response(system, t, F, order)
        out.append(replace(t, force_phasor=F[:, None].astype(complex), response_phasor=resp,
                           harmonics=(), force_harmonics=None, response_harmonics=None))
    return out
