"""Live view of a campaign with a `[sensors]` map: every channel named by point and kind."""

import threading

import pytest

pytest.importorskip("pyqtgraph")
pytest.importorskip("pytestqt")

from nlid_lab.campaign import parse_campaign, run_campaign  # noqa: E402
from nlid_lab.gui._live import LiveView  # noqa: E402
from nlid_lab.gui._offline import OfflineView  # noqa: E402
from nlid_lab.reports import all_level_frfs, load_run  # noqa: E402
from test_campaign_sensors import BASE, EXAMPLES, short  # noqa: E402


def test_live_view_names_points_and_kinds(qtbot, tmp_path):
    data = short(BASE)
    data["sensors"]["response_kinds"] = ["acceleration", "acceleration", "displacement"]
    camp = parse_campaign(data, EXAMPLES)
    view = LiveView(refresh_ms=10)
    qtbot.addWidget(view)
    th = threading.Thread(target=run_campaign, args=(camp, tmp_path / "s.h5"),
                          kwargs={"observer": view.observer})
    th.start()
    qtbot.waitUntil(lambda: view.status == "complete", timeout=60000)
    th.join()
    labels = ["drive (acceleration)", "joint (acceleration)", "payload (displacement)"]
    assert [name for name, _ in view.channel_names()] == ["force@drive"] + labels
    assert [unit for _, unit in view.channel_names()] == ["N", "m/s^2", "m/s^2", "m"]
    legend = [label.text for _, label in view.mag.legend.items]
    assert all(label in legend for label in labels)
    assert not any("DOF" in text for text in legend)
    left = [view.graphs.ci.getItem(0, 0).getItem(i, 0).getAxis("left").labelText
            for i in range(4)]
    assert left == ["force@drive [N]", "drive (acceleration) [m/s^2]",
                    "joint (acceleration) [m/s^2]", "payload (displacement) [m]"]
    assert view.frf is not None and view.frf.H.shape[1] == 3
    assert view.mag_curves[2].yData.size > 0        # the displacement channel is drawn


def test_offline_view_offers_responses_by_point_and_kind(qtbot, tmp_path):
    run_campaign(parse_campaign(short(BASE), EXAMPLES), tmp_path / "a.h5")
    run = load_run(tmp_path / "a.h5")
    offline = OfflineView([run], [all_level_frfs(run)])
    qtbot.addWidget(offline)
    assert [offline.output.itemText(i) for i in range(offline.output.count())] == [
        "response drive (acceleration)", "response joint (acceleration)",
        "response payload (acceleration)"]
