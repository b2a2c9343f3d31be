"""Viewer and live-view plots read back through pyqtgraph's PlotItems: axis labels with units,
log/linear/dB scales, legend entries, visible ranges holding the data, the header and the
progress bar telling the same numbers."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("pyqtgraph")
pytest.importorskip("pytestqt")

from PySide6 import QtGui  # noqa: E402

from analysis.hbm import HBMSystem  # noqa: E402
from analysis.models import Model  # noqa: E402
from analysis.recordings import Recording  # noqa: E402
from nlid_lab import store  # noqa: E402
from nlid_lab.campaign import CampaignStart  # noqa: E402
from nlid_lab.gui import _snapshot as snapshot  # noqa: E402
from nlid_lab.gui._live import HARMONIC_FLOOR_DB, LiveView  # noqa: E402
from nlid_lab.gui._offline import OfflineView, harmonic_distortion  # noqa: E402
from nlid_lab.reports import all_level_frfs, load_run  # noqa: E402
from test_report import STICK, random_run, stepped_run  # noqa: E402

FS = 2048.0


def legend_names(plot) -> list[str]:
    return [label.text for _, label in plot.legend.items]


def data_items(plot):
    return [c for c in plot.listDataItems() if c.xData is not None and c.xData.size]


def assert_view_holds(qtbot, plot, items=None) -> None:
    """The visible range holds every curve's data (log axes compare in log10), once the
    view has painted (pyqtgraph updates its auto range then)."""
    qtbot.wait(50)
    (x0, x1), (y0, y1) = plot.viewRange()
    for c in items if items is not None else data_items(plot):
        x, y = c.getData()          # already log10 on a log axis
        y = y[np.isfinite(y)]
        assert x0 <= x.min() and x.max() <= x1
        assert y0 <= y.min() and y.max() <= y1


def lightness(name: str) -> float:
    return QtGui.QColor(name).lightnessF()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("runs")
    rng = np.random.default_rng(0)
    acc = tmp / "acc.h5"
    store.save_recording(acc, Recording(fs=256.0, excitation="random", force_dofs=[0],
                                        force=rng.normal(size=(4096, 1)),
                                        response=rng.normal(size=(4096, 1)), level=3.0,
                                        response_kind="acceleration"))
    return {"random": load_run(random_run(tmp / "r.h5", seconds=8.0)),
            "stepped": load_run(stepped_run(tmp / "s.h5")), "acc": load_run(acc)}


def offline(qtbot, *runs) -> OfflineView:
    view = OfflineView(list(runs), [all_level_frfs(r) for r in runs])
    qtbot.addWidget(view)
    view.resize(1400, 900)
    view.show()
    qtbot.waitExposed(view)
    return view


def test_viewer_axes_units_legend_and_panels(qtbot, runs):
    view = offline(qtbot, runs["random"], runs["acc"])
    assert view.mag.getAxis("left").labelText == "Receptance |X/F| [m/N]"
    assert view.mag.getAxis("left").logMode and not view.phase.getAxis("left").logMode
    assert view.phase.getAxis("left").labelText == "Phase [deg]"
    assert view.phase.getAxis("bottom").labelText == "Frequency [Hz]"
    assert legend_names(view.mag) == ["r: 0.5 N rms", "r: 20 N rms",
                                      "acc: 3 N rms (acceleration converted)"]
    assert_view_holds(qtbot, view.mag)
    assert view.coh.isVisible() and not view.dist.isVisible()     # no stepped level ticked
    assert view.coh.getAxis("left").labelText == "γ² [-]"
    names = [view.tree.topLevelItem(0).child(i).text(0) for i in range(2)]
    fm = view.tree.fontMetrics()
    for name in names:                    # level names not cut (child rows are indented)
        assert view.tree.columnWidth(0) >= fm.horizontalAdvance(name) + view.tree.indentation()
    colours = [c.opts["pen"].color().name() for c in data_items(view.mag)]
    assert lightness(colours[0]) > lightness(colours[2]) > lightness(colours[1])   # 0.5 < 3 < 20


def test_viewer_stepped_levels_show_harmonic_distortion(qtbot, runs):
    view = offline(qtbot, runs["stepped"])
    assert not view.coh.isVisible() and view.dist.isVisible()     # no empty coherence panel
    qtbot.wait(50)
    assert view.coh.size().height() < 1 and view.dist.size().height() > 150   # nor its room
    assert view.dist.getAxis("left").labelText == "THD [dB]"
    assert not view.dist.getAxis("left").logMode
    rec = runs["stepped"].recordings[1]
    thd = harmonic_distortion(rec)[:, 0]
    X = HBMSystem(Model.load(STICK), harmonics=(1, 3, 5)).sweep(rec.freqs, [rec.level]).X
    exact = 20 * np.log10(np.sqrt(np.abs(X[:, 1, 0]) ** 2 + np.abs(X[:, 2, 0]) ** 2)
                          / np.abs(X[:, 0, 0]))
    np.testing.assert_allclose(thd, exact, atol=1e-3)             # noise-free synthesis
    curves = data_items(view.dist)
    assert len(curves) == 2 and np.allclose(curves[1].yData, thd)
    assert_view_holds(qtbot, view.dist)
    assert legend_names(view.mag) == ["50 N", "400 N"]


def test_viewer_table_shows_value_and_interval(qtbot, runs, tmp_path):
    path = tmp_path / "s.h5"
    path.write_bytes(runs["stepped"].path.read_bytes())
    est = {"kind": "hysteresis", "w": [1.0], "params": {"kd": 2.3e7, "fd": 250.0},
           "ci95": {"kd": [2.2e7, 2.4e7], "fd": [240.0, 260.0]}}
    store.save_result(path, "analyze-hbm", {"elements": [est], "cost": 0.01, "warnings": []})
    view = offline(qtbot, load_run(path))
    table = view.table
    fm = table.fontMetrics()
    for j in range(table.columnCount()):
        widest = max(fm.horizontalAdvance(table.item(i, j).text())
                     for i in range(table.rowCount()))
        assert table.columnWidth(j) >= widest
        assert not table.isColumnHidden(j)
    used = sum(table.columnWidth(j) for j in range(table.columnCount()))
    assert table.viewport().width() >= used                       # value and interval visible
    assert table.item(0, 4).text() == "[2.2e+07, 2.4e+07]"


def test_viewer_periodic_std_curves_have_legend_entries(qtbot, runs):
    from types import SimpleNamespace
    frfs = all_level_frfs(runs["random"])
    for frf in frfs:                          # the BLA fields the viewer draws
        g = frf.H[:, :, 0]
        frf.bla = SimpleNamespace(freqs=frf.freqs, G=g, var_total=np.abs(g) ** 2 * 1e-2,
                                  var_noise=np.abs(g) ** 2 * 1e-4)
    view = OfflineView([runs["random"]], [frfs])
    qtbot.addWidget(view)
    names = legend_names(view.mag)
    assert names == ["0.5 N rms", "20 N rms", "std of G: noise + distortion",
                     "std of G: noise"]


def test_viewer_converts_every_kind_onto_the_chosen_axis(qtbot, runs):
    from nlid_lab.reports import phase_deg
    view = offline(qtbot, runs["random"], runs["acc"])
    disp, acc = view.frfs[0][0], view.frfs[1][0]

    def drawn(index):
        """(f, |H|, phase) of the index-th ticked level as drawn (log axis holds log10; the
        phase's gaps at its +-180 wraps left out)."""
        f, logmag = data_items(view.mag)[index].getData()
        ph = data_items(view.phase)[index].getData()[1]
        return f, 10 ** logmag, ph[np.isfinite(ph)]

    def expected(frf, k, f):
        """(i w)^k times the level's own FRF (response DOF 0), at the drawn lines."""
        h = frf.H[np.searchsorted(frf.freqs, f), 0, 0] * (2j * np.pi * f) ** k
        return np.abs(h), phase_deg(h)

    view.set_kind("acceleration")
    assert view.mag.getAxis("left").labelText == "Accelerance |A/F| [(m/s²)/N]"
    assert view.frf_as.currentData() == "acceleration"
    assert legend_names(view.mag) == ["r: 0.5 N rms (displacement converted)",
                                      "r: 20 N rms (displacement converted)", "acc: 3 N rms"]
    f, mag, ph = drawn(0)
    want_mag, want_ph = expected(disp, 2, f)
    np.testing.assert_allclose(mag, want_mag, rtol=1e-12)
    np.testing.assert_allclose(ph, want_ph, atol=1e-9)
    f, mag, _ = drawn(2)                                  # measured as acceleration: as is
    np.testing.assert_allclose(mag, expected(acc, 0, f)[0], rtol=1e-12)
    assert_view_holds(qtbot, view.mag)

    view.frf_as.setCurrentIndex(1)                        # the box: mobility
    assert view.kind == "velocity"
    assert view.mag.getAxis("left").labelText == "Mobility |V/F| [(m/s)/N]"
    assert legend_names(view.mag)[2] == "acc: 3 N rms (acceleration converted)"
    f, mag, ph = drawn(2)
    want_mag, want_ph = expected(acc, -1, f)
    np.testing.assert_allclose(mag, want_mag, rtol=1e-12)
    np.testing.assert_allclose(ph, want_ph, atol=1e-9)
    f, mag, _ = drawn(1)
    np.testing.assert_allclose(mag, expected(view.frfs[0][1], 1, f)[0], rtol=1e-12)


def test_view_command_frf_as(qtbot, tmp_path, monkeypatch):
    from nlid_lab.cli import main
    seen = []
    import nlid_lab.gui as gui                      # the command takes `render` from here
    monkeypatch.setattr(gui, "render", lambda view, path, size: seen.append(
        view.mag.getAxis("left").labelText) or str(path))
    path = random_run(tmp_path / "r.h5", seconds=4.0)
    assert main(["view", str(path), "--frf-as", "acceleration", "--snapshot",
                 str(tmp_path / "v.png")]) == 0
    assert seen == ["Accelerance |A/F| [(m/s²)/N]"]


def stepped_info(n_steps: int = 10) -> CampaignStart:
    return CampaignStart(fs=FS, excitation="stepped-sine", force_dofs=(0,), n_dof=1,
                         harmonics=(0, 1, 2, 3), n_steps=n_steps, levels=(2.0, 8.0))


def feed_steps(obs, level: int, amp: float, freqs, start: int = 0) -> None:
    t = np.arange(1024) / FS
    for k, f in enumerate(freqs, start):
        h1 = amp * 1e-5 / (1 + 1j * (f - 50) / 5)
        harm = np.array([[0.0], [h1], [0.01 * h1], [0.1 * h1]])
        obs.step(level, k, f, amp * np.cos(2 * np.pi * f * t)[:, None],
                 np.real(h1 * np.exp(2j * np.pi * f * t))[:, None], 0.001, harm)


def test_live_stepped_header_progress_levels_and_harmonics_in_db(qtbot, tmp_path):
    view = LiveView(refresh_ms=10)
    qtbot.addWidget(view)
    view.resize(1200, 800)
    view.show()
    view.observer.campaign_started(stepped_info())
    freqs = np.linspace(40, 60, 10)
    feed_steps(view.observer, 0, 2.0, freqs)
    feed_steps(view.observer, 1, 8.0, freqs[:3])
    qtbot.waitUntil(lambda: view.level == 1 and len(view.steps) == 3, timeout=5000)
    view.drain()
    text = view.label.text()
    assert "level 2/2: 8 N" in text and "step 3/10" in text
    assert view.progress.value() == 3 and view.progress.maximum() == 10
    assert view.progress.format() == "level 2/2 · step 3/10"       # same numbers as header
    # the finished level stays, in a lighter colour than the higher one
    assert legend_names(view.mag) == ["2 N", "8 N"]
    curves = data_items(view.mag)
    assert [c.xData.size for c in curves] == [10, 3]
    assert lightness(curves[0].opts["pen"].color().name()) > \
        lightness(curves[1].opts["pen"].color().name())
    assert view.mag.getAxis("left").labelText == "Receptance |X/F| [m/N]"
    assert view.mag.getAxis("left").logMode
    assert_view_holds(qtbot, view.mag)
    # magnitude ticks: decades and 2x, 5x only, so labels cannot pile up
    axis = view.mag.getAxis("left")
    lo, hi = view.mag.viewRange()[1]
    ticks = [v for _, values in axis.tickValues(lo, hi, 300) for v in values]
    mantissa = np.round(10 ** (np.asarray(ticks) - np.floor(np.asarray(ticks))), 6)
    assert set(mantissa) <= {1.0, 2.0, 5.0} and len(ticks) <= 8
    # harmonic content in dB below the fundamental: orders 2 and 3 at -40 and -20 dB
    harm = view.harm_plot
    assert harm.getAxis("left").labelText == "|X_k| / |X_1| [dB]"
    assert not harm.getAxis("left").logMode
    (bars,) = view.harm_bars
    tops = np.asarray(bars.opts["y0"]) + np.asarray(bars.opts["height"])
    np.testing.assert_allclose(tops, [0.0, -40.0, -20.0], atol=1e-9)
    assert np.all(np.asarray(bars.opts["y0"]) == HARMONIC_FLOOR_DB)
    (y0, y1) = harm.viewRange()[1]
    assert y0 <= HARMONIC_FLOOR_DB and y1 >= 0.0
    snapshot.render(view, tmp_path / "live.png", (1200, 800))


def test_live_random_and_periodic_headers(qtbot):
    view = LiveView(refresh_ms=10)
    qtbot.addWidget(view)
    view.resize(1200, 800)
    view.show()
    rng = np.random.default_rng(1)
    info = CampaignStart(fs=512.0, excitation="random", force_dofs=(0,), n_dof=1,
                         levels=(5.0, 20.0), averages=8, block_len=1024)
    view.observer.campaign_started(info)
    for k in range(3):
        f = rng.standard_normal((1024, 1))
        view.observer.block(0, k, f, 1e-5 * f)
    qtbot.waitUntil(lambda: view.blocks == 3, timeout=5000)
    view.drain()
    assert "level 1/2: 5 N rms" in view.label.text() and "block 3/8" in view.label.text()
    assert view.progress.format() == "level 1/2 · block 3/8" and view.progress.value() == 3
    assert view.mag.titleLabel.text == "FRF: H1 averaged over the blocks"
    assert legend_names(view.mag) == ["5 N rms"]
    assert_view_holds(qtbot, view.mag)
    view.observer.campaign_started(replace(info, period=256, transient_periods=1,
                                           averages=4))
    for k in range(2):
        f = np.tile(rng.standard_normal((256, 1)), (3, 1))
        view.observer.block(0, k, f, 1e-5 * f)
    qtbot.waitUntil(lambda: view.blocks == 2, timeout=5000)
    view.drain()
    text = view.label.text()
    assert text.startswith("periodic random") and "realization 2/4" in text
    assert "BLA over 2 realizations" in text
    assert view.mag.titleLabel.text == "FRF: best linear approximation over the realizations"
