"""Modal parameters of the underlying linear FRF column."""

import numpy as np
import pytest

from analysis.modal import modal_fit
from analysis.model import Model


def test_three_dof_modes():
    m = Model.load("examples/models/three-dof-paper.toml")
    f = np.linspace(20, 400, 800)
    res = modal_fit(f, m.linear_frf(f, [0]), 3)
    n = 3
    a = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(m.mass, m.stiffness), -np.linalg.solve(m.mass, m.damping)]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    np.testing.assert_allclose(res.freqs_hz, np.abs(lam) / 2 / np.pi, rtol=1e-6)
    np.testing.assert_allclose(res.damping, -lam.real / np.abs(lam), rtol=1e-5)
    shape0 = np.real(res.shapes[0])
    assert np.all(shape0 > 0)                           # first mode in phase
    assert len(res.to_json()) == 3 and res.to_json()[0]["freq_hz"] == pytest.approx(70.83, abs=0.01)
