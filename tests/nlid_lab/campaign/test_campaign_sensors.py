"""Campaign `[sensors]`: a few channels at named model points, each in its kind, on sim://."""

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from analysis.recordings import SensorMap
from nlid_lab.campaign import CampaignError, load_plant_model, parse_campaign, run_campaign
from nlid_lab.cli import main
from nlid_lab.store import open_run

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
EXAMPLE = EXAMPLES / "campaign-sim-sensors.toml"
BASE = tomllib.loads(EXAMPLE.read_text())
POINTS = ["root", "n2", "drive", "n4", "n5", "n6", "joint", "n8", "n9", "tip", "payload"]


def short(data: dict) -> dict:
    """``data`` with a short plan and a noise-free plant (samples comparable exactly)."""
    data = copy.deepcopy(data)
    data["random"].update(levels=[5.0], averages=2, block_size=1024)
    data["plant"]["noise_std"] = 0.0
    return data


def every_point(kind: str) -> dict:
    """The example measured the old way: one [[channel]] per model point, all in ``kind``."""
    data = short(BASE)
    del data["sensors"], data["safety"]
    data["daq"]["response_kind"] = kind
    data["channel"] = [{"name": "F", "quantity": "force", "dof": POINTS.index("drive")}] + [
        {"name": p, "quantity": kind, "dof": j} for j, p in enumerate(POINTS)]
    return data


def test_sensors_table_gives_channels_at_points():
    c = parse_campaign(BASE, EXAMPLES)
    assert c.sensors == SensorMap(("drive", "joint", "payload"), ("acceleration",) * 3,
                                  ("drive",))
    assert [(ch.name, ch.quantity, ch.dof) for ch in c.channels] == [
        ("force@drive", "force", 0), ("drive", "acceleration", 0),
        ("joint", "acceleration", 1), ("payload", "acceleration", 2)]
    assert c.n_dof == 3 and c.force_dof == 0 and c.response_kind == "acceleration"
    model = load_plant_model(c)
    assert [ch.dof for ch in c.daq_channels(model)] == [2, 2, 6, 10]   # the model's points


def test_sim_run_records_only_the_mapped_channels_in_their_kinds(tmp_path):
    """The sensor run's channels are, sample for sample, the all-point runs' columns of the
    same points in the same kinds (same drive, same level control, noise-free plant)."""
    full = {}
    for kind in ("acceleration", "displacement"):
        run_campaign(parse_campaign(every_point(kind), EXAMPLES), tmp_path / f"{kind}.h5")
        full[kind] = open_run(tmp_path / f"{kind}.h5").recordings()[0]
    data = short(BASE)
    data["sensors"] = {"response_points": ["payload", "drive", "joint"],
                       "response_kinds": ["acceleration", "acceleration", "displacement"],
                       "force_points": ["drive"]}
    result = run_campaign(parse_campaign(data, EXAMPLES), tmp_path / "sensors.h5")
    assert result.status == "complete"
    run = open_run(tmp_path / "sensors.h5")
    rec = run.recordings()[0]
    assert run.sensors == SensorMap(("payload", "drive", "joint"),
                                    ("acceleration", "acceleration", "displacement"),
                                    ("drive",))
    assert rec.sensors == run.sensors and rec.response_kind == "mixed"
    assert rec.n_dof == 3 and rec.force_dofs.tolist() == [1]   # force at channel 'drive'
    acc, disp = full["acceleration"].response, full["displacement"].response
    np.testing.assert_array_equal(rec.force, full["acceleration"].force)
    np.testing.assert_allclose(rec.response[:, :2], acc[:, [10, 2]], rtol=0, atol=1e-12
                               * np.abs(acc).max())
    np.testing.assert_allclose(rec.response[:, 2], disp[:, 6], rtol=0, atol=1e-12
                               * np.abs(disp).max())
    assert np.std(rec.response[:, 2]) > 0
    table = [(c["name"], c["kind"]) for c in run.channels]
    assert table == [("force@drive", "force"), ("payload", "response"),
                     ("drive", "response"), ("joint", "response")]


def test_without_sensors_the_run_has_no_map(tmp_path):
    run_campaign(parse_campaign(every_point("acceleration"), EXAMPLES), tmp_path / "a.h5")
    assert open_run(tmp_path / "a.h5").sensors is None


@pytest.mark.parametrize("change,match", [
    (lambda d: d.update(channel=[{"name": "F", "quantity": "force", "dof": 0}]),
     r"\[sensors\] or \[\[channel\]\] tables, not both"),
    (lambda d: d["sensors"].pop("force_points"), "needs force_points"),
    (lambda d: d["sensors"].pop("response_points"), "needs response_points"),
    (lambda d: d["sensors"].update(force_points=["drive", "joint"]), "one point the shaker"),
    (lambda d: d["sensors"].update(force_points=["tip"]), "no response channel measures 'tip'"),
    (lambda d: d["sensors"].update(response_kinds=["jerk"] * 3), "'jerk' is not one of"),
    (lambda d: d["sensors"].update(response_kinds=["acceleration"]), "names 1 channel"),
    (lambda d: d["sensors"].update(points=["x"]), "not points"),
    (lambda d: d["sensors"].update(response_points="drive"), "must be a list of names"),
    (lambda d: d["sensors"].update(response_points=["drive", "drive", "joint"]),
     "measured by two channels"),
    (lambda d: d["daq"].update(response_kind="displacement"), "response_kind = displacement"),
    (lambda d: d["safety"].update(limits={"tip": 1.0}),
     r"unknown channel 'tip' \(channels: force@drive, drive, joint, payload\)"),
])
def test_sensors_validation_names_the_problem(change, match):
    data = copy.deepcopy(BASE)
    change(data)
    with pytest.raises(CampaignError, match=match):
        parse_campaign(data, EXAMPLES)


def test_a_point_the_model_lacks_is_named():
    data = copy.deepcopy(BASE)
    data["sensors"]["response_points"] = ["drive", "joint", "wingtip"]
    del data["safety"]
    with pytest.raises(CampaignError, match="point 'wingtip' is not in the model"):
        load_plant_model(parse_campaign(data, EXAMPLES))


@pytest.mark.parametrize("urls", [("serial-emu://", "serial-emu://"),
                                  ("serial-emu://", "can-emu://virtual/x"),
                                  ("serial:///dev/ttyUSB0", "serial:///dev/ttyUSB1")])
def test_serial_and_can_refuse_sensors_in_one_line(tmp_path, capsys, urls):
    shaker, daq = (f'[shaker]\nurl = "{urls[0]}"', f'[daq]\nurl = "{urls[1]}"')
    text = EXAMPLE.read_text().replace('[shaker]\nurl = "sim://"', shaker) \
        .replace('[daq]\nurl = "sim://"', daq)
    data = tomllib.loads(text)
    assert (data["shaker"]["url"], data["daq"]["url"]) == urls
    path = tmp_path / "c.toml"
    path.write_text(text)
    assert main(["campaign", "check", str(path)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "compiling" not in line]
    assert len(err) == 1 and "[sensors] needs the sim:// backend" in err[0]


@pytest.mark.slow
def test_example_runs_end_to_end_through_fit_linear_and_diagnose(tmp_path, capsys):
    """The example as documented: campaign run, fit-linear of the lowest level (the in-band
    modes of the 6-mode model it simulates), diagnose with the fitted model (accepted)."""
    import json

    from analysis.models import Model
    run, fitted = tmp_path / "sim-sensors.h5", tmp_path / "fitted.toml"
    assert main(["campaign", "run", str(EXAMPLE), "--out", str(run), "--quiet"]) == 0
    assert main(["fit-linear", str(run), "--band", "3", "100", "--out", str(fitted),
                 "--json", str(tmp_path / "fit.json"), "--quiet"]) == 0
    fit = json.loads((tmp_path / "fit.json").read_text())
    assert fit["points"] == ["drive", "joint", "payload"] and fit["level"] == 2.0
    true = Model.load(EXAMPLES / "models" / "beam-payload-modal.toml")
    in_band = [f for f in true.natural_frequencies() if 3 < f < 100]
    found = sorted(m["freq_hz"] for m in fit["modes"])
    assert len(found) == len(in_band)
    # Welch at 0.25 Hz lines on a 1 %-damped 6.6 Hz mode: within a line of the truth
    assert all(abs(f - t) < 0.25 for f, t in zip(found, in_band))
    assert main(["diagnose", str(fitted), str(run), "--band", "3", "100",
                 "--json", str(tmp_path / "d.json"), "--quiet"]) == 0
    assert json.loads((tmp_path / "d.json").read_text())["verdict"]


def test_the_true_model_is_adequate_over_the_automatic_band(tmp_path):
    """Three accelerometers of 11 points: diagnosed with the model it was simulated from, over
    the band chosen from the force, every level lies within its floor (before the integration
    high-pass followed the residual force below the drive band, 0.5 Hz, and the true model
    misfit 20 N by 19x its floor)."""
    import json

    run, out = tmp_path / "sim-sensors.h5", tmp_path / "d.json"
    assert main(["campaign", "run", str(EXAMPLE), "--out", str(run), "--quiet"]) == 0
    assert main(["diagnose", str(EXAMPLES / "models" / "beam-payload-modal.toml"), str(run),
                 "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert d["evidence"]["band_hz"][0] >= 3.0
    assert d["verdict"] == "adequate"
    assert all(lv["before"] <= lv["floor"] for lv in d["fit"]["levels"])


def test_one_level_control_loop_for_every_measure():
    """`_Runner.control` (random rms and swept-sine amplitude alike): per try the settle
    blocks, one measured block, a drive step limited to x4 and max_drive; a warning naming the
    measure after the last try; the last block returned only when measured at the final
    drive."""
    from types import SimpleNamespace

    from nlid_lab.campaign._campaign import _Runner

    class Plant:                   # force = 3 N/V x drive; the block's value is the force
        def __init__(self):
            self.drive, self.levels, self.taken = 0.5, [], 0

        def set_level(self, drive):
            self.drive = drive
            self.levels.append(drive)

        def take(self, n):
            self.taken += 1
            return np.full((n, 1), 3.0 * self.drive), float(self.taken)

    plant = Plant()
    runner = object.__new__(_Runner)
    runner.c = SimpleNamespace(max_drive=10.0)
    runner.bench = SimpleNamespace(shaker=plant)
    runner.take, runner.gain, runner.level, runner.warnings = plant.take, 1.0, 3, []
    drive, data, t0 = runner.control(6.0, 0.5, lambda d: float(d[0, 0]), "force rms", 8, 2,
                                     0.05, 6)
    assert drive == pytest.approx(2.0) and plant.levels == [pytest.approx(2.0)]
    assert runner.gain == pytest.approx(3.0) and plant.taken == 6 and t0 == 6.0
    assert data[0, 0] == pytest.approx(6.0) and runner.warnings == []
    # a target out of reach: x4 per step, then max_drive; the block measured before the
    # last correction is not returned
    plant.levels = []
    drive, data, _ = runner.control(1e3, 2.0, lambda d: float(d[0, 0]), "force amplitude", 8,
                                    1, 0.02, 3, " at 40 Hz")
    assert plant.levels == [8.0, 10.0, 10.0] and drive == 10.0 and data is None
    assert runner.warnings == ["level 3: force amplitude not within 2% of 1000.0 N at 40 Hz "
                               "after 3 tries"]
