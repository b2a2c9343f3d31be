"""CSV recordings as acquisition systems export them: preambles, units in the header,
semicolon or tab delimiters, decimal commas, no DOF in the column names."""

import numpy as np
import pytest

from analysis.errors import InputError
from nlid_lab import recordings_io as rio
from nlid_lab.cli import main
from nlid_lab.units import G0

FS, N = 1024.0, 512


@pytest.fixture
def channels():
    rng = np.random.default_rng(3)
    return np.arange(N) / FS, rng.normal(size=N), rng.normal(size=(N, 2))


def _rows(columns, fmt, delim, decimal_comma=False):
    out = []
    for row in zip(*columns):
        text = delim.join(fmt % v for v in row)
        out.append(text.replace(".", ",") if decimal_comma else text)
    return out


def test_semicolon_export_with_preamble_units_and_decimal_comma(tmp_path, channels):
    t, f, a = channels
    lines = ["Project: wing GVT", "Operator: A. Engineer", "Sample rate: 1024 Hz", "",
             "Time (s);Force (N);Acc tip [m/s^2];Acc payload [g]"]
    lines += _rows([t, f, a[:, 0], a[:, 1] / G0], "%.17g", ";", decimal_comma=True)
    (tmp_path / "run.csv").write_text("\n".join(lines) + "\n")
    rec = rio.read_csv(tmp_path / "run.csv", force_dofs=[0])
    assert rec.fs == pytest.approx(FS) and rec.response_kind == "acceleration"
    np.testing.assert_allclose(rec.force[:, 0], f, rtol=1e-12)
    np.testing.assert_allclose(rec.response, a, rtol=1e-12)
    assert rec.force_dofs.tolist() == [0] and rec.meta["channels"][1] == "Acc tip"


def test_tab_export_in_ms_kn_and_mm_through_the_cli(tmp_path, channels):
    t, f, a = channels
    lines = ["# force_dofs = 1", "Time [ms]\tF shaker [kN]\tx1 [mm]\tx2 [mm]"]
    lines += _rows([1e3 * t, f / 1e3, 1e3 * a[:, 0], 1e3 * a[:, 1]], "%.17g", "\t")
    (tmp_path / "run.csv").write_text("\n".join(lines) + "\n")
    assert main(["import", str(tmp_path / "run.csv"), "--out", str(tmp_path / "run.h5")]) == 0
    [rec] = rio.load_recordings(tmp_path / "run.h5")
    assert rec.response_kind == "displacement" and rec.force_dofs.tolist() == [1]
    np.testing.assert_allclose(rec.force[:, 0], f, rtol=1e-12)
    np.testing.assert_allclose(rec.response, a, rtol=1e-12)


@pytest.mark.parametrize("header, extra, words", [
    ("Time (s),Force (N),a1 [m/s^2],x2 [mm]", ["# force_dofs = 0"], "different quantities"),
    ("Time (s),Force (N),a1 [m/s^2],a2 [m/s^2]", [], "force_dofs = K"),
    ("Time (s),Force (N),a1 [furlong],a2 [m/s^2]", [], "unknown unit 'furlong'"),
    ("Time (s),Force (N),a1@0,a2 [m/s^2]", [], "of every channel"),
    ("Time (s),Force (N),a1 [m/s^2],a2 [m/s^2]", ["# force_dofs = 2"], "outside the response"),
    ("Time (s),Force (N),a1 [m/s^2],a2 [m/s^2]", ["# response_kind = \"velocity\"",
                                                 "# force_dofs = 0"], "column units say"),
])
def test_export_errors_name_the_column_or_key(tmp_path, channels, header, extra, words):
    t, f, a = channels
    lines = extra + [header] + _rows([t, f, a[:, 0], a[:, 1]], "%.10g", ",")
    (tmp_path / "bad.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as info:
        rio.read_csv(tmp_path / "bad.csv")
    assert words in str(info.value)
