"""Candidate screening (paper eq 20): the true elements and locations rank first."""

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.excitation import random_gaussian
from analysis.model import Model
from analysis.plant import Plant
from analysis.reverse_path import screen_candidates
from analysis.reverse_path._screening import default_locations


def _run(path, fs, rms, band, oversample, n=2**17):
    model = Model.load(path)
    force = random_gaussian(n, fs, band, rms, seed=11)[:, None]
    out = Plant(model, fs, [0], oversample=oversample).run(force)
    return model, force, out.displacement


@pytest.fixture(scope="module")
def sdof():
    return _run("examples/models/sdof-cubic-quaddamp.toml", 1024.0, 20.0, (5, 150), 2)


@pytest.fixture(scope="module")
def mdof():
    return _run("examples/models/three-dof-paper.toml", 4096.0, 8.0, (5, 400), 4)


def test_sdof_ranks_cubic_and_quadratic_damping_first(sdof):
    model, force, x = sdof
    res = screen_candidates((force, x), model.with_elements([]), fs=1024.0, force_dofs=[0],
                            nperseg=4096, force_hold="linear")
    top = [r["basis"] for r in res.rows[:2]]
    assert top == ["x^3", "v|v|"]
    assert [r["selected"] for r in res.rows[:3]] == [True, True, False]
    assert res.rows[0]["p"] == pytest.approx(6e10, rel=2e-3)
    assert res.rows[1]["p"] == pytest.approx(20.0, rel=0.05)
    assert max(r["imag_ratio"] for r in res.rows[:2]) < 0.01
    assert "x^3" in res.table() and res.to_json()["ranking"][0]["basis"] == "x^3"


def test_mdof_finds_both_elements_and_locations(mdof):
    model, force, x = mdof
    res = screen_candidates((force, x), model.with_elements([]), fs=4096.0, force_dofs=[0],
                            nperseg=4096, force_hold="linear")
    found = {(r["basis"], tuple(r["w"])) for r in res.rows if r["selected"]}
    assert found == {("x^3", (0.0, -1.0, 1.0)), ("x|x|", (-1.0, 0.0, 1.0))}
    assert len(res.rows) == 8 * 6


def test_locations_and_bad_input(sdof):
    assert len(default_locations(3)) == 6
    model, force, x = sdof
    with pytest.raises(InputError, match="unknown basis"):
        screen_candidates((force, x), model, [("x^7", [1.0])], fs=1024.0, force_dofs=[0])
    with pytest.raises(InputError, match="non-zero vector"):
        screen_candidates((force, x), model, [("x^3", [1.0, 0.0])], fs=1024.0,
                          force_dofs=[0])
    res = screen_candidates((force, x), model.with_elements([]), [("x^3", [1.0])],
                            fs=1024.0, force_dofs=[0], nperseg=4096, force_hold="linear")
    assert np.isfinite(res.rows[0]["p"])


def test_cli_screen_adds_ranking(sdof, tmp_path, capsys):
    import json

    from nlid_lab.cli import main
    model, force, x = sdof
    rec = tmp_path / "rec.npz"
    np.savez(rec, fs=1024.0, excitation="random", force_dofs=np.array([0]), force=force,
             response=x)
    cand = tmp_path / "cand.toml"
    cand.write_text(open("examples/models/sdof-cubic-quaddamp.toml").read()
                    .replace("p = 6.0e10", "").replace("p = 20.0", ""))
    out = tmp_path / "out.json"
    assert main(["analyze", "reverse-path", str(rec), "--model", str(cand), "--json",
                 str(out), "--screen", "--nperseg", "4096"]) == 0
    js = json.loads(out.read_text())
    assert [r["basis"] for r in js["screening"]["ranking"][:2]] == ["x^3", "v|v|"]
    assert "candidate screening" in capsys.readouterr().out
