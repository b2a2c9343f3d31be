"""The diagnosis of runs with a sensor map on a modal model with more modes than measured
points: a candidate leaving the model's valid range is rejected (not an abort), replays restart
a modal model from the measured points, and messages name the points."""

import numpy as np
import pytest

from analysis.models import Candidate
from analysis.diagnose._compare import LevelFRF
from analysis.diagnose._leakage import Floor
from analysis.diagnose._outofsample import Predictor
from analysis.diagnose._policy import decide
from analysis.diagnose._prepare import Prepared
from analysis.diagnose._replay import horizon_samples, replay, state_map
from analysis.diagnose._select import Fit
from analysis.models import Element
from analysis.plant import Plant
from structures import beam_with_payload

POINTS = ["drive", "joint", "payload"]


def modal_at_three_points(elements=()):
    """The beam with payload in [modal] form: 6 modes seen at 3 points."""
    s = beam_with_payload()
    m = s.model.modal_form([s.points[p] for p in POINTS], POINTS, n_modes=6)
    return m.with_elements(list(elements)) if elements else m


def test_state_map_reproduces_the_measured_points():
    m = modal_at_three_points()
    assert m.n_q == 6 and m.n_dof == 3
    for w in (m.stiffness, m.mass):
        assert np.allclose(m.shapes @ state_map(m, w), np.eye(3), atol=1e-9)
    s = beam_with_payload().model        # a model over its points: the identity
    assert np.array_equal(state_map(s, s.stiffness), np.eye(s.n_q))


@pytest.mark.parametrize("kind,params", [("gap", {"k": 2e5, "g": None}),
                                         ("cubic_spring", {"p": 1e10})])
def test_replay_of_a_modal_model_at_fewer_points(kind, params):
    """Short-horizon replays restart the 6-mode model from 3 measured points (they failed
    with 'state entry x has shape (3,), this plant needs (6,)'); the exact model predicts the
    motion better than predicting rest (relative residual 1). The unobserved modes start at
    the least-energy state, so the residual is not zero (measured, gap: 0.62 at the drive,
    where the white force excites the high modes most, 0.18 and 0.21 at joint and payload)."""
    fs, n = 1024.0, 16384
    rng = np.random.default_rng(3)
    force = 20.0 * rng.standard_normal((n, 1))
    lin = modal_at_three_points()
    x0 = Plant(lin, fs, [0]).run(force)
    w = np.array([0.0, -1.0, 1.0])
    if params.get("g", 0) is None:       # contact at the peaks of the joint deformation
        params = dict(params, g=2.0 * float(np.std(x0.displacement @ w)))
    model = modal_at_three_points([Element(kind, w, params)])
    out = Plant(model, fs, [0]).run(force)
    p = Prepared(out.displacement, out.velocity, force, np.array([0]), fs, 20.0, None, "test")
    r = replay(model, p, horizon_samples(model, fs), max_samples=2048)
    assert np.all(np.isfinite(r.residual)) and r.residual.shape == (3,)
    assert np.all(r.residual < 1.0) and r.residual[1:].max() < 0.5, r.residual


class _Search:
    """One 1x1 'level' whose measured FRF is ``1 + 0.1 b`` plus 1 % noise; every candidate
    is scored as that effect (its own `Predictor`), so both below would win out of sample."""

    def __init__(self):
        rng = np.random.default_rng(4)
        f = np.linspace(1.0, 50.0, 256)
        self.b = np.exp(-((f - 20.0) / 8.0) ** 2)[:, None, None] + 0j
        noise = 0.01 * (rng.standard_normal(self.b.shape) + 1j * rng.standard_normal(
            self.b.shape)) / np.sqrt(2)
        ones = np.ones((f.size, 1, 1))
        self.levels = [LevelFRF(f"level {i}", float(i), f, 1.0 + 0.1 * self.b + noise * k,
                                ones, 1e-4 * ones, np.ones((1, 1)))
                       for i, k in ((1, 1.0), (2, -1.0))]
        self.H0s = [np.ones_like(lf.H) for lf in self.levels]
        self.chi2_0 = 100.0
        self.n_values = float(sum(lf.n_values for lf in self.levels))

    def predictor(self, fit, joint=False, earlier=()):
        return Predictor(lambda t: [1.0 + t[0] * self.b for _ in self.levels],
                         np.array([0.1]), 1, np.array([0.1]))

    def companions(self, fit):
        return []


def test_candidate_leaving_the_valid_range_is_rejected_not_raised():
    """A stuck stiffness taken from the linear part that makes K indefinite rejects that
    candidate, with the reason in its evidence; the next one is decided on."""
    m = modal_at_three_points()
    bad = Fit(Candidate("hysteresis", (1, 2), 3, compensated=True, names=tuple(POINTS)),
              {"kd": 1e9, "fd": 10.0, "n": 1.0}, {}, 1.0, 1e4)
    good = Fit(Candidate("cubic_spring", (1, 2), 3, names=tuple(POINTS)), {"p": 1e10}, {},
               2.0, 1e4)
    search = _Search()
    step = decide(m, search, [bad, good], lambda fixed: 1.0, [Floor(0.0, 0.0, 0.01)] * 2)
    assert step.found and step.best is good
    assert step.rejected[0].candidate == bad.cand.label
    assert "valid range" in step.rejected[0].reason
    assert bad.evidence["rejected"] == step.rejected[0].reason


def test_unexplained_names_the_points():
    """The misfit location is given by point name (JSON ``location.points`` beside the
    ``dofs`` indices) and the sentence uses the names."""
    from analysis.diagnose._report import place
    assert place([1, 2], ["joint", "payload"]) == "at joint, payload"
    assert place([1, 2], ["1", "2"]) == "on DOF(s) 1, 2"
    assert place([1, 2], None) == "on DOF(s) 1, 2"
