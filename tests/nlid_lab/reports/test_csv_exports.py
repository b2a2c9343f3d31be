"""CSV recordings as acquisition systems export them: preambles, units in the header,
semicolon or tab delimiters, decimal commas, no DOF in the column names."""

import numpy as np
import pytest

from analysis.errors import InputError
from nlid_lab import formats as rio
from nlid_lab.formats import G0
from nlid_lab.cli import main

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


def test_columns_of_different_kinds_are_a_sensor_map(tmp_path, channels):
    """Units naming different quantities give each channel its own kind (a sensor map)."""
    t, f, a = channels
    lines = ["# force_dofs = 0", "Time (s),Force (N),a1 [m/s^2],x2 [mm]"]
    lines += _rows([t, f, a[:, 0], 1e3 * a[:, 1]], "%.17g", ",")
    (tmp_path / "mixed.csv").write_text("\n".join(lines) + "\n")
    rec = rio.read_csv(tmp_path / "mixed.csv")
    assert rec.sensors.response_kinds == ("acceleration", "displacement")
    np.testing.assert_allclose(rec.response, a, rtol=1e-12)


def _f16_csv(path, force, voltage, acc):
    """A CSV laid out like the F-16 GVT exports: no time column, no units, no sample rate."""
    lines = ["Force,Voltage,Acceleration1,Acceleration2,Acceleration3"]
    lines += _rows([force, voltage, *acc.T], "%.17g", ",")
    path.write_text("\n".join(lines) + "\n")


def test_export_without_time_column_through_the_channel_map(tmp_path, channels):
    """The map picks the force and the accelerations (a unit after a list applies to every
    name in it), the voltage stays out of the responses, fs and the layout come from the map."""
    _, f, a = channels
    acc = np.column_stack([a, a[:, 0] - a[:, 1]])
    _f16_csv(tmp_path / "L1.csv", f, 0.1 * f, acc / G0)
    out = tmp_path / "run.h5"
    assert main(["import", str(tmp_path / "L1.csv"), "--out", str(out), "--map", "force=Force",
                 "response=Acceleration1,Acceleration2,Acceleration3:g", "fs=400",
                 "force_dofs=0", "period=128", "transient_periods=1"]) == 0
    [rec] = rio.load_recordings(out)
    assert rec.fs == 400 and rec.response_kind == "acceleration" and rec.n_dof == 3
    np.testing.assert_allclose(rec.force[:, 0], f, rtol=1e-12)
    np.testing.assert_allclose(rec.response, acc, rtol=1e-12)
    assert (rec.layout.period, rec.layout.transient_periods, rec.layout.periods) == (128, 1, 3)


def test_export_without_time_column_needs_a_sample_rate(tmp_path, channels, capsys):
    _, f, a = channels
    _f16_csv(tmp_path / "L1.csv", f, f, np.column_stack([a, a[:, 0]]))
    assert main(["import", str(tmp_path / "L1.csv"), "--out", str(tmp_path / "run.h5"),
                 "--map", "force=Force", "response=Acceleration1", "force_dofs=0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no sample rate; add fs=RATE" in err[0]
    assert not (tmp_path / "run.h5").exists()
