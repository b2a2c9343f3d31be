"""UFF58 export: FRF and coherence datasets written with pyuff and read back unchanged."""

import numpy as np
import pytest

from analysis.models import Model
from analysis.recordings import Recording
from nlid_lab.reports import _uff as uff
from nlid_lab.cli import main
from nlid_lab.formats import write_npz
from analysis.spectral import level_frf

MODEL = Model.load("examples/models/three-dof-paper.toml")
FS = 2048.0


def periodic_random(n: int = 2**15, rms: float = 5.0, noise: float = 0.0, seed: int = 0
                    ) -> Recording:
    """Linear response of the paper's 3-DOF chain (elements off) to periodic random force,
    computed exactly in the frequency domain; ``noise`` is relative sensor noise."""
    rng = np.random.default_rng(seed)
    f = rng.standard_normal((n, 1)) * rms
    X = np.einsum("fij,fj->fi", MODEL.linear_frf(np.fft.rfftfreq(n, 1 / FS), [0]),
                  np.fft.rfft(f, axis=0))
    x = np.fft.irfft(X, n, axis=0)
    x += noise * x.std(axis=0) * rng.standard_normal(x.shape)
    return Recording(FS, "random", [0], f, x, level=rms)


def stepped(n_steps: int = 12) -> Recording:
    freqs = np.linspace(50.0, 95.0, n_steps)
    t = np.arange(1500) / FS
    H = MODEL.linear_frf(freqs, [0])[:, :, 0]
    force = 8.0 * np.cos(2 * np.pi * freqs[:, None] * t)[:, :, None]
    resp = np.real(8.0 * H[:, None, :] * np.exp(2j * np.pi * freqs[:, None, None] * t[:, None]))
    return Recording(FS, "stepped-sine", [0], force, resp, freqs=freqs, level=8.0)


def test_h1_matches_model_within_random_error():
    rec = periodic_random(noise=0.02)
    frf = level_frf(rec)
    true = MODEL.linear_frf(frf.freqs, [0])
    gamma2 = frf.multiple_coherence
    # Bendat & Piersol: normalised random error of |H1| is sqrt(1-g2)/(|g| sqrt(2 n_d))
    eps = np.sqrt(1 - gamma2) / np.sqrt(gamma2 * 2 * frf.n_averages)
    ok = gamma2 > 0.9
    err = np.abs(np.abs(frf.H[:, :, 0]) - np.abs(true[:, :, 0])) / np.abs(true[:, :, 0])
    modes = (frf.freqs > 20) & (frf.freqs < 350)     # where the responses stand above noise
    assert ok[modes].mean() > 0.9
    # 4 sigma per bin plus a leakage allowance for the Hann window at 2048/nperseg Hz bins
    assert np.mean(err[ok] < 4 * eps[ok] + 0.01) > 0.99


def test_round_trip_random(tmp_path):
    frf = level_frf(periodic_random())
    sets = uff.datasets([frf, frf], "run-a")
    path = tmp_path / "frf.uff"
    uff.write_uff(path, sets)
    back = uff.read_uff(path)
    assert len(back) == len(sets) == 2 * 2 * 3         # 2 levels x (FRF + coh) x 3 outputs
    for s, b in zip(sets, back):
        assert b["func_type"] == s["func_type"]
        assert (b["rsp_node"], b["ref_node"], b["load_case_id"]) == \
            (s["rsp_node"], s["ref_node"], s["load_case_id"])
        np.testing.assert_allclose(b["x"], s["x"], rtol=1e-12)
        # pyuff writes %20.11e: 12 significant digits per real and imaginary part
        np.testing.assert_allclose(b["data"], s["data"], rtol=1e-10,
                                   atol=1e-10 * np.abs(s["data"]).max())
    frf_sets = [b for b in back if b["func_type"] == uff.FUNC_FRF]
    assert all(np.iscomplexobj(b["data"]) for b in frf_sets)
    assert frf_sets[0]["ordinate_axis_units_lab"] == "m"
    assert frf_sets[0]["orddenom_axis_units_lab"] == "N"
    assert frf_sets[0]["abscissa_spacing"] == 1        # 0.5 Hz steps survive the header


def test_round_trip_stepped_uneven(tmp_path):
    rec = stepped()
    frf = level_frf(rec)
    np.testing.assert_allclose(frf.H[:, :, 0], MODEL.linear_frf(rec.freqs, [0])[:, :, 0],
                               rtol=1e-9)
    sets = uff.datasets([frf], "run-b")
    assert {s["func_type"] for s in sets} == {uff.FUNC_FRF}    # no coherence for sine
    uff.write_uff(tmp_path / "s.uff", sets)
    back = uff.read_uff(tmp_path / "s.uff")
    for s, b in zip(sets, back):
        assert b["abscissa_spacing"] == 0
        np.testing.assert_allclose(b["x"], s["x"], rtol=1e-5)   # 6-digit abscissa field
        np.testing.assert_allclose(b["data"], s["data"], rtol=1e-10)


def test_export_uff_command(tmp_path, capsys):
    npz = tmp_path / "rec.npz"
    write_npz(npz, periodic_random(n=2**13))
    out = tmp_path / "out.uff"
    assert main(["export-uff", str(npz), "--out", str(out), "--json", "-"]) == 0
    assert '"frf": 3' in capsys.readouterr().out
    assert len(uff.read_uff(out)) == 6


@pytest.mark.parametrize("args", [["missing.h5"], ["missing.npz"]])
def test_export_uff_bad_input(tmp_path, args, capsys):
    assert main(["export-uff", str(tmp_path / args[0]), "--out", str(tmp_path / "x.uff")]) == 2
    assert "error" in capsys.readouterr().err
