"""A model through the same stepped-sine test: every level's steps simulated by harmonic
balance, as tables of the same layout (so that the same backbone estimator reads the model as
it read the test: `nlid-lab backbone --model`). A force-controlled level is simulated at the
force each step measured; a response-controlled one holds what the test held: each step's
force is scaled until the model's response at the held channel has the measured amplitude
(secant iteration in log force per step, `HOLD_ITERATIONS`, as a controller does; the slope
of amplitude over force is far from 1 where a slider starts to slip)."""

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


def _response(system: HBMSystem, t: StepTable, F: np.ndarray, order: np.ndarray,
              guess: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fundamental response phasors in the table's kinds, and the element deformations
    (each step's next start: a held step follows its own branch as its force changes)."""
    res = system.sweep(t.freqs, F[:, None], guess=guess)
    x = res.X[:, list(system.harmonics).index(1)]
    return x * (2j * np.pi * t.freqs[:, None]) ** order[None, :], res.U


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
        resp, U = _response(system, t, F, order)
        if t.control == Control.RESPONSE:
            j = t.control_dof
            target = np.abs(t.response_phasor[:, j])
            slope = np.ones_like(F)          # d log|x| / d log F, secant estimate per step
            for _ in range(HOLD_ITERATIONS):
                amp = np.maximum(np.abs(resp[:, j]), 1e-300)
                miss = np.log(target / amp)
                if np.max(np.abs(miss)) < HOLD_TOL:
                    break
                F_new = F * np.exp(miss / slope)
                # each step starts at the held amplitude: a stiffening model has up to
                # three responses at one force, and the held one is on its own branch
                guess = U * (target / amp)[:, None, None] if U.size else None
                resp_new, U = _response(system, t, F_new, order, guess)
                d_log_a = np.log(np.maximum(np.abs(resp_new[:, j]), 1e-300) / amp)
                d_log_f = np.log(F_new / F)
                moved = np.abs(d_log_f) > 1e-12
                # negative on a stiffening curve's middle branch, where the controller
                # holds an amplitude that a force alone would not
                ratio = d_log_a[moved] / d_log_f[moved]
                slope[moved] = np.where(ratio < 0, -1.0, 1.0) * np.clip(np.abs(ratio), 0.1,
                                                                        10.0)
                F, resp = F_new, resp_new
        out.append(replace(t, force_phasor=F[:, None].astype(complex), response_phasor=resp,
                           harmonics=(), force_harmonics=None, response_harmonics=None))
    return out
