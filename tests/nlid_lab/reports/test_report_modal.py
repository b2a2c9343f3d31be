"""The report's modal-fit section: the fit `fit-linear` makes of the lowest random level, its
stabilisation diagram read back from the figure, and the modes table on the page."""

import re
from pathlib import Path

import numpy as np
import pytest

from analysis.models import Model
from nlid_lab import methods
from nlid_lab.reports import RunData, load_run, modal_fit_section, write_report
from analysis.recordings import Recording
from test_report import QUAD, random_run

TITLE = "Modal fit of the lowest level (fit-linear)"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return load_run(random_run(tmp_path_factory.mktemp("modal") / "r.h5"))


def test_stabilisation_figure_reads_back(run):
    sec = modal_fit_section(run)
    assert sec.title == TITLE
    (stem, fig), = sec.figures
    ax, twin = fig.axes[0], fig.axes[1]
    assert ax.get_xlabel() == "Frequency [Hz]" and ax.get_ylabel() == "Model order"
    assert twin.get_ylabel() == "Sum of |receptance| [m/N]"
    # the force is band-limited to 200 Hz: the fit band stops there, not at Nyquist
    lo, hi = ax.get_xlim()
    assert 0 < lo < 5 and 200 <= hi < 205
    stable = np.concatenate([ln.get_xdata() for ln in ax.lines if ln.get_marker() == "+"])
    unstable = [ln for ln in ax.lines if ln.get_marker() == "o"]
    assert stable.size >= 10 and unstable
    # the SDOF's linear resonance: sqrt(k/m) / 2 pi; stable poles gather there (the lowest
    # level still carries some quadratic damping, so within 1 %)
    model = Model.load(QUAD)
    fn = np.sqrt(model.stiffness[0, 0] / model.mass[0, 0]) / (2 * np.pi)
    assert np.median(np.abs(stable / fn - 1)) < 0.01
    # dashed lines: the selected modes, which the table lists
    selected = [ln.get_xdata()[0] for ln in ax.lines if ln.get_linestyle() == "--"]
    table = [float(f) for f in re.findall(r"<tr><td>\d+</td><td>([\d.]+)</td>", sec.text)]
    assert selected and np.allclose(selected, table, atol=5e-4)
    labels = ax.get_legend().get_texts()
    assert [t.get_text() for t in labels] == ["stable pole", "not stable", "selected mode",
                                              "sum of |receptance|"]
    curve = twin.lines[0].get_ydata()
    assert np.all(curve > 0) and twin.get_yscale() == "log"


def test_report_page_holds_the_diagram(tmp_path, run):
    out = write_report(run, tmp_path / "rep", estimators=methods)
    assert TITLE in out.sections and "stabilisation.png" in out.figures
    html = Path(out.html).read_text()
    assert 'src="stabilisation.png"' in html and "max MAC to another mode" in html
    assert (tmp_path / "rep" / "stabilisation.png").stat().st_size > 10_000


def test_stepped_runs_have_no_modal_section(tmp_path):
    freqs = np.array([40.0, 50.0, 60.0])
    t = np.arange(512) / 1024.0
    sine = np.cos(2 * np.pi * freqs[:, None] * t)[:, :, None]
    rec = Recording(1024.0, "stepped-sine", [0], sine, 1e-5 * sine, freqs=freqs, level=1.0)
    assert modal_fit_section(RunData(tmp_path / "s.h5", [rec])) is None


def test_a_level_fit_linear_cannot_take_says_why(tmp_path, run):
    rec = run.recordings[0]
    two = Recording(rec.fs, "random", [0, 1], np.repeat(rec.force, 2, axis=1),
                    np.repeat(rec.response, 2, axis=1), level=rec.level)
    sec = modal_fit_section(RunData(tmp_path / "two.h5", [two]))
    assert sec.title == TITLE and not sec.figures
    assert "No modal fit of level 0.5: fit-linear takes one force channel" in sec.text
