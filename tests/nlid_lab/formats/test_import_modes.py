"""FE modes from a universal file (dataset 55) into a [modal] model: the modes of the 21-DOF
beam with a payload written with pyuff (normal and complex modes, shapes not mass-normalised),
imported at four named points, compared with the FE model (nlid-lab import-modes)."""

import json

import numpy as np
import pyuff
import pytest
from scipy.linalg import eigh

from analysis.models import Model
from nlid_lab.cli import main
from nlid_lab.commands.import_modes import ModesImport
from structures import beam_with_payload

PAYLOAD_NODE = 100
POINTS = {"drive": "3:z", "joint": "7:z", "tip": "10:z", "payload": f"{PAYLOAD_NODE}:z"}
#: Largest relative rounding of a value written as %13.5e (six significant digits).
EPS = 5e-6


@pytest.fixture(scope="module")
def beam():
    return beam_with_payload()


def fe_modes(beam):
    """Undamped modes of the FE model, mass-normalised (columns), and their frequencies."""
    lam, vec = eigh(beam.model.stiffness, beam.model.mass)
    return np.sqrt(lam) / (2 * np.pi), vec


def node_values(vec_column):
    """Dataset 55 node values of one FE mode: beam nodes 1..10 (transverse z, rotation about
    y), the payload on its own node."""
    n_beam = (vec_column.size - 1) // 2
    z = np.r_[vec_column[0:2 * n_beam:2], vec_column[-1]]
    ry = np.r_[vec_column[1:2 * n_beam:2], 0.0]
    nodes = np.r_[np.arange(1, n_beam + 1), PAYLOAD_NODE]
    return nodes, z, ry


def write_normal_modes(path, beam, zeta=0.01, damping=True, modal_mass=True):
    """Normal modes (analysis type 2), 6 values per node, each shape scaled to unit peak with
    its modal mass (as FE codes export them)."""
    freqs, vec = fe_modes(beam)
    uff = pyuff.UFF(str(path))
    for r, f in enumerate(freqs):
        nodes, z, ry = node_values(vec[:, r])
        peak = np.abs(z).max()
        zero = np.zeros(nodes.size)
        d = pyuff.prepare_55(
            model_type=1, analysis_type=2, data_ch=3, spec_data_type=8, data_type=2,
            load_case=1, mode_n=r + 1, freq=f, modal_m=1 / peak ** 2 if modal_mass else 0.0,
            modal_damp_vis=zeta if damping else 0.0, modal_damp_his=0.0,
            node_nums=nodes, r1=zero, r2=zero, r3=z / peak, r4=zero, r5=ry / peak, r6=zero,
            return_full_dict=True)
        uff.write_sets(d, mode="add")
    return freqs


def write_complex_modes(path, beam, zeta=0.01):
    """Complex modes (analysis type 3) of the modally damped FE model, each shape turned by
    an arbitrary complex factor c, with its modal A = 2 i w_d c^2."""
    freqs, vec = fe_modes(beam)
    rng = np.random.default_rng(3)
    uff = pyuff.UFF(str(path))
    for r, f in enumerate(freqs):
        wn = 2 * np.pi * f
        lam = -zeta * wn + 1j * wn * np.sqrt(1 - zeta ** 2)
        nodes, z, _ = node_values(vec[:, r])
        c = rng.uniform(0.5, 2.0) * np.exp(1j * rng.uniform(-np.pi, np.pi)) / np.abs(z).max()
        zero = np.zeros(nodes.size, complex)
        d = pyuff.prepare_55(
            model_type=1, analysis_type=3, data_ch=2, spec_data_type=8, data_type=5,
            load_case=1, mode_n=r + 1, eig=lam, modal_a=2j * lam.imag * c ** 2, modal_b=0j,
            node_nums=nodes, r1=zero, r2=zero, r3=z * c)
        uff.write_sets(d, mode="add")
    return freqs


def fe_frf(beam, freqs):
    sensors = [beam.points[k] for k in POINTS]
    return beam.model.linear_frf(freqs, [beam.points["drive"]])[:, sensors, 0]


def rounding_bound(beam, freqs, eps_residue, eps_freq):
    """First-order bound of the receptance error (drive column at the four points) from
    relative errors ``eps_residue`` of each modal residue ``phi_i phi_j / m`` and
    ``eps_freq`` of each natural frequency and damping ratio (values rounded in the file)."""
    fn, vec = fe_modes(beam)
    sensors = [beam.points[k] for k in POINTS]
    w, wn = 2 * np.pi * freqs[:, None], 2 * np.pi * fn[None, :]
    den = wn ** 2 - w ** 2 + 2j * 0.01 * wn * w
    d_den = 2 * eps_freq * wn ** 2 + 2 * 0.01 * wn * w * (2 * eps_freq)
    res = np.abs(vec[sensors] * vec[beam.points["drive"]])          # (4, n_modes)
    term = res[None] / np.abs(den)[:, None, :]
    return np.sum(term * (eps_residue + d_den[:, None, :] / np.abs(den)[:, None, :]), axis=2)


def import_cli(tmp_path, uff_path, *extra):
    out = tmp_path / "modes.toml"
    js = tmp_path / "modes.json"
    points = [f"{k}={v}" for k, v in POINTS.items()]
    code = main(["import-modes", str(uff_path), "--out", str(out), "--points", *points,
                 "--json", str(js), *extra])
    assert code == 0
    data = json.loads(js.read_text())
    assert data["schema_version"] == 1                     # and it reads back as written
    assert ModesImport.from_json(data).to_json() == data
    return Model.load(out), data


def test_normal_modes_with_modal_mass_give_the_fe_frfs(tmp_path, beam):
    path = tmp_path / "fe.uff"
    fn = write_normal_modes(path, beam)
    model, summary = import_cli(tmp_path, path)
    assert model.points == list(POINTS)
    assert summary["normalisation"] == "modal mass"
    np.testing.assert_allclose(model.natural_frequencies(), fn, rtol=EPS)
    np.testing.assert_allclose([m["damping_ratio"] for m in summary["modes"]], 0.01, rtol=EPS)
    freqs = np.linspace(1.0, 400.0, 4000)
    err = np.abs(model.linear_frf(freqs, [model.point_index("drive")])[:, :, 0]
                 - fe_frf(beam, freqs))
    # residue phi_i phi_j / m: two shape values and the modal mass, each rounded
    bound = rounding_bound(beam, freqs, eps_residue=3 * EPS, eps_freq=EPS)
    assert np.all(err <= bound)
    assert err.max() > 0                                   # the file really was rounded


def test_complex_modes_with_modal_a_give_the_fe_frfs(tmp_path, beam):
    path = tmp_path / "fe.uff"
    fn = write_complex_modes(path, beam)
    model, summary = import_cli(tmp_path, path)
    assert summary["normalisation"] == "modal A"
    # eigenvalue parts rounded to 6 digits: |lambda| and -Re/|lambda| within 2 eps
    np.testing.assert_allclose(model.natural_frequencies(), fn, rtol=2 * EPS)
    np.testing.assert_allclose([m["damping_ratio"] for m in summary["modes"]], 0.01,
                               rtol=2 * EPS)
    assert max(m["complexity"] for m in summary["modes"]) < 10 * EPS   # proportional damping
    freqs = np.linspace(1.0, 400.0, 4000)
    err = np.abs(model.linear_frf(freqs, [model.point_index("drive")])[:, :, 0]
                 - fe_frf(beam, freqs))
    # residue phi_i phi_j 2 i w_d / a: two complex shape values (sqrt 2 eps each), the two
    # parts of modal A (sqrt 2 eps) and w_d (2 eps)
    bound = rounding_bound(beam, freqs, eps_residue=(3 * np.sqrt(2) + 2) * EPS,
                           eps_freq=2 * EPS)
    assert np.all(err <= bound)


def test_band_selects_modes_and_damping_fills_the_gaps(tmp_path, beam, capsys):
    path = tmp_path / "fe.uff"
    fn = write_normal_modes(path, beam, damping=False, modal_mass=False)
    out = tmp_path / "m.toml"
    assert main(["import-modes", str(path), "--out", str(out), "--points", "7:z",
                 "tip=10:-z", "--band", "3", "200"]) == 2
    assert "--damping" in capsys.readouterr().err
    assert main(["import-modes", str(path), "--out", str(out), "--points", "7:z",
                 "tip=10:-z", "--band", "3", "200", "--damping", "0.02"]) == 0
    text = capsys.readouterr().out
    assert "shapes taken as mass-normalised" in text and "--damping 0.02" in text
    model = Model.load(out)
    inband = fn[(fn >= 3) & (fn <= 200)]
    assert model.points == ["7:z", "tip"] and model.n_q == inband.size == 4
    np.testing.assert_allclose(model.natural_frequencies(), inband, rtol=EPS)
    np.testing.assert_allclose(np.diag(model.damping) / (2 * np.sqrt(np.diag(model.stiffness))),
                               0.02, rtol=1e-12)
    # unit-peak shapes as written (no modal mass), the tip's sign flipped
    freqs, vec = fe_modes(beam)
    r = np.flatnonzero((freqs >= 3) & (freqs <= 200))
    peak = np.abs(vec[0:20:2][:, r]).max(axis=0)
    peak = np.maximum(peak, np.abs(vec[-1, r]))
    np.testing.assert_allclose(model.shapes[1], -vec[beam.points["tip"], r] / peak,
                               rtol=EPS, atol=EPS)


def test_default_points_are_every_moving_translation(tmp_path, beam):
    path = tmp_path / "fe.uff"
    write_normal_modes(path, beam)
    out = tmp_path / "m.toml"
    assert main(["import-modes", str(path), "--out", str(out)]) == 0
    model = Model.load(out)
    assert model.points == [f"{n}:z" for n in range(1, 11)] + [f"{PAYLOAD_NODE}:z"]


@pytest.mark.parametrize("content, extra, message", [
    ("not a universal file\n", [], "no mode shapes"),
    ("truncated", [], "not closed by a -1 line"),
    (None, ["--points", "tip=99:z"], "node 99 is not in the file"),
    (None, ["--points", "tip=10:q"], "NODE:DIR"),
    (None, ["--points", "a=10:z", "a=7:z"], "given twice"),
    (None, ["--band", "500", "600"], "no mode in it"),
    (None, ["--load-case", "4"], "--load-case 4"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, beam, capsys, content, extra, message):
    path = tmp_path / "fe.uff"
    if content in (None, "truncated"):
        write_normal_modes(path, beam)
        if content:
            text = path.read_text()
            path.write_text(text[:len(text) // 2])
    else:
        path.write_text(content)
    code = main(["import-modes", str(path), "--out", str(tmp_path / "m.toml"), *extra])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "m.toml").exists()


def test_no_overwrite_without_force(tmp_path, beam, capsys):
    path = tmp_path / "fe.uff"
    write_normal_modes(path, beam)
    out = tmp_path / "m.toml"
    out.write_text("keep me")
    assert main(["import-modes", str(path), "--out", str(out)]) == 2
    assert out.read_text() == "keep me" and "--force" in capsys.readouterr().err
    assert main(["import-modes", str(path), "--out", str(out), "--force"]) == 0
    assert Model.load(out).n_q == 21
