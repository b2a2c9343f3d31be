"""Nonlinearity detection from data alone: level dependence of random FRFs, BLA distortion."""

import json
from pathlib import Path

import numpy as np
import pytest

from analysis.detection import detect
from analysis.errors import InputError
from analysis.plant import Plant, add_relative_noise, random_gaussian
from analysis.models import Model
from analysis.recordings import Recording
from nlid_lab.campaign import load_campaign, run_campaign
from nlid_lab.cli import main
from nlid_lab.formats import load_recordings
from nlid_lab.store import save_recording

FS = 1024.0
SDOF = Model.load("examples/models/sdof-cubic-quaddamp.toml")


def _levels(model, levels=(2.0, 20.0), noise=0.02, fs=FS, band=(5, 200), oversample=2):
    recs = []
    for k, level in enumerate(levels):
        f = random_gaussian(2**16, fs, band, level, seed=10 + k)[:, None]
        x = Plant(model, fs, [0], oversample=oversample).run(f).displacement
        recs.append(Recording(fs, "random", [0], f, add_relative_noise(x, noise, k + 1),
                              level=level, force_hold="linear"))
    return recs


def test_linear_structure_shows_no_level_dependence():
    """Linear part only, 2 % noise: about 1 % of the lines by chance (measured 0.9 %)."""
    result = detect(_levels(SDOF.with_elements([])))
    (t,) = result.tests
    assert result.verdict == "no evidence" and not t.nonlinear
    assert t.share_flagged < t.share_limit


def test_cubic_spring_makes_the_frf_level_dependent():
    """Measured: 42 % of the lines flagged, median change +3.8 dB over the noise."""
    result = detect(_levels(SDOF))
    (t,) = result.tests
    assert result.verdict == "nonlinear" and t.share_flagged > 0.2
    assert t.band_hz[0] < 50.3 < t.band_hz[1] and t.levels == (2.0, 20.0)


def test_three_dof_paper_system():
    """Paper 3.3.2 system at 1 and 8 N: measured 82 % of the lines (all three responses)."""
    model = Model.load("examples/models/three-dof-paper.toml")
    (t,) = detect(_levels(model, (1.0, 8.0), fs=2048.0, band=(5, 400), oversample=4)).tests
    assert t.nonlinear and min(t.by_output) > 0.5


def test_cli_detect(tmp_path, capsys):
    paths = []
    for rec in _levels(SDOF):
        paths.append(str(tmp_path / f"l{rec.level:g}.h5"))
        save_recording(paths[-1], rec)
    assert main(["detect", *paths, "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["verdict"] == "nonlinear"
    assert "NONLINEAR" in captured.err and "level dependence" in captured.err
    assert main(["detect", paths[0]]) == 2                 # one level: nothing to compare
    assert "no level to test" in capsys.readouterr().err
    assert main(["detect", *paths, "--nperseg", "0"]) == 2
    assert "nperseg" in capsys.readouterr().err


def test_detect_needs_something_to_test():
    with pytest.raises(InputError, match="no level to test"):
        detect(_levels(SDOF, levels=(5.0,)))


def test_stepped_sine_level_dependence(tmp_path):
    """Stepped-sine campaigns of the example at 2 and 8 N, fundamental FRFs compared against
    the error read off each block's halves: the linear part gives no evidence (measured 1 of
    21 steps, median -19 dB: the halves also see the block's settling drift, so the test is
    conservative), the cubic spring and quadratic damping flag every step."""
    root = Path(__file__).resolve().parents[3] / "examples"
    text = (root / "campaign-sim-stepped.toml").read_text()
    text = text.replace('model = "models/', f'model = "{root}/models/')
    lin = SDOF.with_elements([])
    lin.save(tmp_path / "linear.toml")
    verdicts = {}
    for name, model in (("linear", str(tmp_path / "linear.toml")), ("cubic", None)):
        path = tmp_path / f"campaign-{name}.toml"
        path.write_text(text if model is None else
                        text.replace(f'model = "{root}/models/sdof-cubic-quaddamp.toml"',
                                     f'model = "{model}"'))
        run_campaign(load_campaign(path), tmp_path / f"{name}.h5")
        (t,) = detect(load_recordings(tmp_path / f"{name}.h5")).tests
        assert t.method == "stepped-level-dependence"
        verdicts[name] = t
    assert not verdicts["linear"].nonlinear
    assert verdicts["cubic"].nonlinear and verdicts["cubic"].share_flagged > 0.8


def test_periodic_levels_of_one_realization_are_period_averaged():
    """Multisine levels as a GVT stores them (one realization of P periods each, levels in
    separate recordings): the period-averaged FRFs of the lowest and highest level are compared
    with their noise from the period spread; a cubic joint is flagged, the linear FE structure
    is not."""
    from analysis.plant import multisine, periodic
    from analysis.models import Element
    from analysis.recordings import PeriodicLayout
    from structures import beam_with_payload, gvt_recording
    beam = beam_with_payload()
    names = ["drive", "joint", "payload"]
    fs, n, up, p = 512.0, 1024, 4, 6
    w = np.zeros(beam.model.n_dof)
    w[beam.points["joint"]], w[beam.points["payload"]] = -1.0, 1.0
    joint = [Element("cubic_spring", w, {"p": 3e10})]

    def levels(elements):
        return [gvt_recording(beam, names, "drive",
                              periodic(multisine(n * up, fs * up, (2.0, 120.0), lev, seed=3),
                                       p + 1),
                              fs, up, layout=PeriodicLayout(n, 1, p, 1), level=lev,
                              elements=elements, seed=int(lev)) for lev in (0.5, 20.0)]

    linear = detect(levels(()))
    assert linear.verdict == "no evidence", linear.tests
    assert linear.tests[0].method == "level-dependence"
    assert detect(levels(joint)).verdict == "nonlinear"
