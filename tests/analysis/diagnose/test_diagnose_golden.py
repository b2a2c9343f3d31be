"""The diagnosis result is typed (`analysis.diagnose._result`) and its JSON is what the command
wrote before: byte for byte but for the added ``schema_version`` and numbers within
`golden_cases.RTOL` (BLAS thread counts move them; goldens written by the
command before the refactor, `golden_cases`); results stored in the earlier layouts still read.
"""

from __future__ import annotations

import json

import pytest

from analysis.diagnose import SCHEMA_VERSION, Diagnosis, Verdict
from golden_cases import CASES, GOLDEN, run_case, same_as_golden, without_added_keys

FAST = {"stepped-stiffness"}
"""Cases in `make test` (the others take 20-40 s each; random-cubic is also compared in
`test_diagnose_stepped_cli.test_cli_diagnose_runs_on_npz_and_hdf5`)."""


@pytest.mark.parametrize("case", [c if c in FAST else pytest.param(c, marks=pytest.mark.slow)
                                  for c in CASES])
def test_command_json_is_the_golden_one_plus_its_schema_version(case, tmp_path):
    text = run_case(case, tmp_path)
    data = json.loads(text)
    assert data["schema_version"] == SCHEMA_VERSION
    assert next(iter(data)) == "schema_version"
    golden = (GOLDEN / f"{case}.json").read_text()
    assert same_as_golden(without_added_keys(text), golden), (
        f"the diagnose JSON of case {case} differs from golden/{case}.json; if a change "
        "meant to move the numbers, regenerate: python tests/analysis/diagnose/golden_cases.py")
    # reading the JSON back gives the same JSON
    assert Diagnosis.from_json(data).to_json() == data


def test_every_golden_reads_back_typed():
    for path in sorted(GOLDEN.glob("*.json")):
        data = json.loads(path.read_text())
        d = Diagnosis.from_json(data)
        assert d.verdict in set(Verdict)
        again = d.to_json()
        assert again.pop("schema_version") == SCHEMA_VERSION
        assert again == data, path.name


LEGACY_CONTRACT = {       # contracts section 4 as first written: no version, no levels
    "verdict": "discrepancy", "level_dependent": True,
    "location": {"dofs": [1], "band_hz": [10.0, 20.0]},
    "missing_physics": [{"kind": "cubic_spring", "w": [0, 1, 0], "params": {"p": 3.0e9}}],
    "fit": {"metric": "relative FRF error", "before": 0.41, "after": 0.03},
    "explanation": "The mismatch is missing nonlinear physics."}

LEGACY_LEVELS = {         # per-level errors at the top level only, before fit.levels
    "verdict": "adequate", "level_dependent": False,
    "location": {"dofs": [], "band_hz": None}, "missing_physics": [],
    "fit": {"metric": "relative FRF error", "before": 0.02, "after": 0.02,
            "held_back": ["level 2"]},
    "explanation": "adequate", "ranking": [],
    "levels": [{"label": "level 1", "level": 1.0, "held_back": False,
                "error_before": 0.01, "error_after": 0.01},
               {"label": "level 2", "level": 2.0, "held_back": True,
                "error_before": 0.02, "error_after": 0.02}],
    "warnings": ["one"]}


def test_results_stored_in_earlier_layouts_read():
    d = Diagnosis.from_json(LEGACY_CONTRACT)
    assert d.verdict is Verdict.DISCREPANCY and d.level_dependent is True
    assert d.location.dofs == (1,) and d.location.band_hz == (10.0, 20.0)
    assert d.location.points is None
    (c,) = d.chosen
    assert (c.kind, c.w, c.params, c.ci95) == ("cubic_spring", (0, 1, 0), {"p": 3.0e9}, {})
    assert (d.fit.before, d.fit.after, d.fit.levels) == (0.41, 0.03, ())
    assert d.model is None and d.curves == ()
    assert c.dofs == (1,)                        # from w, where the entry has no dofs
    out = d.to_json()
    (mp,) = LEGACY_CONTRACT["missing_physics"]
    assert {k: out["missing_physics"][0][k] for k in mp} == mp
    assert out["location"] == LEGACY_CONTRACT["location"]

    d = Diagnosis.from_json(LEGACY_LEVELS)
    assert [(lv.label, lv.before, lv.after, lv.held_back) for lv in d.fit.levels] == [
        ("level 1", 0.01, 0.01, False), ("level 2", 0.02, 0.02, True)]
    assert d.fit.held_back == ("level 2",) and d.warnings == ("one",)
    assert all(lv.floor is None and lv.within_floor is None for lv in d.fit.levels)


def test_a_newer_schema_is_refused_with_the_fix():
    with pytest.raises(ValueError, match="update nlid-lab"):
        Diagnosis.from_json(dict(LEGACY_CONTRACT, schema_version=SCHEMA_VERSION + 1))


def test_the_result_is_frozen():
    d = Diagnosis.from_json(LEGACY_CONTRACT)
    with pytest.raises(AttributeError):
        d.verdict = Verdict.ADEQUATE
    with pytest.raises(AttributeError):
        d.fit.after = 0.0


def test_a_run_holding_an_earlier_layout_reports_it(tmp_path):
    """A diagnosis stored in a run before the schema version is found by its name and read
    typed by the report: its per-level bars come from the top-level rows."""
    import numpy as np

    from analysis.recordings import Recording
    from analysis.diagnose import RESULT_NAME
    from nlid_lab.reports import load_run, stored_diagnosis
    from nlid_lab.reports._report import diagnosis_levels, diagnosis_section
    from nlid_lab.store import save_recording, save_result

    rng = np.random.default_rng(1)
    rec = Recording(256.0, "random", [0], rng.standard_normal((2048, 1)),
                    rng.standard_normal((2048, 2)), level=1.0)
    path = tmp_path / "run.h5"
    save_recording(path, rec)
    save_result(path, RESULT_NAME, LEGACY_LEVELS)
    run = load_run(path)
    d = stored_diagnosis(run)
    assert d.verdict is Verdict.ADEQUATE and d.explanation == "adequate"
    bars = diagnosis_levels(d, "N rms")
    assert [(b.label, b.before, b.held_back) for b in bars] == [
        ("1 N rms", 0.01, False), ("2 N rms", 0.02, True)]
    sec = diagnosis_section(run)
    assert [name for name, _ in sec.figures] == ["diagnosis_fit"]
