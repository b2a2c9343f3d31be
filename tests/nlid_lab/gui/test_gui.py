"""Qt views offscreen (pytest-qt): live view fed by a running simulated campaign thread,
offline viewer and PNG snapshots that show the expected curves."""

import threading

import numpy as np
import pytest

pytest.importorskip("pyqtgraph")
pytest.importorskip("pytestqt")

from PySide6 import QtGui  # noqa: E402

from analysis.models import Model  # noqa: E402
from analysis.plant import Plant  # noqa: E402
from nlid_lab.campaign import CampaignStart  # noqa: E402
from nlid_lab.cli import main  # noqa: E402
from nlid_lab.gui import _plots as plots, _snapshot as snapshot  # noqa: E402
from nlid_lab.gui._live import LiveView  # noqa: E402
from nlid_lab.gui._offline import OfflineView  # noqa: E402
from nlid_lab.reports import all_level_frfs, load_run  # noqa: E402
from test_report import random_run  # noqa: E402

MODEL = Model.load("examples/models/three-dof-paper.toml")
LINEAR = MODEL.with_elements([])
FS, BLOCK = 2048.0, 2048


def colour_pixels(path, hex_colour: str, tol: int = 40) -> int:
    img = QtGui.QImage(str(path)).convertToFormat(QtGui.QImage.Format.Format_RGB888)
    arr = np.frombuffer(img.constBits(), np.uint8).reshape(img.height(), img.bytesPerLine())
    rgb = arr[:, :img.width() * 3].reshape(img.height(), img.width(), 3).astype(int)
    target = np.array(QtGui.QColor(hex_colour).getRgb()[:3])
    return int(np.all(np.abs(rgb - target) < tol, axis=-1).sum())


def campaign_thread(observer, n_blocks: int, model=LINEAR, rms: float = 2.0):
    """A simulated random campaign: the plant runs block by block in its own thread and
    reports to ``observer`` as `nlid_lab.campaign._campaign` does."""
    def work():
        rng = np.random.default_rng(0)
        plant = Plant(model, FS, [0])
        observer.campaign_started(CampaignStart(fs=FS, excitation="random", force_dofs=(0,),
                                                n_dof=model.n_dof, block_len=BLOCK))
        for k in range(n_blocks):
            f = rms * rng.standard_normal((BLOCK, 1))
            observer.block(0, k, f, plant.run(f).response)
        observer.campaign_finished("complete")
    th = threading.Thread(target=work)
    th.start()
    return th


def test_live_view_builds_frf_average_by_average(qtbot, tmp_path):
    view = LiveView(refresh_ms=10)
    qtbot.addWidget(view)
    seen = []
    view.timer.timeout.connect(lambda: view.frf and seen.append(view.frf.n_averages))
    th = campaign_thread(view.observer, n_blocks=12)
    qtbot.waitUntil(lambda: view.status == "complete", timeout=20000)
    th.join()
    assert view.blocks == 12 and view.frf.n_averages == 12
    assert seen == sorted(seen) and seen[-1] == 12                  # grows per average
    freqs, mag = view.mag_curves[0].xData, view.mag_curves[0].yData
    assert freqs.size > 100 and np.all(mag > 0)
    # the averaged H1 of the linear plant follows the model receptance at the first mode
    true = np.abs(LINEAR.linear_frf(freqs, [0])[:, 0, 0])
    band = (freqs > 30) & (freqs < 150)
    assert np.median(np.abs(mag[band] - true[band]) / true[band]) < 0.1
    png = snapshot.render(view, tmp_path / "live.png", (1200, 800))
    assert colour_pixels(png, plots.channel_colour(0)) > 200          # force trace
    assert colour_pixels(png, plots.channel_colour(1)) > 200          # DOF 0 curves


def test_live_view_stepped_sine(qtbot, tmp_path):
    view = LiveView(refresh_ms=10)
    qtbot.addWidget(view)
    obs = view.observer
    obs.campaign_started(CampaignStart(fs=FS, excitation="stepped-sine", force_dofs=(0,),
                                       n_dof=3, harmonics=(1, 3, 5), n_steps=10))
    t = np.arange(1024) / FS
    freqs = np.linspace(50, 95, 8)
    H = LINEAR.linear_frf(freqs, [0])[:, :, 0]
    for i, f in enumerate(freqs):
        x = np.real(4 * H[i] * np.exp(2j * np.pi * f * t)[:, None])
        harm = np.array([4 * H[i], 0.1 * H[i], 0.01 * H[i]])
        obs.step(0, i, f, 4 * np.cos(2 * np.pi * f * t)[:, None], x, 0.002 * i, harm)
    qtbot.waitUntil(lambda: len(view.steps) == 8, timeout=5000)
    assert view.progress.value() == 8 and view.progress.maximum() == 10
    mag = view.mag_curves[1].yData
    np.testing.assert_allclose(mag, np.abs(H[:, 1]), rtol=1e-6)
    assert "95.00 Hz" in view.label.text()
    assert np.allclose(view.error_curve.getData()[1], 0.2 * np.arange(8))
    png = snapshot.render(view, tmp_path / "stepped.png")
    assert colour_pixels(png, "#d62728") > 100                         # control error


def test_offline_view_and_snapshot(qtbot, tmp_path):
    run = load_run(random_run(tmp_path / "r.h5", seconds=8.0))
    view = OfflineView([run], [all_level_frfs(run)])
    qtbot.addWidget(view)
    assert view.checked() == [(0, 0), (0, 1)]
    items = view.mag.listDataItems()
    assert len(items) == 2
    png = snapshot.render(view, tmp_path / "off.png")
    for colour in plots.level_colours(2):
        assert colour_pixels(png, colour, tol=30) > 100
    view.tree.topLevelItem(0).child(0).setCheckState(0, view.tree.topLevelItem(0)
                                                     .child(1).checkState(0).Unchecked)
    assert len(view.mag.listDataItems()) == 1


def test_view_command_snapshot(qtbot, tmp_path):
    path = random_run(tmp_path / "r.h5", seconds=8.0)
    png = tmp_path / "v.png"
    assert main(["view", str(path), "--snapshot", str(png), "--size", "900", "600"]) == 0
    img = QtGui.QImage(str(png))
    assert (img.width(), img.height()) == (900, 600)
    assert colour_pixels(png, plots.level_colours(2)[1], tol=30) > 100
    assert main(["view", str(tmp_path / "nope.h5"), "--snapshot", str(png)]) == 2


def _live_campaign(qtbot, camp, out) -> LiveView:
    """Run campaign ``camp`` (`nlid_lab.campaign.run_campaign`) in a thread into a live view."""
    from nlid_lab.campaign import run_campaign
    view = LiveView(refresh_ms=10)
    qtbot.addWidget(view)
    th = threading.Thread(target=run_campaign, args=(camp, out),
                          kwargs={"observer": view.observer})
    th.start()
    qtbot.waitUntil(lambda: view.status == "complete", timeout=60000)
    th.join()
    return view


def test_live_view_from_real_sim_campaign(qtbot, tmp_path):
    """`nlid_lab.campaign.run_campaign` on the simulated rig drives the live view."""
    from nlid_lab.campaign import load_campaign
    camp = load_campaign("examples/campaign-sim-random.toml")
    view = _live_campaign(qtbot, camp, tmp_path / "c.h5")
    per_level = camp.plan.averages
    assert view.level == len(camp.levels) - 1 and view.blocks >= per_level
    assert view.frf is not None and view.frf.n_averages >= per_level
    assert [name for name, _ in view.channel_names()] == ["F0", "x0"]
    assert view.time_curves[1].yData.size > 0


def test_live_view_shows_the_bla_of_a_periodic_campaign(qtbot, tmp_path):
    """Periodic-random campaign on the simulated rig: the FRF shown is the robust BLA over
    the realizations so far, on the period's exact lines."""
    from nlid_lab.campaign import load_campaign
    camp = load_campaign("examples/campaign-sim-periodic.toml")
    camp.plan.averages, camp.plan.periods = 3, 2
    view = _live_campaign(qtbot, camp, tmp_path / "p.h5")
    assert view.frf is not None and view.frf.bla is not None and view.frf.n_averages == 3
    df = np.diff(view.frf.freqs)
    assert np.allclose(df, camp.fs / camp.plan.block_size)          # exact lines, every one
    # offline, the same run shows the BLA with its total and noise standard deviation
    run = load_run(tmp_path / "p.h5")
    offline = OfflineView([run], [all_level_frfs(run)])
    qtbot.addWidget(offline)
    assert len(offline.mag.listDataItems()) == 3
