"""``campaign run --live``: the live view follows a campaign run in a worker thread
(offscreen, pytest-qt); closing the window stops the campaign, which --resume finishes."""

from pathlib import Path

import pytest

pytest.importorskip("pyqtgraph")
pytest.importorskip("pytestqt")

import nlid_lab.gui._live as live  # noqa: E402
from nlid_lab.cli import main  # noqa: E402
from nlid_lab.store import open_run  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
STEPS = 6


def stepped(tmp_path: Path, step: str = "8.0") -> Path:
    text = (ROOT / "examples" / "campaign-sim-stepped.toml").read_text()
    text = text.replace('model = "models/', f'model = "{ROOT}/examples/models/')
    text = text.replace("step = 2.0", f"step = {step}")
    path = tmp_path / "campaign.toml"
    path.write_text(text)
    return path


class Spy(live.LiveView):
    """The live view, remembering what it showed when its window closed."""

    seen: list = []
    close_after_steps: int | None = None

    def drain(self) -> int:
        n = super().drain()
        if self.close_after_steps is not None and len(self.steps) >= self.close_after_steps:
            self.close()
        return n

    def closeEvent(self, event) -> None:  # noqa: N802 - Qt name
        Spy.seen.append({"status": self.status, "info": self.info, "steps":
                         len(self.steps), "level": self.level, "bar": (
                             self.progress.value(), self.progress.maximum())})
        super().closeEvent(event)


@pytest.fixture
def spy(qapp, monkeypatch):
    Spy.seen, Spy.close_after_steps = [], None
    monkeypatch.setattr(live, "LiveView", Spy)
    return Spy


def test_live_view_follows_campaign_and_closes_when_done(spy, tmp_path):
    out = tmp_path / "run.h5"
    assert main(["campaign", "run", str(stepped(tmp_path)), "--out", str(out),
                 "--live-close"]) == 0
    assert open_run(out).status == "complete"
    [shown] = spy.seen
    assert shown["status"] == "complete" and shown["level"] == 1
    assert shown["info"].n_steps == STEPS and shown["steps"] == STEPS
    assert shown["bar"] == (STEPS, STEPS)  # progress bar full for the last level
    assert shown["info"].harmonics[:2] == (0, 1)


def test_closing_the_window_stops_the_campaign(spy, tmp_path, capsys):
    campaign, out = stepped(tmp_path, "2.0"), tmp_path / "run.h5"
    spy.close_after_steps = 3
    assert main(["campaign", "run", str(campaign), "--out", str(out), "--live"]) == 130
    assert "interrupted" in capsys.readouterr().err
    run = open_run(out)
    assert run.status == "interrupted" and 3 <= sum(lv.n_segments for lv in run.levels) < 42
    assert main(["campaign", "run", str(campaign), "--out", str(out), "--resume"]) == 0
    assert [lv.n_segments for lv in open_run(out).levels] == [21, 21]
