"""The demo end to end on a reduced configuration: campaign -> HDF5 run -> reverse-path
estimate (table, JSON, stored result) -> HTML report, and the reverse-path CLI on its run."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Element, Model
from nlid_lab import store
from nlid_lab.cli import main

SDOF = Path(__file__).resolve().parents[2] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
DURATION, FS = 64.0, 1024.0
NPERSEG = int(DURATION * FS) // 4          # what the demo picks for records this short
FN = float(Model.load(SDOF).natural_frequencies()[0])


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["demo", "--out", str(out), "--levels", "15", "30", "--duration",
                   str(DURATION), "--json", str(out / "summary.json")])
    assert rc == 0
    return out, buf.getvalue()


def _candidate(tmp_path: Path) -> Path:
    model = Model.load(SDOF)
    cand = model.with_elements([Element(e.kind, e.w, {}) for e in model.elements])
    path = tmp_path / "candidate.toml"
    cand.save(path)
    return path


def test_demo_estimate_table_json_and_stored_result(demo):
    out, printed = demo
    model = Model.load(SDOF)
    est = json.loads((out / "reverse-path.json").read_text())
    assert est["force_hold"] == "linear"               # declared by the simulated run
    assert [e["kind"] for e in est["elements"]] == ["cubic_spring", "quadratic_damping"]
    for e, ref in zip(est["elements"], model.elements):
        value, (lo, hi) = e["params"]["p"], e["ci95"]["p"]
        truth = ref.params["p"]
        assert lo < value < hi
        # noise-free: the random error (95 % half-width) plus the 0.1 % budget for
        # the systematic error of noise-free data
        assert abs(value - truth) <= 1e-3 * truth + (hi - lo) / 2, (e["kind"], value)
    mc = est["multiple_coherence"]
    assert mc["min"] >= 0.99 and mc["min_linear"] < 0.5       # paper fig 3.9
    # the campaign drives independent random blocks: their joins spread the drive spectrum a
    # little past the band edges that the band selection reads off the force spectrum
    assert mc["band_hz"][0] == pytest.approx(5.0, abs=0.5)
    assert mc["band_hz"][1] == pytest.approx(200.0, abs=0.5)
    # underlying linear system: one mode at the model's natural frequency, its damping from
    # the residual-force H1 fitted through the Welch kernel (tests/test_reverse_path_linear:
    # within 2.3 % at 0.5 Hz lines, 3 std 4 %); here 0.0625 Hz lines
    (mode,) = est["modal"]["modes"]
    fn = FN
    zeta = model.damping[0, 0] / (2 * np.sqrt(model.stiffness[0, 0] * model.mass[0, 0]))
    df = FS / NPERSEG
    assert est["resolution_hz"] == pytest.approx(df)
    assert mode["freq_hz"] == pytest.approx(fn, rel=1e-3)
    assert mode["damping_ratio"] == pytest.approx(zeta, rel=0.04)
    assert "residual-force" in est["modal"]["method"]
    assert mode["shape"] == [1.0] and mode["in_band"]
    # the same estimate is stored in the run, under the name the report lists
    run = store.open_run(out / "sdof-random.h5")
    assert run.results["analyze-reverse-path"]["elements"] == est["elements"]
    # readable table: true vs estimated with intervals, coherence and the mode
    assert "true" in printed and "95 % interval" in printed and "multiple coherence" in printed
    assert "cubic_spring" in printed and "50.3" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["estimate"]["elements"] == est["elements"]
    assert summary["detection"]["verdict"] == "nonlinear"           # model-free, before fitting
    assert "detection (model-free" in printed


def test_demo_writes_the_report(demo):
    out, printed = demo
    page = out / "report" / "index.html"
    html = page.read_text()
    assert "analyze-reverse-path" in html                 # stored estimates table
    assert "reverse_path_coherence.png" in html
    assert (out / "report" / "reverse_path_linear_coefficients_in0.png").stat().st_size > 10_000
    assert str(page) in printed


def test_cli_on_demo_run_reproduces_it_and_honours_force_hold(demo, tmp_path, capsys):
    out, _ = demo
    cand = _candidate(tmp_path)
    run = str(out / "sdof-random.h5")
    base = ["analyze", "reverse-path", run, "--model", str(cand), "--nperseg", str(NPERSEG)]
    assert main(base + ["--json", "-"]) == 0
    captured = capsys.readouterr()
    js = json.loads(captured.out)                         # stdout is pure JSON
    assert "estimate" in captured.err and "mode" in captured.err
    demo_js = json.loads((out / "reverse-path.json").read_text())
    assert js["force_hold"] == "linear" and js["elements"] == demo_js["elements"]
    assert js["modal"] == demo_js["modal"]
    assert main(base + ["--force-hold", "none", "--json", str(tmp_path / "none.json")]) == 0
    none = json.loads((tmp_path / "none.json").read_text())
    assert none["force_hold"] == "none"
    # ignoring the first-order hold scales the force spectrum by 1/sinc^2(f/fs): the cubic
    # coefficient comes out high by at least that factor at the resonance (0.8 %), roughly
    ratio = none["elements"][0]["params"]["p"] / js["elements"][0]["params"]["p"]
    assert ratio > 1 + 0.5 * (1 / np.sinc(FN / FS) ** 2 - 1)


def test_cli_sequential_refinement(demo, tmp_path, capsys):
    out, _ = demo
    run = str(out / "sdof-random.h5")
    base = ["analyze", "reverse-path", run, "--model", str(_candidate(tmp_path)),
            "--nperseg", str(NPERSEG), "--json", "-"]
    assert main(base + ["--refine", "sequential"]) == 0
    captured = capsys.readouterr()
    js = json.loads(captured.out)
    assert "sequential (each with the others fixed)" in captured.err
    assert js["refine"]["method"] == "sequential"
    # both elements act on the forced DOF: each refined value inside its joint interval
    for el, joint in zip(js["elements"], js["refine"]["joint"]):
        lo, hi = joint["ci95"]
        assert lo <= el["params"]["p"] <= hi, (el, joint)
