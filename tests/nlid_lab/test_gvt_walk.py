"""What a test engineer stumbled on walking docs/gvt-workflow.md on the artifact twins (issue
#23 item 3), each fixed and held here.

1. `fit-linear` took a one-sample channel delay out of its own FRF but `diagnose`, reading the
   run as recorded, then called the F-16-layout artifact twin "unexplained" (lowest level's
   FRF error 0.108 against a floor of 0.017): the summary line now says to import again with
   ``response_delay=`` in the map.
2. The drift and offset artifacts leak onto the period's lowest lines, which were named
   "interference at 0.1 Hz" (now ``slow drift at 0.1 Hz``), and on the small twin (0.5 Hz
   lines, band from 5 Hz) joined the band within the run gap: the report's modal fit (no
   ``--band``) ran over 0.5-100 Hz with 12 % FRF error (now 5-100 Hz, 2.2 %).
3. The fit band was printed as ``2.05078-14.9414 Hz``: now to 4 digits.
4. The report's level table said ``averages 1`` for a period-averaged multisine of 1 x 2
   periods (now ``1 x 2 periods``), and its modal-fit section named neither the delay
   fit-linear took out nor a drift line as such (it now gives fit-linear's own phrases).
"""

from __future__ import annotations

import contextlib
import io
import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.append(str(ROOT / "tests"))
import daq_twin as T  # noqa: E402
from analysis.spectral import excited_lines  # noqa: E402
from nlid_lab.cli import main  # noqa: E402


def _cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_fit_linear_says_how_to_align_the_run(tmp_path):
    """A one-sample delay: fit-linear names it and the map entry that aligns the run."""
    files = [str(p) for p in T.export(tmp_path, ("delay", "drift"), T.LEVELS, 3)]
    run = str(tmp_path / "run.h5")
    assert _cli(["import", *files, "--out", run, *T.MAP])[0] == 0
    code, out, err = _cli(["fit-linear", run, "--out", str(tmp_path / "l.toml")])
    assert code == 0, err
    first = out.splitlines()[0]
    assert "lag the force by 1 sample (95 % interval" in first
    assert first.endswith("import it again with response_delay=1 in the --map first")
    band = out.splitlines()[1].split(" mode(s) in ")[1].split(" Hz")[0]
    assert all(len(x.replace(".", "")) <= 4 for x in band.split("-")), band
    code, out, err = _cli(["report", run, "--out", str(tmp_path / "rep")])
    assert code == 0, err
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "lag the force by 1 sample (95 % interval" in page and "slow drift at 0.5 Hz" in page
    assert "response_delay=1</code>" in page        # the report states it as fit-linear does
    assert "modes in 5-100 Hz" in page                  # the drift's lines not in the band
    assert len(re.findall(r"<td>3 x \d periods</td>", page)) == len(T.LEVELS)


def test_drift_leakage_is_split_off_the_band():
    """Lines 1-4 falling as 1/k^2 (a drift's leakage), a gap, the band from line 10: the band
    keeps its own lines and the drift is named once; a band that itself starts at line 1
    stays whole."""
    f = np.arange(400) * 0.5
    p = np.zeros(400)
    p[10:200] = 1.0
    p[1:5] = 1e-2 / np.arange(1, 5) ** 2
    got = excited_lines(f, p)
    assert got.lines[0] == 10 and got.lines.size == 190
    (drift,) = got.interference
    assert drift.drift and drift.freq_hz == 0.5
    q = np.zeros(400)
    q[1:200] = 1.0
    assert excited_lines(f, q).lines.size == 199 and not excited_lines(f, q).interference


def test_drift_on_the_lowest_lines_is_named_a_drift():
    """A line on the period's first DFT line (a drift's leakage) is a drift; the same line
    further up is interference."""
    n = 400
    f = np.arange(n) * 0.1
    p = np.zeros(n)
    p[50:300] = 1.0                        # the designed band, 5-30 Hz
    for line in (1, 350):
        q = p.copy()
        q[line] = 1e-3
        (got,) = excited_lines(f, q).interference
        assert got.drift == (line == 1)
        assert got.text().startswith("slow drift at 0.1 Hz" if line == 1
                                     else "interference at 35.0 Hz")
