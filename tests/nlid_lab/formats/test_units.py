"""FRF axes carry the unit of the data drawn: receptance m/N, mobility (m/s)/N, accelerance
(m/s²)/N; runs of different response kinds in one viewer are converted to one kind."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyqtgraph")
pytest.importorskip("pytestqt")

from analysis.models import Element, Model  # noqa: E402
from analysis.plant import simulate  # noqa: E402
from analysis.recordings import Recording  # noqa: E402
from nlid_lab import store  # noqa: E402
from nlid_lab.gui._offline import OfflineView  # noqa: E402
from analysis.spectral import convert_frf  # noqa: E402
from nlid_lab.methods._reverse_path import report_sections  # noqa: E402
from nlid_lab.reports import all_level_frfs, load_run  # noqa: E402

SDOF = Path(__file__).resolve().parents[3] / "examples" / "models" / "sdof-cubic-quaddamp.toml"
FS = 512.0


def _run(path: Path, kind: str) -> Path:
    """The SDOF model under one random drive (the same for every kind), noise-free."""
    model = Model.load(SDOF)
    force = 2.0 * np.random.default_rng(0).normal(size=(32768, 1))
    x = simulate(model, force, FS, [0], response_kind=kind)
    store.save_recording(path, Recording(fs=FS, excitation="random", force_dofs=[0],
                                         force=force, response=x, response_kind=kind,
                                         level=2.0), model_toml=SDOF.read_text())
    return path


def test_convert_frf_is_i_omega_per_derivative():
    f = np.array([1.0, 10.0])
    H = np.array([[2.0 + 1j], [0.5 - 1j]])
    iw = 2j * np.pi * f[:, None]
    np.testing.assert_allclose(convert_frf(H, f, "displacement", "acceleration"), H * iw ** 2)
    np.testing.assert_allclose(convert_frf(H, f, "acceleration", "velocity"), H / iw)
    np.testing.assert_array_equal(convert_frf(H, f, "velocity", "velocity"), H)


@pytest.mark.parametrize("first, unit", [("displacement", "Receptance |X/F| [m/N]"),
                                         ("acceleration", "Accelerance |A/F| [(m/s²)/N]")])
def test_viewer_shows_mixed_kinds_in_the_first_runs_kind(qtbot, tmp_path, first, unit):
    other = "acceleration" if first == "displacement" else "displacement"
    runs = [load_run(_run(tmp_path / f"{k}.h5", k)) for k in (first, other)]
    view = OfflineView(runs, [all_level_frfs(r) for r in runs])
    qtbot.addWidget(view)
    assert view.mag.getAxis("left").labelText == unit
    (fa, ya), (fb, yb) = (item.getData() for item in view.mag.listDataItems())
    names = [item.name() for item in view.mag.listDataItems()]
    assert "converted" not in names[0] and f"({other} converted)" in names[1]
    # the same plant and drive: after conversion the two estimates are one FRF around the
    # resonance (the magnitude axis is logarithmic: the items hold log10 |H|; frequency is
    # linear)
    np.testing.assert_array_equal(fa, fb)
    fn = float(Model.load(SDOF).natural_frequencies()[0])
    near = (fa > 0.7 * fn) & (fa < 1.3 * fn)
    assert np.median(np.abs(10 ** (yb - ya) - 1)[near]) < 1e-3    # 1e-4 measured


def test_report_labels_the_underlying_linear_frf_of_an_acceleration_run_as_receptance(
        tmp_path):
    run = load_run(_run(tmp_path / "acc.h5", "acceleration"))
    model = Model.load(SDOF)
    candidate = model.with_elements([Element(e.kind, e.w.copy(), {}) for e in model.elements])
    [section] = report_sections(run, [], None, candidate)
    fig = section.figures[0][1]
    assert fig.axes[0].get_ylabel() == "|H_L| [m/N]"
    # and the values drawn are receptances: the model's own, near resonance
    line = fig.axes[0].get_lines()[0]
    f, mag = line.get_xdata(), line.get_ydata()
    fn = float(model.natural_frequencies()[0])
    near = (f > 0.8 * fn) & (f < 1.2 * fn)
    H_model = np.abs(model.linear_frf(f[near], [0])[:, 0, 0])
    assert np.median(np.abs(mag[near] / H_model - 1)) < 0.05
