"""A ground-vibration-test export: periodic multisine levels in separate MAT files (struct of
Force, Voltage, Acceleration, Fs), accelerometers, force measured as it acted."""

import json

import numpy as np
import pytest
import scipy.io

from analysis.plant import Plant, add_relative_noise, multisine, periodic
from analysis.models import Element, Model
from nlid_lab.cli import main

FS, PERIOD, UP = 512.0, 1024, 8
TRANSIENT, PERIODS, REALIZATIONS = 6, 4, 4
P_TRUE = 5e8


def truth() -> Model:
    k = np.array([[2e4, -1e4], [-1e4, 2e4]])
    m = np.eye(2)
    return Model(m, 2e-4 * k + 0.5 * m, k, [Element("cubic_spring", [0.0, 1.0], {"p": P_TRUE})])


def export(path, model, rms, seed):
    """What the acquisition system writes: the DAQ samples a smooth force and the
    accelerations (the structure simulated UP times faster), 1 % sensor noise."""
    blocks_f, blocks_a = [], []
    for r in range(REALIZATIONS):
        fine = multisine(PERIOD * UP, FS * UP, (3.0, 60.0), rms, seed=seed + r)
        drive = periodic(fine, TRANSIENT + PERIODS)
        out = Plant(model, FS * UP, [0], response_kind="acceleration").run(drive[:, None])
        blocks_f.append(drive[::UP])
        blocks_a.append(out.response[::UP])
    rng = np.random.default_rng(seed)
    acc = add_relative_noise(np.concatenate(blocks_a), 0.01, rng)
    force = add_relative_noise(np.concatenate(blocks_f)[:, None], 0.01, rng)[:, 0]
    scipy.io.savemat(path, {"data": {
        "Force": force[:, None], "Voltage": 0.1 * force[:, None], "Acceleration": acc / 9.80665,
        "Fs": FS, "BlockSize": PERIOD, "Title": f"multisine {rms} N"}})


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gvt")
    files = []
    for i, rms in enumerate((1.5, 5.0)):
        files.append(tmp / f"level{i}.mat")
        export(files[-1], truth(), rms, seed=10 * i + 1)
    out = tmp / "gvt.h5"
    assert main(["import", *map(str, files), "--out", str(out), "--map", "force=Force",
                 "response=Acceleration:g", "fs=Fs", "force_dofs=0", "period=BlockSize",
                 f"transient_periods={TRANSIENT}", f"realizations={REALIZATIONS}"]) == 0
    candidate = tmp / "candidate.toml"
    truth().with_elements([Element("cubic_spring", [0.0, 1.0], {})]).save(candidate)
    return tmp, out, candidate


def test_detect_period_averages_the_imported_multisine(run, capsys):
    tmp, out, _ = run
    js = tmp / "detect.json"
    assert main(["detect", str(out), "--json", str(js)]) == 0
    result = json.loads(js.read_text())
    bla = [t for t in result["tests"] if t["method"] == "bla"]
    assert len(bla) == 2 and all(t["realizations"] == REALIZATIONS for t in bla)
    assert all(t["periods"] == PERIODS for t in bla)
    assert bla[1]["nonlinear"] and result["verdict"] == "nonlinear"


def test_reverse_path_period_averages_and_covers_the_truth(run):
    tmp, out, candidate = run
    js = tmp / "rp.json"
    assert main(["analyze", "reverse-path", str(out), "--model", str(candidate),
                 "--json", str(js)]) == 0
    result = json.loads(js.read_text())
    assert result["noise"]["method"].startswith("periodic")
    assert result["force_hold"] == "none"
    [el] = result["elements"]
    lo, hi = el["ci95"]["p"]
    assert lo <= P_TRUE <= hi and (hi - lo) < 0.05 * P_TRUE, (el["params"]["p"], lo, hi)


def test_realizations_back_to_back_found_without_layout_keys(run, capsys):
    """The same exports with no layout key in the map: period, realizations and transient
    periods found on import (the responses settle over the 6 generated transient periods at
    the higher level, so both levels drop 6); detect and reverse-path period-average with no
    flags and cover the truth as with the explicit layout."""
    tmp, _, candidate = run
    files = [tmp / "level0.mat", tmp / "level1.mat"]
    out = tmp / "found.h5"
    assert main(["import", *map(str, files), "--out", str(out), "--map", "force=Force",
                 "response=Acceleration:g", "fs=Fs", "force_dofs=0",
                 "--json", str(tmp / "found.json")]) == 0
    said = capsys.readouterr().out
    assert (f"periodic: {PERIOD}-sample period found, {REALIZATIONS} realizations back to "
            f"back of {TRANSIENT + PERIODS} periods each") in said
    found = json.loads((tmp / "found.json").read_text())["period_found"]
    assert {f["realizations"] for f in found.values()} == {REALIZATIONS}
    from nlid_lab.formats import load_recordings          # Voltage kept, block by block
    for path, rec in zip(files, load_recordings(out)):
        volt = scipy.io.loadmat(path, simplify_cells=True)["data"]["Voltage"]
        np.testing.assert_array_equal(rec.monitors["Voltage"], volt)
    js = tmp / "found-detect.json"
    assert main(["detect", str(out), "--json", str(js)]) == 0
    bla = [t for t in json.loads(js.read_text())["tests"] if t["method"] == "bla"]
    assert all(t["realizations"] == REALIZATIONS for t in bla)
    steady = {t["periods"] for t in bla}
    assert len(steady) == 1 and 2 <= steady.pop() <= PERIODS
    js = tmp / "found-rp.json"
    assert main(["analyze", "reverse-path", str(out), "--model", str(candidate),
                 "--json", str(js)]) == 0
    result = json.loads(js.read_text())
    assert result["noise"]["method"].startswith("periodic")
    [el] = result["elements"]
    lo, hi = el["ci95"]["p"]
    assert lo <= P_TRUE <= hi and (hi - lo) < 0.05 * P_TRUE, (el["params"]["p"], lo, hi)


def test_a_map_giving_only_the_period_gets_the_realizations(run, capsys):
    from nlid_lab.formats import load_recordings
    tmp, _, _ = run
    out = tmp / "given.h5"
    assert main(["import", str(tmp / "level0.mat"), "--out", str(out), "--map", "force=Force",
                 "response=Acceleration:g", "fs=Fs", "force_dofs=0", "period=BlockSize",
                 f"transient_periods={TRANSIENT}"]) == 0
    assert (f"periodic: {PERIOD}-sample period given, {REALIZATIONS} realizations back to "
            "back") in capsys.readouterr().out
    [rec] = load_recordings(out)
    assert (rec.layout.period, rec.layout.transient_periods, rec.layout.periods,
            rec.layout.realizations) == (PERIOD, TRANSIENT, PERIODS, REALIZATIONS)
