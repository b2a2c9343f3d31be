"""Exports laid out as public real data sets are (issue #23, session 33), as small twins:
the F-16 sine-sweep files, a Silverbox-like circuit export, CSV exports with a header row and
a time column, mains at 60 Hz and at 50.02 Hz (not locked to the DAQ's clock).

What each stumbled on before, now held here (docs/recording-formats.md "F-16 sine sweeps",
"Silverbox-like"; docs/gvt-workflow.md "Public layouts"):

1. a ``SineSw`` file imported with the F-16 section's command was stored as plain random
   (its generated force read as clipped); fit-linear, reverse path and backbone refused it
   without naming the command that takes a sweep;
2. the Silverbox-like file stopped at "the sample rate 'Fs' is not one number" (the file has
   none), then at "missing key(s) ['force_dofs']; an NPZ recording needs ..." (one response
   channel: nothing to choose), then imported as plain random (its ten realizations between
   gaps found nowhere); `:V` was "unknown unit";
3. a mapped CSV with a time column stopped asking for ``fs=``; an unmapped one was neither
   trimmed nor searched for its period, and ``Acceleration1`` columns were displacements;
4. mains at 50.02 Hz leaked into the lines around the one left out: fit-linear found a third
   mode at 49.4 Hz (0.08 % damping) and detect called the lowest level nonlinear (6.6 % of
   the lines; 2.9 % with locked 60 Hz mains): the unlocked sinusoid is now fitted and taken
   out of the periods (`analysis.spectral._unlocked`).
"""

from __future__ import annotations

import contextlib
import io
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.io

ROOT = Path(__file__).resolve().parents[2]
sys.path.append(str(ROOT / "tests"))
sys.path.append(str(ROOT / "tests" / "analysis" / "spectral"))
import daq_twin as T  # noqa: E402
from analysis.models import Element, Model  # noqa: E402
from analysis.plant import simulate  # noqa: E402
from analysis.recordings import (DaqArtifacts, SweepLaw, apply_daq_artifacts,  # noqa: E402
                                 find_bursts, looks_like_sweep)
from analysis.spectral import best_linear_approximation  # noqa: E402
from nlid_lab import formats  # noqa: E402
from nlid_lab.cli import main  # noqa: E402


def _cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def test_f16_sine_sweep_files_import_as_sweeps(tmp_path):
    """The F-16 section's import command on ``SineSw`` files: swept sine, law estimated;
    detect names the levels by their force amplitude; the modal and random-data commands
    refuse in one line naming analyze hbm."""
    from test_sweep_runs import f16_like

    law = SweepLaw(2.0, 15.0, "linear", 0.5)
    files = []
    for k, amp in ((1, 4.8), (7, 95.6)):
        files.append(tmp_path / f"F16Data_SineSw_Level{k}.mat")
        scipy.io.savemat(files[-1], f16_like(law, amp, 137, 800, 2e6))
    run = tmp_path / "run.h5"
    code, out, err = _cli(["import", *files, "--out", run, "--map", "force=Force",
                           "response=Acceleration[0:3]:m/s^2", "fs=Fs", "force_dofs=0",
                           "force_hold=\"none\""])
    assert code == 0, err
    assert "imported 2 files (swept-sine" in out and "the force sweeps" in out
    assert "clipped" not in out                    # the generated sine's crests, not a range
    for rec in formats.load_recordings(run):
        s = rec.sweep.law
        assert abs(s.start_hz - 2.0) < 0.01 and abs(s.stop_hz - 15.0) < 0.01
        assert abs(s.rate / 0.5 - 1) < 0.005
    code, out, err = _cli(["detect", run])
    assert code == 0, err
    assert "(swept sine up, 4.8 N vs 95.6 N, fundamental): NONLINEAR" in out
    for argv in (["fit-linear", run, "--out", tmp_path / "l.toml"],
                 ["backbone", run]):
        code, out, err = _cli(argv)
        assert code == 2 and err.count("\n") == 1 and "analyze hbm" in err, err


def test_a_sweep_is_told_from_a_multisine_and_noise():
    law = SweepLaw(2.0, 15.0, "linear", 0.5)
    t = np.arange(int(law.duration * 400)) / 400
    assert looks_like_sweep(np.sin(law.phase(t)), 400.0)
    from analysis.plant import multisine, periodic
    assert not looks_like_sweep(periodic(multisine(1024, 400.0, (2, 15), 1.0, seed=1), 8), 400.)
    assert not looks_like_sweep(np.random.default_rng(0).normal(size=8192), 400.0)


FS_SB, N_SB, R_SB = 1e7 / 2 ** 14, 8192, 5


def _silverbox(path: Path) -> None:
    """``V1``, ``V2`` rows: ``R_SB`` odd multisines of ``N_SB`` samples between 100-119-sample
    gaps of zeros, then a Gaussian 'arrow' of growing amplitude; a Duffing circuit (60 Hz,
    3 %), volts, no sample rate in the file."""
    k = (2 * np.pi * 60) ** 2
    model = Model(np.eye(1), np.array([[2 * 0.03 * 2 * np.pi * 60]]), np.array([[k]]),
                  [Element("cubic_spring", [1.0], {"p": 2e15})], "silverbox-like")
    rng = np.random.default_rng(1)
    parts = []
    for r in range(R_SB):
        spec = np.zeros(N_SB // 2 + 1, complex)
        lines = np.arange(1, int(200 / (FS_SB / N_SB)), 2)
        spec[lines] = np.exp(2j * np.pi * np.random.default_rng(r).uniform(size=lines.size))
        x = np.fft.irfft(spec, N_SB)
        parts += [np.zeros(100 + rng.integers(0, 20)), 0.1 * x / x.std()]
    arrow = np.linspace(0, 0.3, 6000) * rng.standard_normal(6000)
    u = np.concatenate(parts + [np.zeros(100), arrow, np.zeros(50)])
    y = simulate(model, u[:, None], FS_SB, [0], response_kind="displacement")[:, 0] * k
    scipy.io.savemat(path, {"V1": u[None], "V2": (y + 1e-4 * rng.standard_normal(y.size))[None]})


def test_silverbox_like_export(tmp_path):
    """What the user types and what each step says: the rate is asked for by name, volts are
    mapped without a unit, the realizations are found between the gaps (the arrow left out),
    fit-linear finds the circuit's resonance, detect says in one line why it cannot test."""
    src = tmp_path / "SNLS80mV.mat"
    _silverbox(src)
    run = tmp_path / "sb.h5"
    code, _, err = _cli(["import", src, "--out", run, "--map", "force=V1", "response=V2"])
    assert code == 2 and "no sample rate variable 'Fs' (the file holds V1, V2)" in err
    assert "fs=RATE" in err
    code, _, err = _cli(["import", src, "--out", run, "--map", "force=V1:V", "response=V2:V",
                         "fs=610.35"])
    assert code == 2 and "'V' is a voltage" in err and "force=V1 response=V2" in err
    code, out, err = _cli(["import", src, "--out", run, "--map", "force=V1", "response=V2",
                           "fs=610.35"])
    assert code == 0, err
    assert f"{R_SB} bursts of {N_SB} samples between quiet gaps taken as realizations" in out
    assert "burst at sample" in out and "left out (not a realization)" in out
    (rec,) = formats.load_recordings(run)
    lay = rec.layout
    assert (lay.period, lay.transient_periods, lay.periods, lay.realizations) == (
        N_SB, 0, 1, R_SB)
    code, out, err = _cli(["fit-linear", run, "--out", tmp_path / "l.toml"])
    assert code == 0, err
    assert f"BLA over {R_SB} realizations of one period" in out
    fn = float(out.splitlines()[3].split()[1])
    assert 60.0 < fn < 66.0, out                   # 60 Hz, stiffened by the cubic term
    code, _, err = _cli(["detect", run])
    assert code == 2 and "realizations of one period each" in err and err.count("\n") == 1


def test_bursts_are_found_between_quiet_gaps():
    rng = np.random.default_rng(0)
    gaps = [np.zeros(50), np.zeros(130), np.zeros(77)]
    bursts = [rng.normal(size=512) for _ in range(3)]
    x = np.concatenate([gaps[0], bursts[0], gaps[1], bursts[1], gaps[2], bursts[2],
                        np.zeros(40), rng.normal(size=900)])
    b = find_bursts(x)
    assert b.length == 512 and b.starts == (50, 692, 1281)
    assert b.others == ((1833, 900),)
    assert np.array_equal(b.cut(x), np.concatenate(bursts))
    assert find_bursts(rng.normal(size=4000)) is None


def _csv(path: Path, rec, header: str) -> None:
    t = np.arange(rec.force.shape[0]) / rec.fs
    np.savetxt(path, np.column_stack([t, rec.force, rec.response]), delimiter=",",
               header=header, comments="", fmt="%.10g")


def test_csv_exports_with_a_time_column(tmp_path):
    """Header row and time column: mapped, the rate comes from the time column (and it is no
    monitor); unmapped, the export is cleaned as a mapped one (padding, period) and
    ``Acceleration1`` columns are accelerations."""
    spec = DaqArtifacts.of(["zeros"], T.FS)
    recs = [apply_daq_artifacts(r, spec, np.random.default_rng(3))
            for r in T.clean_levels()]
    for i, rec in enumerate(recs):
        _csv(tmp_path / f"L{i}.csv", rec, "Time,Force,Acceleration1,Acceleration2")
        _csv(tmp_path / f"U{i}.csv", rec, "Time (s),Force (N),Acc1 (m/s^2),Acc2 (m/s^2)")
    files = [tmp_path / f"L{i}.csv" for i in range(len(recs))]
    code, out, err = _cli(["import", *files, "--out", tmp_path / "a.h5", "--map",
                           "force=Force", "response=Acceleration1,Acceleration2:m/s^2",
                           "force_dofs=0", "force_hold=\"none\""])
    assert code == 0, err
    assert "fs 512 Hz" in out and "monitor" not in out
    assert "1024-sample period found, 3 realizations" in out
    for stem, extra in (("U", []), ("L", [])):
        files = [tmp_path / f"{stem}{i}.csv" for i in range(len(recs))]
        code, out, err = _cli(["import", *files, "--out", tmp_path / f"{stem}.h5",
                               "--force-dofs", "0", *extra])
        assert code == 0, err
        assert "2 acceleration channel(s)" in out and "256 lead-in" in out
        assert "1024-sample period found" in out
        for got, clean in zip(formats.load_recordings(tmp_path / f"{stem}.h5"), recs):
            assert got.layout.period == T.PERIOD and got.layout.realizations == 3


def test_mains_off_the_grid_takes_its_neighbours_with_it():
    """Mains at 50.02 Hz (not locked) on the 50 Hz drive line: the line and the two beside
    it are left out; locked mains at 60 Hz leaves its neighbours in."""
    (clean,) = T.clean_levels(True, (2.0,), 3, 3)
    lines = {}
    for hz in (50.02, 60.0):
        spec = DaqArtifacts(mains_hz=hz, mains_db=-30.0)
        rec = apply_daq_artifacts(clean, spec, np.random.default_rng(11))
        lay = rec.layout
        b = best_linear_approximation(rec.force, rec.response, rec.fs, lay.period,
                                      transient_periods=lay.transient_periods,
                                      realizations=lay.realizations)
        lines[hz] = set(np.round(b.freqs, 3))
        assert any(i.source == "mains" and round(i.freq_hz) == round(hz)
                   for i in b.interference)
    assert not {49.5, 50.0, 50.5} & lines[50.02]
    assert {59.5, 60.5} <= lines[60.0] and 60.0 not in lines[60.0]


def test_unlocked_mains_twin_fits_two_modes(tmp_path):
    """The every-artifact twin with mains at 50.02 Hz: fit-linear's two modes, no third."""
    names = tuple(T.GVT_ARTIFACTS)
    spec = replace(DaqArtifacts.of(list(names), T.FS), mains_hz=50.02, mains_db=-30.0)
    files = []
    for i, rec in enumerate(T.clean_levels(True, T.LEVELS[:1], 3, 3)):
        rec = apply_daq_artifacts(rec, spec, np.random.default_rng(11 + i))
        files.append(tmp_path / f"Level{i + 1}.mat")
        scipy.io.savemat(files[-1], {"Force": rec.force.T, "Acceleration": rec.response.T,
                                     "Fs": np.array([[T.FS]])})
    run = tmp_path / "gvt.h5"
    assert _cli(["import", *files, "--out", run, *T.MAP])[0] == 0
    code, out, err = _cli(["fit-linear", run, "--out", tmp_path / "l.toml", "--band", "5",
                           "100"])
    assert code == 0, err
    said = "mains at 50.02 Hz on a drive line, not locked to the period (fitted and taken out)"
    assert "2 mode(s) in 5-100 Hz" in out and said in out
    code, out, err = _cli(["detect", run])
    assert code == 0, err
    assert "0.323 N rms): no evidence" in out and said in out


def test_unlocked_sinusoid_is_fitted_and_taken_out():
    """Noise-free: a periodic drive plus mains at 50.02 Hz and its harmonics; the fit finds
    the frequency within its search step (1/800 line) and what is left is the drive, up to
    the sinusoid's residual a frequency error within that step leaves (~1 % of it)."""
    from analysis.plant import multisine, periodic
    from analysis.spectral._unlocked import remove_unlocked

    fs, n, p = 512.0, 1024, 4
    drive = periodic(multisine(n, fs, (5, 100), 1.0, seed=2), p)
    t = np.arange(n * p) / fs
    mains = sum(0.05 / h * np.cos(2 * np.pi * h * 50.02 * t + h) for h in (1, 2, 3))
    per = np.stack([drive + mains, 2 * drive - mains], axis=1).reshape(1, p, n, 2)
    clean, hz = remove_unlocked(per, fs, 50.0)
    assert abs(hz - 50.02) <= fs / n / 800
    left = clean.reshape(n * p, 2) - np.stack([drive, 2 * drive], axis=1)
    assert np.sqrt(np.mean(left ** 2)) < 0.01 * np.sqrt(np.mean(mains ** 2))
