"""Candidate screening (paper eq 20): the true elements and locations rank first, named by
their model-file kinds; nothing is significant on a linear structure."""

import json

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.plant import Plant, random_gaussian
from analysis.models import Element, Model
from analysis.reverse_path import screen_candidates
from analysis.reverse_path._screening import MIN_GAIN, default_locations, screenable_kinds
from nlid_lab.cli import main

PAPER3 = "examples/models/three-dof-paper.toml"
CUBIC_01 = Element("cubic_spring", np.array([-1.0, 1.0, 0.0]), {"p": 4.0e16})
# sensor noise on every response channel, as a fraction of its rms: 10x the example
# campaigns' (1e-8 m on ~1e-4 m); screening works on H1 spectra without noise correction
NOISE = 1e-3


def _run(model, fs, rms, band, oversample, n=2**17, noise=0.0):
    force = random_gaussian(n, fs, band, rms, seed=11)[:, None]
    x = Plant(model, fs, [0], oversample=oversample).run(force).displacement
    rng = np.random.default_rng(5)
    return force, x + noise * x.std(axis=0) * rng.standard_normal(x.shape)


@pytest.fixture(scope="module")
def sdof():
    model = Model.load("examples/models/sdof-cubic-quaddamp.toml")
    return (model, *_run(model, 1024.0, 20.0, (5, 150), 2))


@pytest.fixture(scope="module")
def mdof():
    model = Model.load(PAPER3)
    return (model, *_run(model, 4096.0, 8.0, (5, 400), 4))


@pytest.fixture(scope="module")
def linear3():
    return Model.load(PAPER3).with_elements([], name="three-dof chain, linear part")


@pytest.fixture(scope="module")
def cubic01(linear3):
    """3-DOF chain with one cubic spring between DOFs 0 and 1, noisy sensors."""
    return _run(linear3.with_elements([CUBIC_01]), 4096.0, 8.0, (5, 400), 4, noise=NOISE)


def _screen(force, x, model, fs=4096.0):
    return screen_candidates((force, x), model, fs=fs, force_dofs=[0], nperseg=4096,
                             force_hold="linear")


def test_library_is_every_kind_screening_can_form():
    # memoryless, linear in one coefficient, other parameters with defaults; the gap needs
    # its width and the memory kinds are not linear in their parameters
    assert set(screenable_kinds()) == {"cubic_spring", "quadratic_spring", "quadratic_damping",
                                       "cubic_damping", "coulomb_friction"}
    assert [w.tolist() for w in default_locations(3)] == [
        [1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 1, 0], [-1, 0, 1], [0, -1, 1]]


def test_sdof_ranks_cubic_and_quadratic_damping_first(sdof):
    model, force, x = sdof
    res = _screen(force, x, model.with_elements([]), fs=1024.0)
    assert [r["label"] for r in res.rows[:2]] == ["cubic_spring DOF 0 to ground",
                                                  "quadratic_damping DOF 0 to ground"]
    assert [r["significant"] for r in res.rows[:3]] == [True, True, False]
    assert res.rows[0]["p"] == pytest.approx(6e10, rel=2e-3)
    assert res.rows[1]["p"] == pytest.approx(20.0, rel=0.05)
    assert max(r["imag_ratio"] for r in res.rows[:2]) < 0.01
    assert "cubic_spring DOF 0 to ground" in res.table()
    assert res.to_json()["ranking"][0]["kind"] == "cubic_spring"


def test_sdof_screening_gives_the_example_candidate(sdof):
    """examples/candidates/sdof-candidate.toml is what screening adds to sdof-linear.toml."""
    _, force, x = sdof
    linear = Model.load("examples/models/sdof-linear.toml")
    res = _screen(force, x, linear, fs=1024.0)
    got = Model.loads(linear.dumps() + res.snippet())
    example = Model.load("examples/candidates/sdof-candidate.toml")
    assert [(e.kind, e.w.tolist(), e.params) for e in got.elements] == \
        [(e.kind, e.w.tolist(), {}) for e in example.elements]
    assert np.array_equal(example.stiffness, linear.stiffness)


def test_mdof_finds_both_elements_and_locations(mdof):
    model, force, x = mdof
    res = _screen(force, x, model.with_elements([]))
    assert {r["label"] for r in res.chosen} == {"cubic_spring between DOFs 1 and 2",
                                                "quadratic_spring between DOFs 0 and 2"}
    assert len(res.rows) == 5 * 6


def test_linear_model_screening_names_the_cubic_between_dofs_0_and_1(cubic01, linear3):
    res = _screen(*cubic01, linear3)
    top = res.rows[0]
    assert (top["kind"], top["w"], top["label"]) == \
        ("cubic_spring", [-1.0, 1.0, 0.0], "cubic_spring between DOFs 0 and 1")
    assert [r["label"] for r in res.chosen] == ["cubic_spring between DOFs 0 and 1"]
    assert top["ci95"][0] <= 4.0e16 <= top["ci95"][1]
    assert top["z"] >= res.z_crit and top["coherence_gain"] >= MIN_GAIN


def test_linear_structure_has_no_significant_candidate(linear3):
    """Threshold: a candidate must remove >= MIN_GAIN = 0.1 decades of incoherence (a noise
    regressor removes about 1/n_averages of it, ~0.02 decades here) and reach |p|/sigma >=
    z_crit, the two-sided 5 % family-wise Bonferroni value over the 30 candidates
    (Student t, 7 dof: 4.9). Both would pass a real element (previous test)."""
    force, x = _run(linear3, 4096.0, 8.0, (5, 400), 4, noise=NOISE)
    res = _screen(force, x, linear3)
    assert res.z_crit == pytest.approx(4.94, abs=0.01)
    assert res.chosen == [] and not any(r["selected"] for r in res.rows)
    assert max(r["coherence_gain"] for r in res.rows) < MIN_GAIN
    assert res.snippet() == ""


def test_snippet_parses_as_model_file_with_the_right_w(cubic01, linear3):
    res = _screen(*cubic01, linear3)
    text = linear3.dumps() + "\n" + res.snippet()
    cand = Model.loads(text)
    (el,) = cand.elements
    assert el.kind == "cubic_spring" and el.w.tolist() == [-1.0, 1.0, 0.0]
    assert el.missing == ["p"]                # parameters left out: to be estimated
    assert res.to_json()["snippet"] == res.snippet()


def test_candidates_by_kind_or_basis_and_bad_input(sdof):
    model, force, x = sdof
    lin = model.with_elements([])
    res = screen_candidates((force, x), lin, [("cubic_spring", [1.0]), ("x^5", [1.0])],
                            fs=1024.0, force_dofs=[0], nperseg=4096, force_hold="linear")
    assert [(r["kind"], r["basis"]) for r in res.rows] == [("cubic_spring", "x^3"),
                                                           (None, "x^5")]
    with pytest.raises(InputError, match="neither a kind"):
        screen_candidates((force, x), model, [("x^7", [1.0])], fs=1024.0, force_dofs=[0])
    with pytest.raises(InputError, match="non-zero vector"):
        screen_candidates((force, x), model, [("x^3", [1.0, 0.0])], fs=1024.0,
                          force_dofs=[0])


@pytest.fixture(scope="module")
def files3(cubic01, linear3, tmp_path_factory):
    force, x = cubic01
    d = tmp_path_factory.mktemp("screen3")
    np.savez(d / "rec.npz", fs=4096.0, excitation="random", force_dofs=np.array([0]),
             force=force, response=x, force_hold="linear")
    linear3.save(d / "linear.toml")
    return d


def _analyze(d, *extra):
    return main(["analyze", "reverse-path", str(d / "rec.npz"), "--model",
                 str(d / "linear.toml"), "--nperseg", "4096", *extra])


def test_cli_screens_a_linear_model(files3, capsys):
    d = files3
    assert _analyze(d, "--screen", "--json", str(d / "out.json"), "--candidate-out",
                    str(d / "cand.toml")) == 0
    out = capsys.readouterr().out
    rank1 = next(line for line in out.splitlines() if line.startswith("   1  "))
    assert "cubic_spring between DOFs 0 and 1" in rank1 and rank1.count("*") == 2
    assert 'kind = "cubic_spring"\nw = [-1.0, 1.0, 0.0]' in out
    assert "|p|/sigma >= 4.94" in out
    js = json.loads((d / "out.json").read_text())
    assert js["elements"] == [] and "modal" not in js
    scr = js["screening"]
    assert scr["chosen"] == ["cubic_spring between DOFs 0 and 1"]
    assert (scr["ranking"][0]["kind"], scr["ranking"][0]["w"]) == \
        ("cubic_spring", [-1.0, 1.0, 0.0])
    assert scr["significance"]["n_candidates"] == 30
    (el,) = Model.loads((d / "linear.toml").read_text() + scr["snippet"]).elements
    assert (el.kind, el.w.tolist()) == ("cubic_spring", [-1.0, 1.0, 0.0])
    cand = Model.load(d / "cand.toml")
    assert [(e.kind, e.w.tolist(), e.known) for e in cand.elements] == \
        [("cubic_spring", [-1.0, 1.0, 0.0], False)]
    # the written candidate is what the estimate takes next
    assert main(["analyze", "reverse-path", str(d / "rec.npz"), "--model",
                 str(d / "cand.toml"), "--nperseg", "4096", "--json", "-"]) == 0
    est = json.loads(capsys.readouterr().out)["elements"][0]
    assert est["ci95"]["p"][0] <= 4.0e16 <= est["ci95"]["p"][1]


def test_cli_screen_json_to_stdout_and_refusals(files3, capsys):
    d = files3
    assert _analyze(d, "--screen", "--json", "-") == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["screening"]["ranking"][0]["kind"] == "cubic_spring"
    assert "candidate screening" in captured.err
    # nothing to estimate without --screen; --candidate-out needs --screen; --store refused
    assert _analyze(d) == 2
    assert "add --screen" in capsys.readouterr().err
    assert _analyze(d, "--candidate-out", str(d / "x.toml")) == 2
    assert "add --screen" in capsys.readouterr().err
    assert main(["import", str(d / "rec.npz"), "--out", str(d / "run.h5")]) == 0
    assert _analyze(d, "--screen", "--store", str(d / "run.h5")) == 2
    assert "drop --store" in capsys.readouterr().err
    # an existing candidate file is not replaced without --force
    (d / "keep.toml").write_text("old")
    assert _analyze(d, "--screen", "--candidate-out", str(d / "keep.toml")) == 2
    assert (d / "keep.toml").read_text() == "old"
    assert not (d / "x.toml").exists()


def test_cli_screen_with_a_candidate_adds_ranking(sdof, tmp_path, capsys):
    model, force, x = sdof
    rec = tmp_path / "rec.npz"
    np.savez(rec, fs=1024.0, excitation="random", force_dofs=np.array([0]), force=force,
             response=x)
    out = tmp_path / "out.json"
    assert main(["analyze", "reverse-path", str(rec), "--model",
                 "examples/candidates/sdof-candidate.toml", "--json", str(out), "--screen",
                 "--nperseg", "4096"]) == 0
    js = json.loads(out.read_text())
    assert [r["kind"] for r in js["screening"]["ranking"][:2]] == ["cubic_spring",
                                                                   "quadratic_damping"]
    assert len(js["elements"]) == 2
    # both chosen candidates are already in the model: nothing to add
    assert js["screening"]["chosen"][:2] == ["cubic_spring DOF 0 to ground",
                                             "quadratic_damping DOF 0 to ground"]
    assert js["screening"]["snippet"] == ""
    assert "candidate screening" in capsys.readouterr().out
