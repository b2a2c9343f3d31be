"""The method registry (`nlid_lab.methods`): one registration reaches analyze, reanalyze,
report and view; stored results are found by their "estimator" (old files by their keys)."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from analysis.spectral import default_nperseg, longest_nperseg, resolving_nperseg
from analysis.models import Element, Model
from nlid_lab import methods, reanalyze as rea, store
from nlid_lab import formats as recordings_io
from nlid_lab.cli import build_parser, main
from nlid_lab.reports import Section, estimate_rows, load_run, write_report
from test_report import random_run

QUAD = Path("examples/models/sdof-cubic-quaddamp.toml")
FS, N = 256.0, 4096


@dataclass
class ToyOptions:
    scale: float = methods.option("--scale", default=1.0, batch=True, type=float,
                                  help="factor on the gain")
    note: str | None = methods.option("--note", help="analyze only")


@dataclass
class ToyEstimate:
    gain: float
    note: str | None

    def to_json(self) -> dict:
        return {methods.ESTIMATOR_KEY: "toy", "warnings": [], "note": self.note,
                "elements": [{"kind": "cubic_spring", "w": [1.0], "params": {"p": self.gain},
                              "ci95": {"p": [self.gain - 1, self.gain + 1]}}]}

    def table(self) -> str:
        return f"toy gain {self.gain:.6g}"

    def write_files(self) -> list[str]:
        return []


def toy_gain(recs, scale: float) -> float:
    """Response rms over force rms of all levels together, times ``scale``."""
    x = np.concatenate([r.response for r in recs])
    f = np.concatenate([r.force for r in recs])
    return float(scale * x.std() / f.std())


def toy_estimate(recs, model, options: ToyOptions) -> ToyEstimate:
    assert isinstance(options, ToyOptions)           # typed options, not argparse
    return ToyEstimate(toy_gain(recs, options.scale), options.note)


def toy_sections(run, frfs, stored, candidate) -> list[Section]:
    if stored is None:
        return []
    return [Section("Toy gain", f"stored as {stored.name}: "
                                f"{stored.elements[0].params['p']:.6g}")]


@pytest.fixture
def toy():
    method = methods.register(methods.Method("toy", "a toy estimator", ToyOptions, "random",
                                             toy_estimate, sections=toy_sections))
    yield method
    methods.unregister("toy")


@pytest.fixture
def run(tmp_path) -> Path:
    """Two random levels of a linear gain-2 'structure' with a little noise."""
    rng = np.random.default_rng(1)
    path = tmp_path / "toy.h5"
    with store.RunWriter(path, fs=FS, excitation="random", force_dofs=[0], n_dof=1,
                         mode="overwrite") as writer:
        for i, rms in enumerate((1.0, 3.0)):
            f = rms * rng.standard_normal((N, 1))
            lv = writer.level(i, rms)
            lv.append_block(f, 2.0 * f + 0.01 * rng.standard_normal((N, 1)))
            lv.complete()
    return path


@pytest.fixture
def candidate(tmp_path) -> Path:
    model = Model.load(QUAD)
    path = tmp_path / "candidate.toml"
    model.with_elements([Element(e.kind, e.w, {}) for e in model.elements]).save(path)
    return path


def test_toy_method_reaches_analyze_reanalyze_report_and_view(toy, run, candidate, tmp_path):
    recs = recordings_io.load_recordings(run)
    out = tmp_path / "toy.json"
    assert main(["analyze", "toy", str(run), "--model", str(candidate), "--scale", "2.5",
                 "--note", "hello", "--json", str(out), "--store", str(run)]) == 0
    result = json.loads(out.read_text())
    assert result["estimator"] == "toy" and result["note"] == "hello"
    assert result["elements"][0]["params"]["p"] == pytest.approx(toy_gain(recs, 2.5))
    assert abs(toy_gain(recs, 1.0) - 2.0) < 0.01               # the data's gain, not a constant
    assert store.open_run(run).results["analyze-toy"] == result
    # reanalyze: the method and its batch option (not the analyze-only one) on the parser ...
    args = build_parser().parse_args(["reanalyze", str(run), "--model", str(candidate),
                                      "--method", "toy", "--scale", "3"])
    assert methods.batch_values(args).get("scale") == 3.0
    with pytest.raises(SystemExit):
        build_parser().parse_args(["reanalyze", str(run), "--model", str(candidate),
                                   "--note", "x"])
    # ... and per level through the registry
    rows = rea.analyse_run(str(run), Model.load(candidate), "toy",
                           methods.BatchOptions.of(scale=3.0))
    assert [r.status for r in rows] == ["ok", "ok"] and rows[0].method == "toy"
    for row, rec in zip(rows, recs):
        assert row.estimates["e0.cubic_spring.p"] == pytest.approx(toy_gain([rec], 3.0))
    # report and view find the stored result by its estimator
    data = load_run(run)
    written = write_report(data, tmp_path / "report", estimators=methods)
    assert "Toy gain" in written.sections
    assert any(r[0] == "analyze-toy" for r in estimate_rows(data.results, methods))
    methods.unregister("toy")
    written = write_report(load_run(run), tmp_path / "r2", estimators=methods)
    assert "Toy gain" not in written.sections
    assert not any(r[0] == "analyze-toy" for r in estimate_rows(data.results, methods))


def test_stored_results_found_by_estimator_else_by_legacy_keys():
    hbm, rp = methods.get("hbm"), methods.get("reverse-path")
    old_hbm = {"elements": [], "cost": 0.1, "warnings": []}
    old_rp = {"elements": [], "multiple_coherence": {"min": 0.99}, "warnings": []}
    # a reverse-path result that happens to carry "cost" is not taken for an hbm fit
    new_rp = {"estimator": "reverse-path", "elements": [], "cost": 1.0,
              "multiple_coherence": {"min": 0.9}}
    results = {"a": old_hbm, "b": old_rp, "c": new_rp, "d": {"verdict": "adequate"}}
    found = methods.find_stored(results, hbm)
    assert (found.name, found.method, found.estimate.cost) == ("a", "hbm", 0.1)
    found = methods.find_stored(results, rp)                              # the last one
    assert (found.name, found.method, found.estimate.coherence_min) == ("c", "reverse-path", 0.9)
    assert [(f.name, f.method) for f in methods.stored_estimates(results)] == [
        ("a", "hbm"), ("b", "reverse-path"), ("c", "reverse-path")]
    assert methods.find_stored({"x": {"estimator": "hbm"}}, rp) is None


def test_each_method_reads_its_results_back_typed_old_layouts_too():
    """`Method.result`: the reanalysis rows come from the typed result, not from JSON keys."""
    rp, hbm = methods.get("reverse-path"), methods.get("hbm")
    el = {"kind": "cubic_spring", "w": [1.0, 0.0], "params": {"p": 2.0e11},
          "ci95": {"p": [1.9e11, 2.1e11]}}
    # stored before "estimator", "force_hold" and "estimated" existed
    old = rp.result.from_json({"elements": [el], "multiple_coherence": {"min": 0.97},
                               "warnings": ["w1"]})
    assert isinstance(old, methods.StoredEstimate) and type(old).__name__ == "ReversePathStored"
    assert old.coherence_min == 0.97 and old.cost is None and old.force_hold is None
    assert old.warnings == ("w1",) and old.elements[0].estimated == ("p",)
    assert old.elements[0].ci95["p"] == (1.9e11, 2.1e11)
    # screening only: no coherence
    assert rp.result.from_json({"estimator": "reverse-path", "elements": [], "warnings": [],
                                "force_hold": "linear"}).coherence_min is None
    fit = hbm.result.from_json({"estimator": "hbm", "cost": 0.25, "harmonics": [1, 3],
                                "warnings": [], "elements": [dict(el, params={"p": 2.0e11,
                                                                              "c": 3.0},
                                                                  estimated=["p"])]})
    assert (fit.cost, fit.coherence_min, fit.harmonics) == (0.25, None, (1, 3))
    assert fit.elements[0].estimated == ("p",)
    assert hbm.result.from_json({"elements": [], "cost": 1}).harmonics == ()   # before them


def test_reanalysis_row_from_the_typed_result(toy):
    """A method without a result type of its own is read by the base `StoredEstimate`."""
    from analysis.recordings import Recording
    rec = Recording(FS, "random", np.array([0]), np.ones((8, 1)), np.ones((8, 1)), level=1.0)
    row = rea.level_row("r.h5", 0, rec, "toy", ToyEstimate(3.0, None))
    assert row.estimates == {"e0.cubic_spring.p": 3.0, "e0.cubic_spring.p.ci95_lo": 2.0,
                             "e0.cubic_spring.p.ci95_hi": 4.0}
    assert row.coherence_min is None and row.cost is None and row.ok


def test_a_new_method_module_is_found_with_no_other_edit(tmp_path, monkeypatch):
    """`methods.discover`: a package's modules not imported yet are imported (in name order),
    so a module that registers a method is the whole addition."""
    pkg = tmp_path / "toy_methods"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "_toy.py").write_text(
        "from dataclasses import dataclass\n"
        "from nlid_lab import methods\n"
        "@dataclass\nclass Options:\n    pass\n"
        "methods.register(methods.Method('toy-found', 'found', Options, 'random',\n"
        "                                lambda recs, model, options: None))\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        assert methods.discover("toy_methods", [str(pkg)]) == ["toy_methods._toy"]
        assert methods.get("toy-found").help == "found"
        assert methods.discover("toy_methods", [str(pkg)]) == []          # once only
    finally:
        methods.unregister("toy-found")
        for name in ("toy_methods._toy", "toy_methods"):
            sys.modules.pop(name, None)
    # the built-ins keep their order: reverse path is the first random-data method
    assert [m.name for m in methods.methods()][:2] == ["reverse-path", "hbm"]


def test_analyze_and_reanalyze_share_each_methods_options(run, candidate, capsys):
    flags = ["--band", "5", "100", "--nperseg", "512", "--refine", "sequential"]
    rp = methods.get("reverse-path")
    a = build_parser().parse_args(["analyze", "reverse-path", "r.h5", "--model", "m", *flags])
    r = build_parser().parse_args(["reanalyze", "r.h5", "--model", "m", *flags,
                                   "--harmonics", "1,3"])
    assert rp.make_options(a) == rp.make_options(methods.batch_values(r))
    assert rp.make_options(a).band == (5.0, 100.0)
    assert methods.get("hbm").make_options(methods.batch_values(r)).harmonics == "1,3"
    # defaults come from the method when reanalyze is not given the option
    bare = build_parser().parse_args(["reanalyze", "r.h5", "--model", "m"])
    assert rp.make_options(methods.batch_values(bare)).refine == "joint"
    assert main(["reanalyze", str(run), "--model", str(candidate), "--harmonics", "2x"]) == 2
    assert "harmonic" in capsys.readouterr().err


def test_analyze_reverse_path_json_names_its_estimator(candidate, tmp_path):
    run = random_run(tmp_path / "rp.h5", seconds=16.0)
    out = tmp_path / "rp.json"
    assert main(["analyze", "reverse-path", str(run), "--model", str(candidate), "--json",
                 str(out), "--store", str(run)]) == 0
    result = json.loads(out.read_text())
    assert result["estimator"] == "reverse-path" and result["modal"]["modes"]
    assert store.open_run(run).results["analyze-reverse-path"] == result
    # the default segment length resolves the resonances (analysis.spectral.resolving_nperseg)
    recs = recordings_io.load_recordings(run)
    band = tuple(result["multiple_coherence"]["band_hz"])
    chosen = min(max(resolving_nperseg(r.force, r.response, r.fs, band, r.response_kind).nperseg
                     for r in recs), longest_nperseg(min(r.force.shape[0] for r in recs)))
    assert result["resolution_hz"] == 1024.0 / chosen
    assert chosen >= default_nperseg(16 * 1024)

