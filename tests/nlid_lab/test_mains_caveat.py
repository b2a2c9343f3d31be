"""The mains caveat on every path that period-averages a multisine (issue #23): with one
realization, mains locked to the period and in quadrature with the drive cannot be told from
a drive line (docs/daq-artifacts.md, "Mains on a drive line"). The BLA, the reverse path,
`fit-linear` and `detect` give the same line, from one source (`analysis.spectral.
MainsCaveat`), and say nothing when two or more realizations let rule 5 check.

The twin (`daq_twin`): 2-DOF chain, multisine 5-100 Hz on 0.5 Hz lines (50, 60 and 100 Hz
are drive lines), one realization of 1 + 3 periods per level.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.append(str(ROOT / "tests"))
import daq_twin as T  # noqa: E402
from analysis.detection import detect  # noqa: E402
from analysis.modal import LinearFitSummary, fit_linear  # noqa: E402
from analysis.spectral import MainsCaveat, best_linear_approximation, level_name  # noqa: E402
from nlid_lab.cli import main  # noqa: E402

#: the drive lines of the twin's band on a mains multiple (50 and 60 Hz grids)
MAINS_LINES = (50.0, 60.0, 100.0)


def _bla(rec):
    lay = rec.layout
    return best_linear_approximation(rec.force, rec.response, rec.fs, lay.period,
                                     transient_periods=lay.transient_periods,
                                     realizations=lay.realizations, force_hold=rec.force_hold)


def _quadrature_mains(rec, db: float = -17.5):
    """``rec`` with a 50 Hz mains line locked to the period, in quadrature with the force's
    50 Hz drive line and ``db`` under it, added to the force (the case rule 6 cannot tell)."""
    n = rec.layout.period
    k = int(round(50.0 * n / rec.fs))
    t = np.arange(rec.force.shape[0]) / rec.fs
    line = np.fft.rfft(rec.force[n:2 * n, 0])[k] * 2 / n       # one steady period
    mains = np.abs(line) * 10 ** (db / 20) * np.cos(2 * np.pi * 50.0 * t + np.angle(line)
                                                     + np.pi / 2)
    return dataclasses.replace(rec, force=rec.force + mains[:, None])


def test_one_realization_caveat_is_the_same_on_every_path():
    """One realization: the BLA, fit-linear and detect carry the same caveat naming the
    drive lines on mains multiples; a mains line in quadrature with the drive stays unnamed
    (nothing tells it) and the caveat covers it."""
    recs = T.clean_levels(levels=T.LEVELS, periods=3, realizations=1)
    expected = MainsCaveat(MAINS_LINES)
    for rec in (recs[0], _quadrature_mains(recs[0])):
        b = _bla(rec)
        assert b.caveat == expected and not b.interference
        fit = LinearFitSummary.of(fit_linear(rec, (5.0, 100.0), points=["drive", "tip"]),
                                  None)
        assert fit.caveat == expected
        assert LinearFitSummary.from_json(fit.to_json()) == fit
    notes = detect(list(recs)).notes
    for rec in recs:
        assert f"{level_name(rec)}: {expected.text()}" in notes


def test_realizations_check_mains_no_caveat():
    """Three realizations: rule 5 checks the drive lines; no caveat on any path."""
    recs = T.clean_levels(levels=T.LEVELS, periods=3)
    assert _bla(recs[0]).caveat is None
    assert LinearFitSummary.of(fit_linear(recs[0], (5.0, 100.0)), None).caveat is None
    assert not any("one realization" in n for n in detect(list(recs)).notes)


def _cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("realizations", [1, 3])
def test_cli_fit_linear_and_detect_say_the_caveat(tmp_path, realizations):
    """The F-16-layout export of the twin with the catalogue's mains, imported with the
    documented map: with one realization `fit-linear` prints the caveat as one warning line
    (JSON ``mains_unchecked_hz``) and `detect` as one note per level (rule 6 names the 50 Hz
    line where it moves the amplitude; the caveat then names what is left); with three,
    neither."""
    files = [str(p) for p in T.export(tmp_path, "mains", T.LEVELS, 3, realizations)]
    run = str(tmp_path / "run.h5")
    assert _cli(["import", *files, "--out", run, *T.MAP])[0] == 0
    code, out, err = _cli(["fit-linear", run, "--out", str(tmp_path / "l.toml"), "--band",
                           "5", "100", "--json", str(tmp_path / "fit.json")])
    assert code == 0, err
    fit = json.loads((tmp_path / "fit.json").read_text())
    said = [line for line in err.splitlines() if "one realization" in line]
    code, det, derr = _cli(["detect", run])
    assert code == 0, derr
    notes = [line for line in det.splitlines() if "one realization" in line]
    if realizations > 1:
        assert not said and not notes and "mains_unchecked_hz" not in fit
        return
    caveat = MainsCaveat(tuple(fit["mains_unchecked_hz"]))
    assert set(caveat.freqs_hz) <= set(MAINS_LINES) and caveat.freqs_hz
    assert said == [f"warning: {caveat.text()}"]
    # one note per level (each level's own lines), the lowest (fitted) level's first
    assert len(notes) == len(T.LEVELS) and notes[0].endswith(caveat.text())
    assert all(n.startswith("note: ") and "Hz is told only when" in n for n in notes)
