"""Excited lines as a test engineer picks them (`analysis.spectral.excited_lines`): the
multisine's designed band, interference (mains 50 Hz and harmonics) left out and named, in
every command that period-averages a multisine (detect, fit-linear)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import f16_twin as T
from analysis.spectral import best_linear_approximation, excited_lines
from nlid_lab.cli import main

MAINS = ((50.0, -30.0), (100.0, -40.0), (150.0, -50.0))     # Hz, dB below the drive lines


def _spectrum(n=1025, band=(100, 400), step=1, missing=(), stray=()):
    """Line power of a drive on ``band`` (every ``step``-th line, ``missing`` left out), plus
    ``stray`` (index, dB) lines."""
    p = np.zeros(n)
    p[np.arange(band[0], band[1] + 1, step)] = 1.0
    p[list(missing)] = 0.0
    for i, db in stray:
        p[i] = 10 ** (db / 10)
    return np.arange(n) * 0.1, p


def test_isolated_lines_are_interference_named_with_their_level():
    f, p = _spectrum(stray=[(500, -35.0), (1000, -39.0), (30, -30.0), (700, -45.0)])
    got = excited_lines(f, p, np.full(f.size, 1e-9))
    assert got.lines.tolist() == list(range(100, 401))
    # a line below the floor (1e-4 of the strongest, -40 dB here) was never taken as excited:
    # nothing to leave out
    assert [(i.freq_hz, round(i.level_db)) for i in got.interference] == \
        [(3.0, -30), (50.0, -35), (100.0, -39)]
    assert got.note() == ("interference at 3.0 Hz, -30 dB, interference at 50.0 Hz, -35 dB, "
                          "interference at 100.0 Hz, -39 dB, left out")


def test_gappy_and_odd_multisines_keep_their_lines_and_drop_off_grid_interference():
    rng = np.random.default_rng(0)
    missing = rng.choice(np.arange(101, 400), 90, replace=False)     # 30 % of the lines
    f, p = _spectrum(missing=missing)
    assert excited_lines(f, p).lines.tolist() == sorted(set(range(100, 401)) - set(missing))
    # odd lines only, a mains line on an even line inside the band
    f, p = _spectrum(band=(101, 399), step=2, stray=[(250, -30.0)])
    got = excited_lines(f, p)
    assert got.lines.tolist() == list(range(101, 400, 2))
    assert [i.freq_hz for i in got.interference] == [25.0]


def test_band_first_and_unsteady_lines():
    f, p = _spectrum(stray=[(500, -40.0)])
    got = excited_lines(f, p, band=(0.0, 45.0))
    assert got.lines.tolist() == list(range(100, 401)) and not got.interference
    # a line whose period average is not above its spread is not a drive line
    noise = np.full(f.size, 1e-9)
    noise[200] = 1.0
    assert 200 not in excited_lines(f, p, noise).lines


def with_mains(levels: list[dict], seed: int = 0) -> list[dict]:
    """The twin's MAT variables with mains pick-up (`MAINS`) added to the force and to every
    accelerometer, each line its level below the median drive line of that channel."""
    rng = np.random.default_rng(seed)
    out = []
    for data in levels:
        new = dict(data)
        for key in ("Force", "Acceleration"):
            x = np.array(data[key], dtype=float)
            t = np.arange(x.shape[1]) / T.FS
            period = x[:, -4096:]                                 # one steady period
            spec = np.abs(np.fft.rfft(period, axis=1))
            f = np.fft.rfftfreq(period.shape[1], 1 / T.FS)
            drive = (f >= T.BAND[0]) & (f <= T.BAND[1])
            for row in range(x.shape[0]):
                line = np.median(spec[row, drive]) * 2 / period.shape[1]   # a drive line's
                # amplitude
                for hz, db in MAINS:
                    x[row] += line * 10 ** (db / 20) * np.cos(2 * np.pi * hz * t
                                                              + rng.uniform(0, 2 * np.pi))
            new[key] = x
        out.append(new)
    return out


@pytest.fixture(scope="module")
def twins():
    """The reduced F-16-like twin (levels 1 and 7), clean and with mains pick-up."""
    t = T.twin(True, 4096, 4, (1, 7))
    return t, T.Twin(with_mains(t.levels), t.period, t.periods, t.joint)


def test_bla_of_the_twin_with_mains_is_the_clean_one(twins):
    clean, mains = (T.recordings(t)[0] for t in twins)
    a, b = (best_linear_approximation(r.force, r.response, r.fs, r.layout.period,
                                      transient_periods=1) for r in (clean, mains))
    assert np.array_equal(a.freqs, b.freqs)              # 2-15 Hz, every line, nothing more
    assert a.freqs.min() >= T.BAND[0] and a.freqs.max() <= T.BAND[1]
    assert not a.interference
    # 50 Hz is above the excited floor (1e-4 of the strongest line: -41.5 dB of the median
    # here) and left out; 100 and 150 Hz were never above it
    (i,) = b.interference
    assert round(i.freq_hz, 1) == 50.0 and abs(i.level_db - MAINS[0][1]) < 1.0, i
    # mains on DFT lines of the period (50 Hz = line 512 of 4096 at 400 Hz) adds nothing to
    # the drive lines: the same FRF but for rounding
    np.testing.assert_allclose(b.G, a.G, rtol=1e-8)


def test_fit_linear_and_detect_through_the_cli_leave_mains_out(twins, tmp_path, capsys):
    """The issue's chain: import, detect, fit-linear --band 2 15 (stopped on the mains line
    before). The same modes as the clean twin, the interference named on the summary line."""
    fits = {}
    for name, t in zip(("clean", "mains"), twins):
        folder = tmp_path / name
        folder.mkdir()
        files = T.export_mat(t, folder, (1, 7))
        run = folder / "run.h5"
        assert main(["import", *map(str, files), "--out", str(run), "--map", "force=Force",
                     "response=Acceleration[0:3]:m/s^2", "fs=Fs", "force_dofs=0",
                     'force_hold="none"']) == 0
        capsys.readouterr()
        assert main(["detect", str(run), "--json", str(folder / "d.json")]) == 0
        said = capsys.readouterr().out
        assert "unknown" not in said and "N rms vs " in said
        assert main(["fit-linear", str(run), "--out", str(folder / "lin.toml"), "--band", "2",
                     "15", "--points", "wing_drive,wing_joint,payload",
                     "--json", str(folder / "fit.json")]) == 0
        fits[name] = (said, capsys.readouterr().out, json.loads((folder / "fit.json").read_text()))
    detect_said, fit_said, fit = fits["mains"]
    assert "note: 12.4 N rms: interference at 50.0 Hz, -30 dB, left out" in detect_said
    assert detect_said.count("N rms: interference at 50.0 Hz, -30 dB, left out") == 2
    # --band first: 50 Hz was never considered
    assert fit_said.splitlines()[0] == "fitted on 12.4 N rms" and "interference" not in fit
    # without --band: left out and said
    assert main(["fit-linear", str(tmp_path / "mains" / "run.h5"), "--out",
                 str(tmp_path / "any.toml"), "--json", str(tmp_path / "any.json")]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first == "fitted on 12.4 N rms; interference at 50.0 Hz, -30 dB, left out", first
    unbanded = json.loads((tmp_path / "any.json").read_text())
    assert [round(i["freq_hz"], 1) for i in unbanded["interference"]] == [50.0]
    clean = fits["clean"][2]
    assert "interference" not in clean and "interference" not in fits["clean"][1]
    # the modes of the clean fit (the same drive-line data but for rounding)
    f0 = [m["freq_hz"] for m in clean["modes"]]
    f1 = [m["freq_hz"] for m in fit["modes"]]
    assert len(f0) == len(f1) >= 7
    np.testing.assert_allclose(f1, f0, rtol=1e-6)
    np.testing.assert_allclose([m["damping_ratio"] for m in fit["modes"]],
                               [m["damping_ratio"] for m in clean["modes"]], rtol=1e-4)
