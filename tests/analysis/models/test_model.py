"""Model files: load, validate, round trip of every kind, and each class of bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis.models import (KINDS, MAX_DOF, MAX_ELEMENTS, MAX_TOML_BYTES, Element, Model,
                            ModelTables)
from analysis.models._model_toml import SupportTable
from analysis.models._support import SUPPORT_KEYS
from analysis.errors import InputError, ModelError

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "models"

PARAMS = {"cubic_spring": {"p": 3e9}, "quadratic_spring": {"p": -2e5},
          "quadratic_damping": {"p": 20.0}, "cubic_damping": {"p": 1e3},
          "coulomb_friction": {"fc": 5.0, "v_reg": 1e-2}, "stick_slip": {"kd": 1e6, "fd": 20.0},
          "hysteresis": {"kd": 1e6, "fd": 20.0, "n": 2.0}, "gap": {"k": 1e7, "g": 1e-4},
          "iwan": {"kd": 1e6, "fd": 20.0, "chi": -0.4, "beta": 0.0}}

LINEAR = """
[linear]
mass = [[1.0, 0.0], [0.0, 2.0]]
damping = [[20.0, -10.0], [-10.0, 20.0]]
stiffness = [[2e4, -1e4], [-1e4, 2e4]]
"""


def test_every_kind_is_covered():
    assert set(PARAMS) == set(KINDS)


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.stem)
def test_examples_load_and_round_trip(path, tmp_path):
    model = Model.load(path)
    assert model.complete == ("candidate" not in path.stem)   # candidates leave values out
    model.save(tmp_path / "m.toml")
    back = Model.load(tmp_path / "m.toml")
    assert back.to_dict() == model.to_dict()


@pytest.mark.parametrize("kind", sorted(PARAMS))
def test_round_trip_every_kind(kind, tmp_path):
    model = Model(np.diag([1.0, 2.0]), np.diag([3.0, 4.0]), [[2e4, -1e4], [-1e4, 2e4]],
                  [Element(kind, [0.0, 1.0], dict(PARAMS[kind])),
                   Element(kind, [-1.0, 1.0], {})], name=f"all {kind}")
    assert not model.complete and model.elements[1].missing == list(KINDS[kind].params)
    path = tmp_path / "m.toml"
    model.save(path)
    back = Model.load(path)
    assert back.name == f"all {kind}"
    np.testing.assert_array_equal(back.mass, model.mass)
    np.testing.assert_array_equal(back.elements[1].w, [-1.0, 1.0])
    assert back.elements[0].params == PARAMS[kind] and back.elements[1].params == {}
    with pytest.raises(ModelError, match="needs every parameter"):
        back.require_complete("simulation")


def test_all_errors_are_input_errors():
    assert issubclass(ModelError, InputError)


def _load_text(tmp_path, text):
    path = tmp_path / "m.toml"
    path.write_text(text)
    return Model.load(path)


@pytest.mark.parametrize("text,match", [
    ("name = 'x'\n[linear\nmass = 1", "not valid TOML"),
    ("name = 'x'\n", r"no \[linear\] table"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[0.0]]\n", "lacks 'stiffness'"),
    ("[linear]\nmass = [[1.0, 0.0]]\ndamping = [[0.0]]\nstiffness = [[1.0]]\n", "square"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[0.0]]\nstiffness = [[1.0, 0], [0, 1]]\n",
     "same size"),
    ("[linear]\nmass = [[1.0, 0.5], [0.0, 1.0]]\ndamping = [[0, 0], [0, 0]]\n"
     "stiffness = [[1, 0], [0, 1]]\n", "mass is not symmetric"),
    ("[linear]\nmass = [[1.0, 0.0], [0.0, -1.0]]\ndamping = [[0, 0], [0, 0]]\n"
     "stiffness = [[1, 0], [0, 1]]\n", "not positive definite"),
    ("[linear]\nmass = [[0.0]]\ndamping = [[0.0]]\nstiffness = [[1.0]]\n",
     "not positive definite"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[0.0]]\nstiffness = [[-1.0]]\n",
     "negative eigenvalue"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[0.0]]\nstiffness = [[nan]]\n", "NaN"),
    ("[linear]\nmass = [[1.0]]\ndamping = [['a']]\nstiffness = [[1.0]]\n",
     r"linear.damping\[0\]\[0\] = 'a' is not a number"),
    ("unit = 'mm'\n[linear]\nmass = [[1.0]]\ndamping = [[0.0]]\nstiffness = [[1.0]]\n",
     "top level: unknown key 'unit'"),
])
def test_bad_model_files(tmp_path, text, match):
    with pytest.raises(ModelError, match=match):
        _load_text(tmp_path, text)


@pytest.mark.parametrize("element,match", [
    ("kind = 'spline_spring'\nw = [1.0, 0.0]\np = 1.0", "unknown kind 'spline_spring'"),
    ("w = [1.0, 0.0]\np = 1.0", "has no 'kind'"),
    ("kind = 'cubic_spring'\np = 1.0", "no position vector"),
    ("kind = 'cubic_spring'\nw = [1.0, 0.0, 0.0]\np = 1.0", "w has 3 entries"),
    ("kind = 'cubic_spring'\nw = [0.0, 0.0]\np = 1.0", "not all zero"),
    ("kind = 'cubic_spring'\nw = [1.0, 0.0]\nq = 1.0", "unknown parameter 'q'"),
    ("kind = 'cubic_spring'\nw = [1.0, 0.0]\np = nan", "not a finite number"),
    ("kind = 'cubic_spring'\nw = [1.0, 0.0]\np = 'big'", "p = 'big' is not a number"),
    ("kind = 'stick_slip'\nw = [1.0, 0.0]\nkd = 1e6\nfd = -2.0", "fd must be > 0"),
])
def test_bad_elements(tmp_path, element, match):
    with pytest.raises(ModelError, match=match):
        _load_text(tmp_path, LINEAR + "\n[[element]]\n" + element + "\n")


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        Model.load(tmp_path / "missing.toml")
    with pytest.raises(ModelError, match="not a regular file"):
        Model.load(tmp_path)
    (tmp_path / "bin.toml").write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(ModelError):
        Model.load(tmp_path / "bin.toml")


def test_missing_parameter_named_at_simulate_time(tmp_path):
    model = _load_text(tmp_path, LINEAR + "\n[[element]]\nkind = 'hysteresis'\n"
                       "w = [1.0, -1.0]\nkd = 1e6\n")
    assert model.elements[0].missing == ["fd", "n"]
    with pytest.raises(ModelError, match=r"element 0 \(hysteresis\) has no value for fd, n"):
        model.require_complete("simulation")


def test_linear_frf_matches_direct_inverse():
    model = Model.loads(LINEAR)
    h = model.linear_frf([0.0, 10.0], force_dofs=[1])
    np.testing.assert_allclose(h[0, :, 0], np.linalg.solve(model.stiffness, [0.0, 1.0]))
    w = 2 * np.pi * 10.0
    z = -w**2 * model.mass + 1j * w * model.damping + model.stiffness
    np.testing.assert_allclose(h[1, :, 0], np.linalg.solve(z, [0.0, 1.0]), rtol=1e-12)


LIN1 = "[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstiffness = [[1e4]]\n"


@pytest.mark.parametrize("text,match", [
    ("[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstiffness = [['1e4']]\n",
     r"linear.stiffness\[0\]\[0\] = '1e4' is not a number"),
    ("[linear]\nmass = [[true]]\ndamping = [[1.0]]\nstiffness = [[1e4]]\n",
     r"linear.mass\[0\]\[0\] = True is not a number"),
    ("[linear]\nmass = 1.0\ndamping = [[1.0]]\nstiffness = [[1e4]]\n",
     "linear.mass = 1.0 is not a matrix"),
    ("[linear]\nmass = [1.0]\ndamping = [[1.0]]\nstiffness = [[1e4]]\n",
     "linear.mass row 0 = 1.0 is not a list"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstifness = [[1e4]]\n",
     r"\[linear\]: unknown key 'stifness'; did you mean 'stiffness'\?"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstiffness = [[1e4]]\nmas = [[1.0]]\n",
     "unknown key 'mas'; did you mean 'mass'"),
    ("nme = 'x'\n" + LIN1, "unknown key 'nme'; did you mean 'name'"),
    ("name = 3\n" + LIN1, "name must be a string"),
    ("[linear]\nmass = [[1e308]]\ndamping = [[1.0]]\nstiffness = [[1e4]]\n",
     "above 1e\\+15"),
    ("[linear]\nmass = [[1e-300]]\ndamping = [[1.0]]\nstiffness = [[1e4]]\n",
     "below 1e-12 kg"),
    ("[linear]\nmass = [[1.0]]\ndamping = [[1.0]]\nstiffness = [[9223372036854775807]]\n",
     "above 1e\\+15"),
    ("[linear]\nmass = [[1e-9]]\ndamping = [[0.0]]\nstiffness = [[1e12]]\n",
     "natural frequency or decay rate above 1e\\+07 Hz"),
    ("element = 3\n" + LIN1, "array of tables"),
])
def test_strict_schema_and_ranges(tmp_path, text, match):
    with pytest.raises(ModelError, match=match):
        _load_text(tmp_path, text)


@pytest.mark.parametrize("element,match", [
    ("kind = 'cubic_spring'\nw = [[1.0]]\np = 1.0", "w = \\[\\[1.0\\]\\] must be a flat list"),
    ("kind = 'cubic_spring'\nw = [true]\np = 1.0", "w = \\[True\\] must be a flat list"),
    ("kind = 'cubic_spring'\nw = 1.0\np = 1.0", "w = 1.0 must be a flat list"),
    ("kind = 'cubic_spring'\nw = [1.0]\np = true", "p = True is not a number"),
    ("kind = 'cubic_spring'\nw = [1.0]\nP = 1.0", "unknown parameter 'P'; did you mean 'p'"),
    ("kind = 'cubic_sprung'\nw = [1.0]\np = 1.0", "did you mean 'cubic_spring'"),
    ("kind = 'gap'\nw = [1.0]\nk = 0.0\ng = 1e-3", "k must be > 0"),
    ("kind = 'gap'\nw = [1.0]\nk = -1e4\ng = 1e-3", "k must be > 0"),
    ("kind = 'cubic_spring'\nw = [1.0]\np = 1e308", "outside -1e\\+30..1e\\+30"),
    ("kind = 'hysteresis'\nw = [1.0]\nkd = 1e4\nfd = 1.0\nn = 1e-300", "n = 1e-300 is outside"),
    ("kind = 'stick_slip'\nw = [1.0]\nkd = 1e20\nfd = 1.0",
     r"element 0 \(stick_slip\) makes a natural frequency"),
    ("kind = 'coulomb_friction'\nw = [1.0]\nfc = 1.0\nv_reg = 1e-300",
     r"element 0 \(coulomb_friction\) makes a natural frequency or decay rate"),
    ("kind = 'cubic_spring'\nw = [1e300]\np = 1.0", "w has an entry above"),
])
def test_strict_elements(tmp_path, element, match):
    with pytest.raises(ModelError, match=match):
        _load_text(tmp_path, LIN1 + "\n[[element]]\n" + element + "\n")


def test_size_bounds(tmp_path):
    many = "".join("\n[[element]]\nkind = 'cubic_spring'\nw = [1.0]\np = 1.0\n"
                   for _ in range(MAX_ELEMENTS + 1))
    with pytest.raises(ModelError, match=f"more than {MAX_ELEMENTS}"):
        _load_text(tmp_path, LIN1 + many)
    n = MAX_DOF + 1
    with pytest.raises(ModelError, match=f"more than {MAX_DOF} DOFs"):
        Model(np.eye(n), np.zeros((n, n)), np.eye(n))


def test_non_regular_and_huge_files_are_refused(tmp_path):
    with pytest.raises(ModelError, match="not a regular file"):
        Model.load("/dev/zero")
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(MAX_TOML_BYTES + 1)
    with pytest.raises(ModelError, match="more than"):
        Model.load(big)


MODAL = """
name = "gvt"
points = ["drive", "joint", "payload"]

[modal]
frequencies_hz = [6.6, 35.1]
damping_ratios = [0.01, 0.02]
shapes = [[0.2, 0.8, 0.9], [0.05, -0.4, 1.1]]
residual_frequencies_hz = [400.0]
residual_damping_ratios = [0.05]
residual_shapes = [[0.3, 0.1, 0.0]]

[[element]]
kind = "stick_slip"
between = ["joint", "payload"]
kd = 1e5
fd = 2.0
"""


def test_modal_form_round_trip_points_and_frf():
    m = Model.loads(MODAL)
    assert m.is_modal and m.n_dof == 3 and m.n_q == 3 and m.n_residual == 1
    np.testing.assert_array_equal(m.elements[0].w, [0.0, -1.0, 1.0])
    back = Model.loads(m.dumps())
    assert back.dumps() == m.dumps() and back.points == m.points
    # receptance = sum of phi phi' / (w_r^2 - w^2 + 2 i zeta w_r w), pseudo-mode included
    f = np.array([3.0, 20.0, 60.0])
    w, wr = 2 * np.pi * f, 2 * np.pi * np.array([6.6, 35.1, 400.0])
    z = np.array([0.01, 0.02, 0.05])
    phi = np.array([[0.2, 0.8, 0.9], [0.05, -0.4, 1.1], [0.3, 0.1, 0.0]])
    want = sum(np.outer(phi[r], phi[r])[None] / (wr[r] ** 2 - w[:, None, None] ** 2
                                                 + 2j * z[r] * wr[r] * w[:, None, None])
               for r in range(3))
    np.testing.assert_allclose(m.linear_frf(f), want, rtol=1e-12)


def test_receptance_evaluator_is_linear_frf_bit_for_bit():
    """`Model.receptance` (checks and contraction order worked out once) computes what the
    direct formulas compute, to the last bit, for one and for many frequencies."""
    diagonal = Model(np.diag([1.0, 2.0, 3.0]), np.diag([1.0, 4.0, 2.0]),
                     np.diag([1e4, 3e4, 2e4]))           # decoupled [linear]: T = I
    for m in (Model.loads(MODAL), Model.loads(LINEAR), diagonal):
        dofs = [m.n_dof - 1, 0]
        ev = m.receptance(dofs)
        for f in (np.array([20.0]), np.linspace(1.0, 80.0, 37)):
            w = 2 * np.pi * f
            if m.decoupled:
                hq = 1.0 / (-w[:, None] ** 2 * np.diag(m.mass) + 1j * w[:, None]
                            * np.diag(m.damping) + np.diag(m.stiffness))
                want = np.einsum("pq,fq,iq->fpi", m.shapes, hq, m.shapes[dofs], optimize=True)
            else:
                z = (-w[:, None, None] ** 2 * m.mass + 1j * w[:, None, None] * m.damping
                     + m.stiffness)
                want = np.linalg.solve(z, np.broadcast_to(m.shapes[dofs].T, (f.size, m.n_q, 2)))
            for _ in range(2):                    # planned, then from the plan
                np.testing.assert_array_equal(ev(f), want)
            np.testing.assert_array_equal(m.linear_frf(f, dofs), want)


@pytest.mark.parametrize("change, match", [
    (("frequencies_hz = [6.6, 35.1]", "frequencies_hz = [-6.6, 35.1]"), "must be > 0 Hz"),
    (("damping_ratios = [0.01, 0.02]", "damping_ratios = [1.5, 0.02]"), r"in \(0, 1\)"),
    (("damping_ratios = [0.01, 0.02]", "damping_ratios = [0.01]"), "1 damping ratios"),
    (("shapes = [[0.2, 0.8, 0.9],", "shapes = [[0.2, 0.8],"), "one value per point"),
    (("shapes = [[0.2, 0.8, 0.9], [0.05, -0.4, 1.1]]", "shapes = [[0.2, 0.8, 0.9]]"),
     "shapes must be 2 x"),
    (('points = ["drive", "joint", "payload"]', 'points = ["drive", "joint", "joint"]'),
     "named twice"),
    (('between = ["joint", "payload"]', 'between = ["joint", "paylod"]'),
     "did you mean 'payload'"),
    (('between = ["joint", "payload"]', 'at = "joint"\nw = [0.0, 1.0, 0.0]'), "got w and at"),
    (('points = ["drive", "joint", "payload"]\n', ""), "needs top-level points"),
])
def test_bad_modal_files_name_the_problem(tmp_path, change, match):
    path = tmp_path / "m.toml"
    path.write_text(MODAL.replace(*change))
    with pytest.raises(ModelError, match=match):
        Model.load(path)


def test_modal_file_keeps_the_damping_coupling_a_correction_leaves(tmp_path):
    """A stuck stiffness taken out of a modal model with a pseudo-mode couples its modes
    through the damping; the [modal] file writes the off-diagonal part (damping_coupling) and
    reads the same receptance back (the diagonal alone changed the beam's damping by 40 %)."""
    from analysis.models import Model
    base = Model.modal([80.0], [0.0015], [[0.73]], residual_freqs_hz=[39.5],
                       residual_damping=[0.05], residual_shapes=[[0.98]])
    wq = base.to_q(np.array([1.0]))
    model = base.with_linear(base.mass, base.damping, base.stiffness - 3e4 * np.outer(wq, wq))
    model.save(tmp_path / "m.toml")
    text = (tmp_path / "m.toml").read_text()
    assert "damping_coupling" in text
    back = Model.load(tmp_path / "m.toml")
    f = np.linspace(20, 100, 81)
    np.testing.assert_allclose(back.linear_frf(f), model.linear_frf(f), rtol=1e-10)
    bad = text.replace("damping_coupling = [\n    [0.0,", "damping_coupling = [\n    [1.0,")
    (tmp_path / "bad.toml").write_text(bad)
    with pytest.raises(Exception, match="zero diagonal"):
        Model.load(tmp_path / "bad.toml")


def test_a_model_files_schema_is_what_the_reader_checks():
    """`ModelTables` gives the keys the strict reader allows: a key it does not name is
    refused, and a model's tables round-trip through `Model.to_dict` / `from_dict`."""
    model = Model.load(EXAMPLES / "sdof-cubic-quaddamp.toml")
    tables = model.to_dict()
    assert set(tables) <= set(ModelTables.__annotations__)
    assert tuple(SupportTable.__annotations__) == SUPPORT_KEYS    # the [support] reader's keys
    assert Model.from_dict(tables).dumps() == model.dumps()
    with pytest.raises(ModelError, match="stiffnes"):
        Model.from_dict({**tables, "stiffnes": 1.0})
