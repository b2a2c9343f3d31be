"""A linear error of a ``[modal]`` model corrects its modes, not its residual pseudo-modes
(`analysis.diagnose._linear_update`): the closed-form updates agree with the corrected model,
and a negative stiffness correction beyond a low pseudo-mode's fictitious static stiffness
leaves the model valid (`circuit-cubic-acc-multisine`: a 1 Hz pseudo-mode of stiffness 39.5,
participation 0.23, beside a 23 Hz mode)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.diagnose._linear_update import (correction_q, modes_model, updated_frf,
                                              updated_receptance)
from analysis.diagnose._select import Fit, corrected_model
from analysis.models import Candidate, Model, library

FREQS = np.linspace(5.0, 60.0, 56)


def _circuit_like(coupling: float = 0.0) -> Model:
    """The accelerometer circuit's start model: a 23 Hz mode and a 1 Hz pseudo-mode."""
    c = None if not coupling else [[0.0, coupling], [coupling, 0.0]]
    return Model.modal([23.0], [0.02], [[0.99]], points=["0"], residual_freqs_hz=[1.0],
                       residual_damping=[0.05], residual_shapes=[[0.23]], damping_coupling=c)


def _error(model: Model, kind: str) -> Candidate:
    return next(c for c in library(model.n_dof, model.points, model.support) if c.kind == kind)


def test_a_correction_leaves_the_pseudo_modes_out():
    m = _circuit_like()
    w = np.ones(1)
    assert m.stiffness_along(w) < 843.0            # the pseudo-mode's static stiffness
    np.testing.assert_array_equal(correction_q(m, w), [0.99, 0.0])
    lin = _error(m, "stiffness_error")
    fixed = corrected_model(m, Fit(lin, {"delta_stiffness": -843.0}, {}, 0.0, 0.0))
    assert np.linalg.eigvalsh(fixed.stiffness).min() > 0
    np.testing.assert_allclose(np.diag(fixed.stiffness),
                               [(2 * np.pi * 23.0) ** 2 - 843.0 * 0.99 ** 2,
                                (2 * np.pi * 1.0) ** 2], rtol=1e-12)


@pytest.mark.parametrize("kind, delta", [("stiffness_error", -843.0),
                                         ("damping_error", 3.0), ("mass_error", 0.05)])
def test_the_closed_form_updates_are_the_corrected_models(kind, delta):
    m = _circuit_like()
    lin = _error(m, kind)
    fixed = corrected_model(m, Fit(lin, {"x": delta}, {}, 0.0, 0.0))
    H, Hm = m.linear_frf(FREQS), modes_model(m).linear_frf(FREQS)
    H2, Hm2 = updated_receptance(H, Hm, kind, lin.w, delta, FREQS)
    scale = np.abs(H).max()
    np.testing.assert_allclose(H2, fixed.linear_frf(FREQS), rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(Hm2, modes_model(fixed).linear_frf(FREQS), rtol=0,
                               atol=1e-12 * scale)
    B = np.ones((1, 1))      # a level FRF of the linear part alone: H0 = H B
    np.testing.assert_allclose(updated_frf(lin, delta, FREQS, Hm, Hm @ B, H @ B),
                               fixed.linear_frf(FREQS) @ B, rtol=0, atol=1e-12 * scale)


def test_without_pseudo_modes_or_with_coupled_ones_the_whole_shape_is_corrected():
    lumped = Model(np.eye(2), 0.1 * np.eye(2), np.array([[2.0, -1.0], [-1.0, 2.0]]) * 1e4)
    w = np.array([1.0, -1.0])
    np.testing.assert_array_equal(correction_q(lumped, w), w)
    assert modes_model(lumped) is None
    coupled = _circuit_like(coupling=0.5)
    np.testing.assert_array_equal(correction_q(coupled, np.ones(1)), [0.99, 0.23])
    assert modes_model(coupled) is None
