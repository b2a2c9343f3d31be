"""Model files: load, validate, round trip of every kind, and each class of bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis.elements import KINDS
from analysis.errors import InputError, ModelError
from analysis.model import Element, Model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "models"

PARAMS = {"cubic_spring": {"p": 3e9}, "quadratic_spring": {"p": -2e5},
          "quadratic_damping": {"p": 20.0}, "cubic_damping": {"p": 1e3},
          "coulomb_friction": {"fc": 5.0, "v_reg": 1e-2}, "stick_slip": {"kd": 1e6, "fd": 20.0},
          "hysteresis": {"kd": 1e6, "fd": 20.0, "n": 2.0}, "gap": {"k": 1e7, "g": 1e-4}}

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
    assert model.complete
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
    ("[linear]\nmass = [[1.0]]\ndamping = [['a']]\nstiffness = [[1.0]]\n", "matrix of numbers"),
    ("unit = 'mm'\n[linear]\nmass = [[1.0]]\ndamping = [[0.0]]\nstiffness = [[1.0]]\n",
     "unknown top-level key"),
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
    ("kind = 'cubic_spring'\nw = [1.0, 0.0]\np = 'big'", "not a finite number"),
    ("kind = 'stick_slip'\nw = [1.0, 0.0]\nkd = 1e6\nfd = -2.0", "fd must be > 0"),
])
def test_bad_elements(tmp_path, element, match):
    with pytest.raises(ModelError, match=match):
        _load_text(tmp_path, LINEAR + "\n[[element]]\n" + element + "\n")


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        Model.load(tmp_path / "missing.toml")
    with pytest.raises(ModelError, match="cannot read"):
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
