"""What the report, views and commands read from a run are typed fields: the stored model
(`Run.model_toml` -> `RunData.model_toml` -> `reference_model`), the level index of an export,
the plant's substeps of a simulation; `Recording.meta` and `Run.meta` are a pass-through bag
that nothing outside the store and the recording formats reads by key (issue 22 item 1)."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from analysis.recordings import Recording
from nlid_lab import store
from nlid_lab.cli import main
from nlid_lab.commands.simulate import simulate
from nlid_lab.formats import Drive
from nlid_lab.reports import candidate_model, load_run, reference_model

ROOT = Path(__file__).resolve().parents[3]
SDOF = ROOT / "examples" / "models" / "sdof-cubic-quaddamp.toml"
#: Where a bag's keys are written and read: the store (run attributes), the formats (a file's
#: own keys), the recordings' own copies of it.
BAG_READERS = ("nlid_lab/store/", "nlid_lab/formats/")


def _random(level: float, seed: int) -> Recording:
    rng = np.random.default_rng(seed)
    return Recording(256.0, "random", [0], rng.standard_normal((1024, 1)),
                     rng.standard_normal((1024, 1)), level=level)


def test_stored_model_is_a_typed_field_of_the_run_and_its_report_data(tmp_path):
    path = tmp_path / "sim.h5"
    store.save_recording(path, _random(1.0, 1), source="sim", model_toml=SDOF.read_text())
    assert store.open_run(path).model_toml == SDOF.read_text()
    run = load_run(path)
    assert run.model_toml == SDOF.read_text()
    assert reference_model(run).to_dict() == Model.load(SDOF).to_dict()
    cand = candidate_model(run)
    assert [el.kind for el in cand.elements] == [el.kind for el in Model.load(SDOF).elements]
    assert all(not el.params for el in cand.elements)      # every parameter to estimate


def test_a_run_without_a_model_has_none_and_its_results_are_read_only(tmp_path):
    path = tmp_path / "import.h5"
    store.save_recording(path, _random(1.0, 1), source="import")
    store.save_result(path, "analyze-x", {"estimator": "x", "elements": []})
    run = load_run(path)
    assert store.open_run(path).model_toml == "" and run.model_toml == ""
    assert reference_model(run) is None and candidate_model(run) is None
    assert run.results["analyze-x"] == {"estimator": "x", "elements": []}
    with pytest.raises(TypeError):                 # the store's documents, not a scratch pad
        run.results["analyze-y"] = {}


def test_export_names_the_level_it_resolved(tmp_path, capsys):
    path = tmp_path / "two.h5"
    store.save_recording(path, [_random(1.0, 1), _random(2.0, 2)])
    out = tmp_path / "l1.npz"
    assert main(["export", str(path), "--level", "1", "--out", str(out), "--json", "-"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["level"] == 1 and got["out"] == str(out)
    assert main(["export", str(path), "--out", str(tmp_path / "x.npz")]) == 2  # two levels
    assert "choose one" in capsys.readouterr().err


def test_simulate_reports_the_plants_substeps_typed():
    model = Model.load(SDOF)
    fs = 1024.0
    force = np.random.default_rng(0).standard_normal((2048, 1))
    drive = Drive(fs=fs, excitation="random", force=force, force_dofs=np.array([0]))
    sim = simulate(model, drive, oversample=3)
    # asked for 3 substeps per sample: the plant only ever raises them, and says so
    assert isinstance(sim.oversample, int) and isinstance(sim.oversample_raised, int)
    assert sim.oversample >= 3 and (sim.oversample > 3) == (sim.oversample_raised > 0)
    assert sim.recording.response.shape == (2048, 1)
    assert "oversample" not in sim.recording.meta       # one place: the typed field


def _bag_reads(source: str) -> list[int]:
    """Lines where ``source`` reads a ``meta`` bag by key (``x.meta[...]``,
    ``x.meta.get(...)``)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        target = (node.value if isinstance(node, ast.Subscript) else
                  node.func.value if isinstance(node, ast.Call)
                  and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
                  else None)
        if isinstance(target, ast.Attribute) and target.attr == "meta":
            lines.append(node.lineno)
    return lines


def test_meta_bags_are_read_by_key_only_at_the_store_and_format_edge():
    found = []
    for pkg in ("analysis", "drivers", "nlid_lab"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel.startswith(BAG_READERS):
                continue
            found += [f"{rel}:{line}" for line in _bag_reads(path.read_text())]
    assert found == [], "read what you need from a typed field, not from meta"


def test_bag_read_check_sees_one():
    source = ("x = rec.meta['level_index']\ny = run.meta.get('model_toml')\n"
              "z = rec.meta\nw = d.get('meta')\nv = rec.extra['k']\n")
    assert _bag_reads(source) == [1, 2]
