"""Artifact matrix (issue #23 item 2): each real-DAQ artifact of the catalogue
(`analysis.recordings.DaqArtifacts`) x each command path on the small GVT twin of
`daq_twin`, exported as F-16-like MAT files and run through the CLI in-process as
docs/gvt-workflow.md says. A cell passes when the command gives the clean twin's result
within the path's tolerance, or says what differs: exits 0 with a warning the clean twin does
not get, or, where no default could serve (`STOPS`), exits 2 with one line; never a
traceback, never exit 1.

Tolerances (what the clean twin's own spread allows):
- import: exit 0, and the period the importer finds is the clean one (1024 samples);
- detect: the same verdict;
- fit-linear: the same number of modes, frequencies within 1 %, damping within 25 %, and the
  written model's in-band accelerance error against the true underlying linear structure
  at most 2x the clean model's plus 1 % (a model with the right modes can still miss the
  FRFs: the one-sample delay gave 49 % before fit-linear took it out);
- analyze reverse-path: the cubic within 3 combined standard errors of the clean estimate
  (the intervals' half-widths / 1.96);
- analyze hbm: the same on a stepped-sine twin (`daq_twin.stepped_drive`: 9 steps through
  the first mode at 5 N, `simulate --response-kind acceleration --daq-artifacts ARTIFACT`,
  `import`, `analyze hbm` with the cubic left out); lead-in zeros and a partial period are
  continuous-record artifacts and leave the steps as they are, force dips do not apply to a
  stepped sine (its controller holds each step's amplitude: simulate says so in one line);
- report: exit 0 and an index.html;
- diagnose (of the cell's fit-linear model, `slow`): the same verdict and, when the clean
  twin names a missing physics, the same kind.

``python tests/nlid_lab/test_artifact_matrix.py`` prints the table of docs/daq-artifacts.md.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))                 # the project before tests/ (run as a script)
sys.path.append(str(ROOT / "tests"))         # daq_twin, as pytest finds it
import daq_twin as T  # noqa: E402
from analysis.models import Element  # noqa: E402
from analysis.recordings import ARTIFACTS  # noqa: E402
from nlid_lab.cli import main  # noqa: E402

PATHS = ("import", "detect", "fit-linear", "reverse-path", "hbm", "report", "diagnose")
#: paths run only with ``-m slow`` (seconds to a minute a cell)
SLOW = {"report", "diagnose"}
#: cells where stopping (exit 2, one line) is the right answer: no default could serve
STOPS = {("dead-channel", "reverse-path"), ("force-dips", "hbm")}
#: cells that do not give the clean result yet, with the measured reason
KNOWN: dict[tuple[str, str], str] = {}
# ("force-dips", "diagnose") left KNOWN in session 32: the dips cut the force near the modes
# (the cell reads ~0.16x the coil force), the cubic acts below every level's floor (3.22 N rms:
# 0.0332 against 0.0441) and the diagnosis says adequate where the clean twin says
# unexplained; it now says so beside the verdict (a gap lowers the misfit by 58 % in sample,
# BIC +320, too small at these levels to be named): `warned`, as detect's NONLINEAR asks.


def _cli(argv: list[str]) -> tuple[int, str]:
    """Exit code and stderr of one command (summaries to stdout are dropped)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, err.getvalue().strip()


@lru_cache(maxsize=None)
def _imported(folder: str, artifact: str | None) -> tuple[int, str, Path]:
    """Export the twin with ``artifact`` and import it; (exit code, stderr, run)."""
    d = Path(folder) / (artifact or "clean")
    d.mkdir(parents=True, exist_ok=True)
    files = T.export(d, artifact)
    run = d / "run.h5"
    code, err = _cli(["import", *map(str, files), "--out", str(run), *T.MAP, "--json",
                      str(d / "import.json"), "--force"])
    cand = d / "cand.toml"
    cand.write_text(T.truth().with_elements([Element("cubic_spring", [-1.0, 1.0], {})]).dumps())
    return code, err, run


@lru_cache(maxsize=None)
def _stepped(folder: str, artifact: str | None) -> dict:
    """The stepped-sine twin with ``artifact`` through simulate, import and analyze hbm."""
    d = Path(folder) / (artifact or "clean") / "stepped"
    d.mkdir(parents=True, exist_ok=True)
    model, drive, rec, run, js = (d / n for n in ("truth.toml", "drive.npz", "rec.npz",
                                                  "run.h5", "hbm.json"))
    model.write_text(T.truth().dumps())
    T.stepped_drive(drive)
    cand = d / "cand.toml"
    cand.write_text(T.truth().with_elements([Element("cubic_spring", [-1.0, 1.0], {})]).dumps())
    for argv in (["simulate", str(model), "--drive", str(drive), "--out", str(rec),
                  "--response-kind", "acceleration", "--seed", "3", "--force",
                  *(["--daq-artifacts", artifact] if artifact else [])],
                 ["import", str(rec), "--out", str(run), "--force"],
                 ["analyze", "hbm", str(run), "--model", str(cand), "--json", str(js),
                  "--force", "--quiet"]):
        code, err = _cli(argv)
        if code != 0:
            return {"code": code, "err": err, "result": {}}
    return {"code": 0, "err": err, "result": json.loads(js.read_text())}


@lru_cache(maxsize=None)
def outcome(folder: Path, artifact: str | None, path: str) -> dict:
    """Run ``path`` on the twin carrying ``artifact``; its exit code, stderr and result."""
    if path == "hbm":
        return _stepped(str(folder), artifact)
    code, err, run = _imported(str(folder), artifact)
    d = run.parent
    if path == "import" or code != 0:
        out = json.loads((d / "import.json").read_text()) if code == 0 else {}
        return {"code": code, "err": err if code else "", "result": out}
    js = d / f"{path}.json"
    if path == "diagnose" and outcome(folder, artifact, "fit-linear")["code"] != 0:
        return outcome(folder, artifact, "fit-linear")
    argv = {"detect": ["detect", str(run)],
            "fit-linear": ["fit-linear", str(run), "--out", str(d / "lin.toml"), "--band",
                           str(T.BAND[0]), str(T.BAND[1])],
            "reverse-path": ["analyze", "reverse-path", str(run), "--model",
                             str(d / "cand.toml")],
            "report": ["report", str(run), "--out", str(d / "report")],
            "diagnose": ["diagnose", str(d / "lin.toml"), str(run), "--model-out",
                         str(d / "fixed.toml")]}[path]
    code, err = _cli([*argv, "--json", str(js), "--force", "--quiet"]
                     if path != "report" else [*argv, "--force"])
    result = json.loads(js.read_text()) if code == 0 and js.exists() else {}
    if path == "report":
        result = {"index": (d / "report" / "index.html").exists()}
    out = {"code": code, "err": err, "result": result}
    if path == "fit-linear" and code == 0:
        out["on_truth"] = _error_on_truth(d / "lin.toml")
    return out


def _error_on_truth(model_file: Path) -> list[float]:
    """In-band accelerance error per channel of a fit-linear model against the twin's true
    underlying linear structure (what the model is worth, whatever noise or distortion the
    artifact added to its own data)."""
    import numpy as np

    from analysis.models import Model

    f = np.arange(T.BAND[0], T.BAND[1], T.FS / T.PERIOD)
    w2 = (2 * np.pi * f[:, None]) ** 2
    true = T.truth().with_elements([]).linear_frf(f, [0])[:, :, 0] * w2
    got = Model.load(model_file).linear_frf(f, [0])[:, :, 0] * w2
    return (np.linalg.norm(got - true, axis=0) / np.linalg.norm(true, axis=0)).tolist()


def compare(path: str, got: dict, clean: dict) -> str:
    """"same", or what differs from the clean twin's result."""
    r, c = got["result"], clean["result"]
    if path == "import":
        found = {(v or {}).get("period") for v in (r.get("period_found") or {"": None}).values()}
        want = {(v or {}).get("period") for v in c["period_found"].values()}
        return "same" if found == want else f"period {sorted(map(str, found))}"
    if path == "detect":
        return "same" if r["verdict"] == c["verdict"] else f"verdict {r['verdict']}"
    if path == "fit-linear":
        fr = [m["freq_hz"] for m in r["modes"]]
        fc = [m["freq_hz"] for m in c["modes"]]
        if len(fr) != len(fc):
            return f"{len(fr)} modes (clean {len(fc)})"
        for m, mc in zip(r["modes"], c["modes"]):
            if abs(m["freq_hz"] / mc["freq_hz"] - 1) > 0.01 \
                    or abs(m["damping_ratio"] / mc["damping_ratio"] - 1) > 0.25:
                return (f"mode {mc['freq_hz']:.2f} Hz -> {m['freq_hz']:.2f} Hz, "
                        f"{100 * m['damping_ratio']:.2f} %")
        err, err_c = got["on_truth"], clean["on_truth"]
        worse = [j for j, e in enumerate(err) if e > 2 * err_c[j] + 0.01]
        return "same" if not worse else "FRF error " + ", ".join(
            f"channel {j} {100 * err[j]:.1f} % (clean {100 * err_c[j]:.1f} %)" for j in worse)
    if path == "diagnose":
        kind = "+".join(e["kind"] for e in r.get("missing_physics") or [])
        want = "+".join(e["kind"] for e in c.get("missing_physics") or [])
        same = r["verdict"] == c["verdict"] and (c["verdict"] != "discrepancy" or kind == want)
        return "same" if same else f"{r['verdict']} {kind}".strip()
    if path in ("reverse-path", "hbm"):
        (e,), (ec,) = r["elements"], c["elements"]
        p, pc = e["params"]["p"], ec["params"]["p"]
        s = (e["ci95"]["p"][1] - e["ci95"]["p"][0]) / 3.92
        sc = (ec["ci95"]["p"][1] - ec["ci95"]["p"][0]) / 3.92
        return "same" if abs(p - pc) <= 3 * (s * s + sc * sc) ** 0.5 else \
            f"p {p:.3g} (clean {pc:.3g})"
    return "same" if r["index"] else "no index.html"


def cell_text(folder: Path, artifact: str, path: str) -> tuple[str, dict]:
    """The table's text for one cell and the raw outcome."""
    got = outcome(folder, artifact, path)
    if got["code"] == 2:
        return f"exit 2: {got['err']}", got
    if got["code"] != 0:
        return f"FAILED (exit {got['code']}): {got['err']}", got
    clean = outcome(folder, None, path)
    text = compare(path, got, clean)
    new = [w for w in got["result"].get("warnings", [])
           if w not in clean["result"].get("warnings", [])]
    return (f"warned: {new[0]}" if text != "same" and new else text), got


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("daq")


def _cells():
    for artifact in ARTIFACTS:
        for path in PATHS:
            marks = [pytest.mark.slow] if path in SLOW else []
            if (artifact, path) in KNOWN:
                marks.append(pytest.mark.xfail(strict=True, reason=KNOWN[artifact, path]))
            yield pytest.param(artifact, path, marks=marks, id=f"{artifact}-{path}")


@pytest.mark.parametrize("artifact, path", list(_cells()))
def test_artifact_gives_the_clean_result_or_one_line(folder, artifact, path):
    text, got = cell_text(folder, artifact, path)
    assert got["code"] in (0, 2), text
    if got["code"] == 2:
        assert (artifact, path) in STOPS, f"a hard stop where a default could serve: {text}"
        assert got["err"] and "\n" not in got["err"], text
    else:
        assert text == "same" or text.startswith("warned: "), text
    if path in ("import", "detect"):      # clipped samples named where they are, only there
        said = (got["result"].get("clipped") if path == "import" else
                [n for n in got["result"]["notes"] if "clipped sample" in n])
        assert bool(said) == (artifact == "clipping"), said


def test_clean_twin_runs_every_path(folder):
    """The clean twin itself: every path runs, the importer finds the period, the cubic
    interval is informative."""
    for path in (p for p in PATHS if p != "diagnose"):        # diagnose: slow cells
        got = outcome(folder, None, path)
        assert got["code"] == 0, (path, got["err"])
    (el,) = outcome(folder, None, "reverse-path")["result"]["elements"]
    lo, hi = el["ci95"]["p"]
    assert 0 < lo < hi < 2 * T.P_TRUE


if __name__ == "__main__":
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        print("| artifact | " + " | ".join(PATHS) + " |")
        print("|---" * (len(PATHS) + 1) + "|")
        for artifact in ARTIFACTS:
            row = [cell_text(Path(tmp), artifact, path)[0].replace("|", "/") for path in PATHS]
            print(f"| {artifact} | " + " | ".join(row) + " |", flush=True)


def test_simulate_adds_named_artifacts(tmp_path, capsys):
    """``simulate --daq-artifacts``: a name outside the catalogue exits 2 listing them; zeros
    pad the record by 0.5 s at each end, force-dips lower the force at the first mode."""
    import numpy as np

    from analysis.plant import random_gaussian

    (tmp_path / "m.toml").write_text(T.truth().dumps())
    n = 8192
    np.savez(tmp_path / "d.npz", fs=T.FS, force=random_gaussian(n, T.FS, T.BAND, 2.0, 1)[:, None],
             force_dofs=np.array([0]), excitation="random")
    base = ["simulate", str(tmp_path / "m.toml"), "--drive", str(tmp_path / "d.npz"), "--out"]
    assert main([*base, str(tmp_path / "x.npz"), "--daq-artifacts", "hum"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "'hum' is not one of mains" in err
    assert main([*base, str(tmp_path / "z.npz"), "--daq-artifacts", "zeros,force-dips",
                 "--seed", "1"]) == 0
    with np.load(tmp_path / "z.npz") as z, np.load(tmp_path / "d.npz") as d:
        force, flat = z["force"][:, 0], d["force"][:, 0]
    half = int(T.FS / 2)
    assert force.size == n + 2 * half and not force[:half].any() and not force[-half:].any()
    f = np.fft.rfftfreq(n, 1 / T.FS)
    gain = np.abs(np.fft.rfft(force[half:-half])) / np.abs(np.fft.rfft(flat)).clip(1e-300)
    at = np.argmin(np.abs(f - 14.92))                         # first mode
    assert gain[at] < 0.5 * np.median(gain[(f > 60) & (f < 100)])
