"""``nlid-lab predict``: forced-response curves through folds, from the command line."""

import json

import numpy as np
import pytest

from nlid_lab.cli import main

DUFFING = """name = "duffing"
[linear]
mass = [[2.0]]
damping = [[10.0]]
stiffness = [[2e5]]
[[element]]
kind = "cubic_spring"
w = [1.0]
p = 6e10
"""


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "duffing.toml"
    path.write_text(DUFFING)
    return path


def test_predict_curves_fold_only_at_high_level(model, tmp_path, capsys):
    out = tmp_path / "curves.json"
    assert main(["predict", str(model), "--amplitude", "1", "5", "--band", "40", "80",
                 "--json", str(out)]) == 0
    curves = json.loads(out.read_text())["curves"]
    low, high = curves
    assert low["folds"] == [] and all(low["stable"]) and low["complete"]
    assert len(high["folds"]) == 2 and high["complete"]
    f_up, f_lo = (f["freq"] for f in high["folds"])
    # the cubic backbone at the upper fold: f = f0 sqrt(1 + 3/4 p A^2 / k)
    a = high["folds"][0]["amplitude"]["0"]
    f0 = np.sqrt(2e5 / 2.0) / (2 * np.pi)
    assert f_up == pytest.approx(f0 * np.sqrt(1 + 0.75 * 6e10 * a ** 2 / 2e5), rel=0.01)
    assert f_lo < f_up
    stable = np.array(high["stable"])
    assert not stable.all() and stable[0] and stable[-1]
    assert "folds at" in capsys.readouterr().out


def test_predict_plot_draws_unstable_dashed(model, tmp_path):
    from matplotlib.image import imread

    from analysis.hbm import response_curves
    from analysis.hbm import HBMSystem
    from analysis.models import Model
    from nlid_lab.reports import response_curves as figure

    m = Model.load(model)
    branches = response_curves(HBMSystem(m, [0], (1, 3)), 40.0, 80.0, [5.0, 1.0])
    fig = figure(branches, [5.0, 1.0], 0, m.name, (40.0, 80.0))
    ax = fig.axes[0]
    assert ax.get_xlabel() == "Frequency [Hz]" and "[m]" in ax.get_ylabel()
    assert ax.get_yscale() == "log" and ax.get_xlim() == (40.0, 80.0)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["5 N", "1 N", "unstable", "fold (jump)"]
    dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"
              and np.isfinite(ln.get_ydata()).any()]
    assert len(dashed) == 1          # only the 5 N curve has an unstable part
    png = tmp_path / "curves.png"
    assert main(["predict", str(model), "--amplitude", "5", "--band", "40", "80",
                 "--plot", str(png)]) == 0
    assert imread(png).shape[0] > 100


@pytest.mark.parametrize("args, words", [
    (["--amplitude", "-1", "--band", "40", "80"], "positive"),
    (["--amplitude", "1", "--band", "40", "40"], "--band"),
    (["--amplitude", "1", "--band", "40", "80", "--force-dof", "3"], "DOF 3"),
    (["--amplitude", "1", "--band", "40", "80", "--plot", "x.svg"], "PNG"),
])
def test_predict_bad_input_is_one_line(model, capsys, args, words):
    assert main(["predict", str(model), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and words in err
