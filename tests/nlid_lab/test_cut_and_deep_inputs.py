"""Issue 26 item 4 and the parsers of item 2: a CSV cut while being written, TOML nested
without bound, ``force_dofs`` of the wrong shape and a NaN fault duration each end in exit 2
with one line naming the problem (and the line of the file), never in a stored value or an
internal error."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from analysis.errors import ModelError
from analysis.models import MAX_TOML_DEPTH, Model, parse_toml
from analysis.models._textfile import toml_depth
from nlid_lab.campaign import CampaignError, parse_campaign
from analysis.recordings import Recording
from nlid_lab import formats as rio

from fuzz_inputs import check_outcome, run_cli, toml_text

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
CAMPAIGN = tomllib.loads((EXAMPLES / "campaign-sim-random.toml").read_text())
CAMPAIGN["plant"]["model"] = str(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")


@pytest.fixture
def csv_text(tmp_path) -> str:
    """A CSV written by `export` (``%.17g``): responses ~1e-5 m, written with exponents."""
    rng = np.random.default_rng(4)
    rec = Recording(fs=256.0, excitation="random", force_dofs=[0],
                        force=rng.normal(size=(300, 1)),
                        response=1e-5 * rng.normal(size=(300, 2)) + 3e-5)
    path = tmp_path / "whole.csv"
    rio.write_csv(path, rec)
    return path.read_text()


def _import(tmp_path, text: str, name: str = "cut") -> tuple[int, str]:
    path = tmp_path / f"{name}.csv"
    path.write_text(text)
    code, err, _ = run_cli(["import", str(path), "--out", str(tmp_path / f"{name}.h5")])
    check_outcome(code, err, False, name)
    return code, err


def test_issue_case_csv_cut_before_its_exponent_is_refused(csv_text, tmp_path):
    """The issue's file: the last number lost its ``e-05``; stored it would be 1e5 times
    its column."""
    body = csv_text.rstrip("\n")
    cut = body[:body.rindex("e")]
    code, err = _import(tmp_path, cut)
    lines = cut.count("\n") + 1
    assert code == 2 and f"line {lines}, the last" in err and "looks cut" in err
    assert "export the file again" in err and not (tmp_path / "cut.h5").exists()


@pytest.mark.parametrize("lost", range(1, 22))
def test_every_cut_inside_the_last_number_is_refused(csv_text, tmp_path, lost):
    """Cut 1..21 characters before the end of the last number (its newline gone too): the
    exponent digits, the exponent, fraction digits, the decimal point, the sign."""
    body = csv_text.rstrip("\n")
    last = body.rsplit(",", 1)[1]
    if lost >= len(last):
        pytest.skip("cut reaches the previous field")
    code, err = _import(tmp_path, body[:-lost])
    assert code == 2 and "the last" in err, (last, lost, err)


def test_whole_files_with_and_without_a_final_newline_import(csv_text, tmp_path):
    assert _import(tmp_path, csv_text, "nl")[0] == 0
    assert _import(tmp_path, csv_text.rstrip("\n"), "no_nl")[0] == 0   # the last line whole
    lines = csv_text.splitlines(keepends=True)   # lines cut off whole: a shorter recording
    assert _import(tmp_path, "".join(lines[:-5]), "shorter")[0] == 0


def test_a_last_line_missing_fields_and_a_short_middle_line_name_the_line(csv_text, tmp_path):
    body = csv_text.rstrip("\n")
    code, err = _import(tmp_path, body[:body.rindex(",")], "fields")
    assert code == 2 and "the last, has 3 of 4 fields" in err
    lines = csv_text.splitlines(keepends=True)
    k = 20
    lines[k] = lines[k][:lines[k].rindex(",")] + "\n"
    code, err = _import(tmp_path, "".join(lines), "middle")
    assert code == 2 and f"line {k + 1} has 3 fields but the header names 4" in err


def test_a_value_ten_times_its_column_on_an_unterminated_last_line(tmp_path):
    """Mixed notation (``%g``): no exponent to miss, the magnitude rule catches the cut."""
    rng = np.random.default_rng(2)
    t = np.arange(200) / 100.0
    rows = [f"{a:g},{b:g},{c:g}" for a, b, c in zip(t, rng.normal(size=200),
                                                   0.001 + 1e-4 * rng.normal(size=200))]
    rows[-1] = rows[-1].rsplit(",", 1)[0] + ",0.50000000"     # 0.5 where ~1e-3 belongs
    code, err = _import(tmp_path, "t,f0@0,x0@0\n" + "\n".join(rows), "magnitude")
    assert code == 2 and "over ten times the column's largest value" in err
    code, _ = _import(tmp_path, "t,f0@0,x0@0\n" + "\n".join(rows) + "\n", "terminated")
    assert code == 0   # a whole line (its newline written) is data, however large


# --- TOML nesting --------------------------------------------------------------------------
def test_toml_depth_ignores_brackets_in_strings_and_comments():
    text = ('name = "[[[[{{{{"\nx = \'[[[\'  # [[[[[[[\ny = """\n[[[[[[\n"""\n'
            "[[element]]\nm = [[1, [2]]]\n")
    assert toml_depth(text) == (3, 7)
    assert parse_toml(text, "t")["element"][0]["m"] == [[1, [2]]]


@pytest.mark.parametrize("depth", [MAX_TOML_DEPTH + 1, 2000, 100_000])
def test_deeply_nested_model_mass_exits_2(tmp_path, depth):
    path = tmp_path / "deep.toml"
    path.write_text("[linear]\nmass = " + "[" * depth + "1.0" + "]" * depth
                    + "\ndamping = [[1.0]]\nstiffness = [[1.0]]\n")
    with pytest.raises(ModelError, match=f"nested {depth} deep on line 2"):
        Model.load(path)
    code, err, _ = run_cli(["predict", str(path), "--amplitude", "1", "--band", "1", "10"])
    check_outcome(code, err, True, f"mass nested {depth} deep")


def test_deeply_nested_campaign_exits_2(tmp_path):
    doc = copy.deepcopy(CAMPAIGN)
    path = tmp_path / "c.toml"
    path.write_text(toml_text(doc).replace("levels = [", "levels = " + "[" * 3000, 1)
                    .replace("]", "]" * 3000, 1))
    code, err, _ = run_cli(["campaign", "check", str(path)])
    check_outcome(code, err, True, "campaign nested 3000 deep")
    assert "nested" in err


# --- force_dofs shape ----------------------------------------------------------------------
@pytest.mark.parametrize("dofs", [[[0]], [[0, 1]], np.zeros((1, 1, 1), int)])
def test_force_dofs_not_flat_exit_2_in_every_reader(tmp_path, dofs):
    rng = np.random.default_rng(0)
    path = tmp_path / "r.npz"
    np.savez(path, fs=256.0, force=rng.normal(size=(512, 1)),
             response=1e-5 * rng.normal(size=(512, 2)), force_dofs=np.asarray(dofs))
    model = tmp_path / "m.toml"
    model.write_text("[linear]\nmass = [[1.0, 0.0], [0.0, 1.0]]\n"
                     "damping = [[2.0, -1.0], [-1.0, 2.0]]\n"
                     "stiffness = [[2e4, -1e4], [-1e4, 2e4]]\n")
    for argv in (["import", str(path), "--out", str(tmp_path / "o.h5")],
                 ["export-uff", str(path), "--out", str(tmp_path / "o.uff")],
                 ["analyze", "reverse-path", str(path), "--model", str(model)],
                 ["diagnose", str(model), str(path)], ["detect", str(path)],
                 ["view", str(path), "--snapshot", str(tmp_path / "v.png")]):
        code, err, _ = run_cli(argv)
        check_outcome(code, err, True, f"{argv[0]} force_dofs {np.shape(dofs)}")
        assert "force_dofs must be a flat list" in err


# --- fault durations -----------------------------------------------------------------------
@pytest.mark.parametrize("key,value", [
    ("stall_seconds", float("nan")), ("stall_seconds", -1.0), ("stall_seconds", True),
    ("stall_at", 2.5), ("stall_at", float("nan")), ("drop_every", float("inf")),
    ("garbage_bytes", 10**9), ("seed", -1)])
def test_bad_fault_values_fail_campaign_check(tmp_path, key, value):
    doc = copy.deepcopy(CAMPAIGN)
    doc["emulator"] = {"faults": {"stall_at": 10, key: value}}
    with pytest.raises(CampaignError, match=f"emulator.faults.{key}"):
        parse_campaign(doc)
    path = tmp_path / "c.toml"
    path.write_text(toml_text(doc))
    code, err, _ = run_cli(["campaign", "check", str(path)])
    check_outcome(code, err, True, f"faults.{key} = {value!r}")


def test_infinite_stall_is_a_valid_fault():
    doc = copy.deepcopy(CAMPAIGN)
    doc["emulator"] = {"faults": {"stall_at": 10, "stall_seconds": float("inf")}}
    assert parse_campaign(doc).fault_spec().stall_seconds == float("inf")


def test_zeros_in_the_column_do_not_hide_a_cut(tmp_path):
    """A record padded with exact zeros (``%.17g`` writes ``0``): a force column cut to a
    few of its fraction digits is still refused."""
    rng = np.random.default_rng(5)
    t = np.arange(300) / 256.0
    f = rng.normal(size=300) * 10
    f[:20] = 0.0
    rows = [f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(t, 1e-5 * rng.normal(size=300), f)]
    text = "t,x0@0,f0@0\n" + "\n".join(rows)
    assert rows[5].endswith(",0")
    code, err = _import(tmp_path, text[:-9], "zeros")
    assert code == 2 and "fewer fraction digits" in err
