"""The recording formats are one table (`formats.FORMATS`): a toy format registered here, with
no other edit, is read by ``import`` and by commands reading files directly, and written by
``export``; a suffix no format has is refused naming those that exist."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from analysis.recordings import Recording
from nlid_lab import formats, store
from nlid_lab.cli import main


def _read_toy(path: Path, options: formats.ReadOptions) -> Recording:
    keys = {k: np.asarray(v) for k, v in json.loads(path.read_text()).items()}
    return formats.recording_from_keys({**keys, **options.keys}, path)


def _write_toy(path: Path, rec: Recording) -> None:
    keys = formats.recording_keys(rec)
    path.write_text(json.dumps({k: np.asarray(v).tolist() for k, v in keys.items()}))


TOY = formats.RecordingFormat("JSON", (".json",), _read_toy, None, _write_toy, direct=True)


@pytest.fixture
def toy():
    formats.register_format(TOY)
    yield TOY
    formats.unregister_format(TOY)


@pytest.fixture
def run(tmp_path) -> tuple[Path, Recording]:
    rng = np.random.default_rng(3)
    rec = Recording(fs=256.0, excitation="random", force_dofs=[0],
                    force=rng.normal(size=(512, 1)), response=rng.normal(size=(512, 2)) * 1e-3,
                    response_kind="acceleration", level=2.0)
    path = tmp_path / "run.h5"
    store.save_recording(path, rec)
    return path, rec


def test_a_toy_format_is_exported_imported_and_read_with_no_other_edit(toy, run, tmp_path,
                                                                        capsys):
    path, rec = run
    out = tmp_path / "level.json"
    assert main(["export", str(path), "--out", str(out)]) == 0
    assert set(json.loads(out.read_text())) >= {"fs", "force", "response", "excitation"}
    (direct,) = formats.load_recordings(out)          # analyze, detect, ... read it as it is
    np.testing.assert_array_equal(direct.response, rec.response)
    back = tmp_path / "back.h5"
    assert main(["import", str(out), "--out", str(back), "--excitation", "random"]) == 0
    (imported,) = store.open_run(back).recordings()
    np.testing.assert_array_equal(imported.force, rec.force)
    np.testing.assert_array_equal(imported.response, rec.response)
    assert (imported.fs, imported.response_kind) == (256.0, "acceleration")


def test_the_messages_list_the_formats_of_the_table(toy, run, tmp_path, capsys):
    path, _ = run
    assert formats.suffix_list("write") == ".npz, .csv, .mat or .json"
    assert formats.suffix_list("direct", (".h5",)) == ".h5, .npz, .csv or .json"
    assert main(["export", str(path), "--out", str(tmp_path / "x.txt")]) == 2
    err = capsys.readouterr().err
    assert "export to a .npz, .csv, .mat or .json recording" in err and "\n" not in err.strip()
    with pytest.raises(ValueError, match=".json"):
        formats.register_format(TOY)                  # one format per suffix


def test_without_the_entry_the_suffix_is_refused(run, tmp_path, capsys):
    path, _ = run
    assert formats.format_of(tmp_path / "x.JSON") is None
    assert main(["export", str(path), "--out", str(tmp_path / "x.json")]) == 2
    assert "export to a .npz, .csv or .mat recording" in capsys.readouterr().err
    (tmp_path / "x.json").write_text("{}")
    with pytest.raises(store.StoreError, match=r"use \.h5, \.npz or \.csv"):
        formats.load_recordings(tmp_path / "x.json")
