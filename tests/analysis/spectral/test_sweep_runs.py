"""Swept sine end to end: F-16-like MAT export import (law estimated), campaigns, detect."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from analysis.models import Element, Model
from analysis.plant import Plant, add_relative_noise
from analysis.recordings import SweepLaw
from nlid_lab import formats as rio
from nlid_lab.cli import main

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
FS = 400.0


M3 = np.diag([20.0, 10.0, 5.0])
K3 = np.array([[3e4, -1e4, 0], [-1e4, 1.5e4, -5e3], [0, -5e3, 5e3]])
C3 = 6e-4 * K3 + 0.5 * M3             # modes 2.88, 5.66, 7.81 Hz; damping 1.8-2.0 %


def f16_like(law: SweepLaw, amplitude: float, lead: int, tail: int, p: float):
    """Force 1xN, Voltage 1xN, Acceleration 3xN (channel-major) of a 3-DOF chain (three
    modes in 2-15 Hz, a cubic spring between the 'wing' and the 'payload' points 1 and 2)
    swept by ``law``, 0.5 % sensor noise: a quiet lead-in (sensor noise) before the sweep,
    trailing zeros."""
    model = Model(M3, C3, K3,
                  [Element("cubic_spring", [0.0, 1.0, -1.0], {"p": p})] if p else [])
    t = np.arange(int(round(law.duration * FS))) / FS
    force = amplitude * np.sin(law.phase(t))
    acc = Plant(model, FS, [0], response_kind="acceleration").run(force[:, None]).response
    rng = np.random.default_rng(0)
    acc = add_relative_noise(acc, 0.005, rng)           # 0.5 % sensor noise
    pad = lambda x: np.concatenate([1e-3 * amplitude * rng.normal(size=lead), x,  # noqa: E731
                                    np.zeros(tail)])
    return {"Force": pad(force)[None], "Voltage": pad(force / 20)[None],
            "Acceleration": np.stack([pad(a) for a in acc.T]), "Fs": FS}


def test_f16_like_sweep_export_imports_with_estimated_law(tmp_path, capsys):
    law = SweepLaw(15.0, 2.0, "linear", 0.05)         # the F-16 sweep: 104,000 samples at 400 Hz
    lead, tail = 137, 800
    scipy.io.savemat(tmp_path / "F16Data_SineSw_Level1.mat", f16_like(law, 4.8, lead, tail, 0))
    scipy.io.savemat(tmp_path / "F16Data_SineSw_Level7.mat", f16_like(law, 95.6, lead, tail,
                                                                       2e6))
    files = [str(tmp_path / f"F16Data_SineSw_Level{k}.mat") for k in (1, 7)]
    out = tmp_path / "sweep.h5"
    assert main(["import", *files, "--out", str(out), "--excitation", "swept-sine", "--map",
                 "force=Force", "response=Acceleration[0:3]:m/s^2", "fs=Fs", "force_dofs=0",
                 "--json", str(tmp_path / "import.json")]) == 0
    said = capsys.readouterr().out
    assert "estimated from the force" in said
    recs = rio.load_recordings(out)
    for rec in recs:
        s = rec.sweep
        assert s.estimated and s.law.law == "linear" and s.law.direction == -1
        # stated tolerance (docs/recording-formats.md): start/stop within 0.01 Hz, rate 0.5 %
        assert abs(s.law.start_hz - 15.0) < 0.01 and abs(s.law.stop_hz - 2.0) < 0.01
        assert abs(s.law.rate / 0.05 - 1) < 0.005
        assert abs(s.trimmed_lead - lead) <= 2 and s.trimmed_tail == tail
        assert rec.force.shape[0] == pytest.approx(law.duration * FS, abs=3)
    assert [round(r.level, 1) for r in recs] == [4.8, 95.6]   # the force amplitude, estimated
    # every key survives run -> export -> import
    assert main(["export", str(out), "--level", "1", "--out", str(tmp_path / "l7.npz")]) == 0
    back = rio.read_npz(tmp_path / "l7.npz")
    assert back.sweep == recs[1].sweep and np.array_equal(back.force, recs[1].force)
    # ... and through MAT: export writes variables MATLAB reads, import needs no map for it
    assert main(["export", str(out), "--level", "1", "--out", str(tmp_path / "l7.mat")]) == 0
    assert main(["import", str(tmp_path / "l7.mat"), "--out", str(tmp_path / "l7.h5")]) == 0
    (again,) = rio.load_recordings(tmp_path / "l7.h5")
    assert again.sweep == recs[1].sweep and np.array_equal(again.response, recs[1].response)
    assert scipy.io.loadmat(tmp_path / "l7.mat")["sweep_law"][0] == "linear"
    # detect: harmonic distortion at the high level, level dependence between the two
    assert main(["detect", str(out), "--json", str(tmp_path / "d.json"), "-q"]) == 0
    result = json.loads((tmp_path / "d.json").read_text())
    harm = [t for t in result["tests"] if t["method"] == "sweep-harmonics"]
    assert [t["nonlinear"] for t in harm] == [False, True]
    assert result["verdict"] == "nonlinear"
    # analyze hbm on the sweeps: the rate check warns (0.05 Hz/s is 7-40 times ISO's limit
    # for these modes) and the fit runs on the points left (8.8-15 Hz, where the joint barely
    # works: the estimate is not meaningful, which the warnings say)
    cand = tmp_path / "cand.toml"
    Model(M3, C3, K3).save(cand)
    cand.write_text(cand.read_text() + '\n[[element]]\nkind = "cubic_spring"\n'
                    'w = [0.0, 1.0, -1.0]\n')
    assert main(["analyze", "hbm", str(out), "--model", str(cand), "--json",
                 str(tmp_path / "h.json"), "-q"]) == 0
    fit = json.loads((tmp_path / "h.json").read_text())
    assert sum("ISO 7626-2" in w for w in fit["warnings"]) == 6     # 3 modes x 2 levels


def test_partial_sweep_option_overrides_the_estimate(tmp_path):
    law = SweepLaw(3.0, 12.0, "log", 4.0)
    data = f16_like(law, 2.0, 50, 100, 0)
    np.savez(tmp_path / "s.npz", fs=FS, force_dofs=[0], force=data["Force"].T,
             response=data["Acceleration"].T, response_kind="acceleration")
    assert main(["import", str(tmp_path / "s.npz"), "--out", str(tmp_path / "s.h5"),
                 "--sweep", "3:12:log"]) == 0
    (rec,) = rio.load_recordings(tmp_path / "s.h5")
    assert (rec.sweep.law.start_hz, rec.sweep.law.stop_hz, rec.sweep.law.law) == (3, 12, "log")
    assert abs(rec.sweep.law.rate / 4.0 - 1) < 0.005 and rec.sweep.estimated


def test_sweep_option_parses_into_its_fields():
    assert rio.parse_sweep_option("15:2:linear:0.05") == rio.SweepOption(15.0, 2.0, "linear",
                                                                         0.05)
    option = rio.parse_sweep_option("3:12")
    assert option.keys() == {"sweep_start_hz": 3.0, "sweep_stop_hz": 12.0}   # rest estimated


def test_bad_sweep_option_is_one_line(tmp_path, capsys):
    np.savez(tmp_path / "s.npz", fs=FS, force_dofs=[0], force=np.ones((10, 1)),
             response=np.ones((10, 1)))
    assert main(["import", str(tmp_path / "s.npz"), "--out", str(tmp_path / "s.h5"),
                 "--sweep", "fast"]) == 2
    assert "START:STOP" in capsys.readouterr().err


@pytest.mark.parametrize("example", ["campaign-sim-sweep.toml", "campaign-serial-sweep.toml"])
def test_sweep_campaign_examples_run_and_detect(tmp_path, example):
    out = tmp_path / "run.h5"
    assert main(["campaign", "run", str(EXAMPLES / example), "--out", str(out), "-q"]) == 0
    recs = rio.load_recordings(out)
    assert [r.sweep.law.direction for r in recs] == [1, -1] * (len(recs) // 2)
    for r in recs:
        assert r.force.shape[0] == pytest.approx(r.sweep.law.duration * r.fs, abs=2)
        assert abs(np.abs(r.force).max() / r.level - 1) < 0.05
    assert main(["detect", str(out), "--json", str(tmp_path / "d.json"), "-q"]) == 0
    result = json.loads((tmp_path / "d.json").read_text())
    if "sim" in example:   # 0.25 Hz/s: analyze hbm warns once per sweep and fits the rest
        assert main(["analyze", "hbm", str(out), "--model",
                     str(EXAMPLES / "candidates" / "sdof-candidate.toml"), "--json",
                     str(tmp_path / "h.json"), "-q"]) == 0
        fit = json.loads((tmp_path / "h.json").read_text())
        assert sum("ISO 7626-2" in w for w in fit["warnings"]) == len(recs)
        assert main(["report", str(out), "--out", str(tmp_path / "rep")]) == 0
        page = (tmp_path / "rep" / "index.html").read_text()
        assert "Swept-sine levels" in page and "8 N, sweep down" in page
    hyst = [t for t in result["tests"] if t["method"] == "sweep-hysteresis"]
    top = max(hyst, key=lambda t: t["levels"][0])
    # 8 N on the hardening SDOF: the up-sweep falls off the resonant branch near 59 Hz, the
    # down-sweep jumps onto it near 53 Hz
    assert top["jumps"]["up"]["jump"] and top["jumps"]["up"]["freq_hz"] > 57
    assert result["verdict"] == "nonlinear"


CAMPAIGN = """name = "duffing sweep"
kind = "swept-sine"
[plant]
model = "{model}"
shaker_gain = 20.0
[shaker]
url = "sim://"
gain_guess = 20.0
[daq]
url = "sim://"
fs = 1024.0
frame_size = 1024
[[channel]]
name = "F0"
quantity = "force"
dof = 0
[[channel]]
name = "x0"
quantity = "displacement"
dof = 0
[sweep]
levels = [{amp}]
start = {lo}
stop = {hi}
rate = 0.02
direction = "up-down"
"""


@pytest.mark.slow
@pytest.mark.parametrize("p, amp, band", [(6e10, 5.0, (46.0, 62.0)), (-2e10, 4.0, (40.0, 54.0))],
                         ids=["hardening", "softening"])
def test_duffing_sweep_campaign_jumps_both_ways_as_harmonic_balance(tmp_path, p, amp, band):
    """Done-when of the issue through campaign -> run -> detect: the slow sweeps (0.02 Hz/s,
    a seventh of the ISO limit) of a hardening and a softening Duffing jump in both
    directions, where harmonic balance says, and their FRF is harmonic balance's within 1 %
    away from the jumps."""
    from analysis.hbm import HBMSystem
    from analysis.spectral import recording_sweep_frf

    model = Model([[2.0]], [[10.0]], [[2e5]], [Element("cubic_spring", [1.0], {"p": p})])
    model.save(tmp_path / "m.toml")
    (tmp_path / "c.toml").write_text(CAMPAIGN.format(model=tmp_path / "m.toml", amp=amp,
                                                     lo=band[0], hi=band[1]))
    out = tmp_path / "run.h5"
    assert main(["campaign", "run", str(tmp_path / "c.toml"), "--out", str(out), "-q"]) == 0
    system = HBMSystem(model, [0], (1, 3, 5))
    jumps = {}
    for rec in rio.load_recordings(out):
        r = recording_sweep_frf(rec, harmonics=(1, 3, 5), points=400)
        hbm = system.sweep(r.freqs, r.force[:, None])
        h_hbm = hbm.X[:, 0, 0] / r.force
        step = np.abs(np.diff(np.log(np.abs(r.frf[:, 0]))))
        j = int(np.argmax(step))
        j_hbm = int(np.argmax(np.abs(np.diff(np.log(np.abs(h_hbm))))))
        assert abs(r.freqs[j] - r.freqs[j_hbm]) < 0.15
        away = (np.abs(r.freqs - r.freqs[j]) > 1.0) \
            & (np.abs(r.freqs - rec.sweep.law.start_hz) > 2.0)
        assert np.abs(r.frf[away, 0] / h_hbm[away] - 1).max() < 0.01
        jumps[rec.sweep.law.direction] = r.freqs[j]
    assert jumps[1] - jumps[-1] > 1.0
    assert main(["detect", str(out), "--json", str(tmp_path / "d.json"), "-q"]) == 0
    result = json.loads((tmp_path / "d.json").read_text())
    (hyst,) = [t for t in result["tests"] if t["method"] == "sweep-hysteresis"]
    assert hyst["nonlinear"] and hyst["jumps"]["up"]["jump"] and hyst["jumps"]["down"]["jump"]
    assert abs(hyst["jumps"]["up"]["freq_hz"] - jumps[1]) < 0.15
    assert all(t["nonlinear"] for t in result["tests"] if t["method"] == "sweep-harmonics")


def test_simulate_plays_a_sweep_drive(tmp_path):
    """A swept-sine drive (its law given) gives a swept-sine recording with the same sweep."""
    from analysis.spectral import sweep_signal

    law = SweepLaw(40.0, 60.0, "log", 30.0)
    np.savez(tmp_path / "drive.npz", fs=1024.0, force_dofs=[0], excitation="swept-sine",
             force=sweep_signal(law, 1024.0, 2.0)[:, None], sweep_start_hz=40.0,
             sweep_stop_hz=60.0, sweep_law="log", sweep_rate=30.0)
    model = tmp_path / "m.toml"
    model.write_text('name = "sdof"\n[linear]\nmass = [[2.0]]\ndamping = [[10.0]]\n'
                     'stiffness = [[2e5]]\n')
    assert main(["simulate", str(model), "--drive", str(tmp_path / "drive.npz"), "--out",
                 str(tmp_path / "sim.h5")]) == 0
    (rec,) = rio.load_recordings(tmp_path / "sim.h5")
    assert rec.excitation == "swept-sine" and rec.sweep.law == law and not rec.sweep.estimated


def test_sweep_tests_pass_a_linear_structure_at_two_levels(tmp_path):
    """Two levels of a linear structure (independent sensor noise), estimated laws: no
    harmonic distortion, no level dependence (the sweep-rate bias is the same at both)."""
    from analysis.detection import detect

    law = SweepLaw(15.0, 2.0, "linear", 0.5)
    recs = []
    for k, amp in enumerate((4.8, 95.6)):
        data = f16_like(law, amp, 60, 200, 0)
        noisy = add_relative_noise(data["Acceleration"].T, 0.005, np.random.default_rng(k))
        np.savez(tmp_path / f"l{k}.npz", fs=FS, force_dofs=[0], excitation="swept-sine",
                 force=data["Force"].T, response=noisy, response_kind="acceleration")
        recs.append(rio.read_npz(tmp_path / f"l{k}.npz"))
    result = detect(recs)
    assert result.verdict == "no evidence", result.tests
    assert {t.method for t in result.tests} == {"sweep-harmonics",
                                                      "sweep-level-dependence"}


def test_log_down_sweep_campaign_plays_its_law(tmp_path):
    """A log down-sweep on the sim rig: the stored force follows the law the run records
    (estimated back from the force alone: log, rate within 1 %, ends within 0.1 Hz)."""
    from analysis.recordings import estimate_sweep

    text = CAMPAIGN.format(model=EXAMPLES / "models" / "sdof-linear.toml", amp=2.0,
                           lo=30.0, hi=70.0)
    text = text.replace('rate = 0.02\ndirection = "up-down"',
                        'rate = 12.0\nlaw = "log"\ndirection = "down"')
    (tmp_path / "c.toml").write_text(text)
    assert main(["campaign", "run", str(tmp_path / "c.toml"), "--out", str(tmp_path / "r.h5"),
                 "-q"]) == 0
    (rec,) = rio.load_recordings(tmp_path / "r.h5")
    assert rec.sweep.law == SweepLaw(70.0, 30.0, "log", 12.0) and not rec.sweep.estimated
    est, amp = estimate_sweep(rec.force[:, 0], rec.fs)
    assert est.law.law == "log" and abs(est.law.rate / 12.0 - 1) < 0.01
    assert abs(est.law.start_hz - 70.0) < 0.1 and abs(est.law.stop_hz - 30.0) < 0.1
    assert amp == pytest.approx(2.0, rel=0.02)


def test_commands_without_a_sweep_route_say_so(tmp_path, capsys):
    """diagnose, fit-linear and reverse path refuse a swept-sine run in one line (exit 2)."""
    from analysis.spectral import sweep_signal

    law = SweepLaw(40.0, 60.0, "linear", 4.0)
    f = sweep_signal(law, 1024.0, 1.0)[:, None]
    np.savez(tmp_path / "s.npz", fs=1024.0, force_dofs=[0], excitation="swept-sine", force=f,
             response=1e-5 * f, sweep_start_hz=40.0, sweep_stop_hz=60.0, sweep_law="linear",
             sweep_rate=4.0)
    model = EXAMPLES / "models" / "sdof-linear.toml"
    for argv in (["diagnose", str(model), str(tmp_path / "s.npz"), "--json",
                  str(tmp_path / "d.json")],
                 ["fit-linear", str(tmp_path / "s.npz"), "--out", str(tmp_path / "m.toml")],
                 ["analyze", "reverse-path", str(tmp_path / "s.npz"), "--model", str(model)]):
        assert main(argv) == 2, argv
        assert "swept" in capsys.readouterr().err or argv[1] == "reverse-path"
