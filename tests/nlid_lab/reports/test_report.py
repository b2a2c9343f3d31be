"""Reports: sections appear when their data exist, figures are real images, HTML links them."""

from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from analysis.hbm import HBMSystem
from analysis.models import Model
from analysis.plant import Plant
from nlid_lab import store
from nlid_lab.cli import main
from analysis.spectral import level_frf
from nlid_lab import methods
from nlid_lab.reports import load_run, write_report

QUAD = Path("examples/models/sdof-cubic-quaddamp.toml")
STICK = Path("examples/models/sdof-stick-slip.toml")


def random_run(path: Path, levels=(0.5, 20.0), seconds: float = 24.0, fs: float = 1024.0):
    """Two random levels of the paper's SDOF cubic + quadratic-damping system (plant)."""
    model = Model.load(QUAD)
    rng = np.random.default_rng(3)
    n = int(seconds * fs)
    with store.RunWriter(path, fs=fs, excitation="random", force_dofs=[0], n_dof=1,
                         model_toml=QUAD.read_text(), mode="overwrite") as run:
        for i, rms in enumerate(levels):
            f = rng.standard_normal((n, 1))
            spec = np.fft.rfft(f, axis=0)
            spec[np.fft.rfftfreq(n, 1 / fs) > 200] = 0          # 0-200 Hz band
            f = np.fft.irfft(spec, n, axis=0)
            f *= rms / f.std()
            lv = run.level(i, rms)
            lv.append_block(f, Plant(model, fs, [0]).run(f).response)
            lv.complete()
    return path


def stepped_run(path: Path, amps=(50.0, 400.0), fs: float = 2048.0):
    """Stepped-sine levels of the stick-slip system synthesised from harmonic balance."""
    model = Model.load(STICK)
    freqs = np.linspace(60.0, 140.0, 17)
    t = np.arange(1024) / fs
    with store.RunWriter(path, fs=fs, excitation="stepped-sine", force_dofs=[0], n_dof=1,
                         model_toml=STICK.read_text(), mode="overwrite") as run:
        for i, amp in enumerate(amps):
            res = HBMSystem(model, harmonics=(1, 3, 5)).sweep(freqs, [amp])
            lv = run.level(i, amp)
            for k, f in enumerate(freqs):
                ph = np.exp(1j * 2 * np.pi * np.outer(t, f * res.harmonics))
                x = np.real(ph @ res.X[k])
                lv.append_step(f, amp * np.cos(2 * np.pi * f * t)[:, None], x, amplitude=amp)
            lv.complete()
    return path


def assert_real_image(path: Path) -> None:
    img = mpimg.imread(path)
    assert img.shape[0] > 200 and img.shape[1] > 300
    rgb = img[..., :3]
    assert rgb.std() > 0.05                       # not blank
    blue = np.all(np.abs(rgb - np.array([0x1f, 0x77, 0xb4]) / 255) < 0.08, axis=-1)
    dark = rgb.sum(axis=-1) < 1.5
    assert dark.mean() > 0.005 and (blue.any() or dark.mean() > 0.01)


def test_random_report_sections(tmp_path):
    run = load_run(random_run(tmp_path / "r.h5"))
    out = write_report(run, tmp_path / "rep", estimators=methods)
    assert list(out.sections[:5]) == ["FRFs per force level",
                                         "Multiple coherence per level (linear analysis)",
                                         "Level dependence of the FRF (random levels)",
                                         "Modal fit of the lowest level (fit-linear)",
                                         "Reverse path: underlying linear system and nonlinear "
                                         "coefficients"]
    html = Path(out.html).read_text()
    assert "the structure is nonlinear" in html
    for name in out.figures:
        assert f'src="{name}"' in html
        assert_real_image(tmp_path / "rep" / name)
    assert "reverse_path_coherence.png" in out.figures


def test_level_frf_tracks_nonlinearity(tmp_path):
    """Fig 3.5 physics: the cubic spring raises the resonance at the high level."""
    run = load_run(random_run(tmp_path / "r.h5"))
    low, high = (level_frf(r, i) for i, r in enumerate(run.recordings))
    peak = [f.freqs[np.argmax(np.abs(f.H[:, 0, 0]))] for f in (low, high)]
    fn = np.sqrt(2e5 / 2.0) / (2 * np.pi)                    # 50.3 Hz
    assert abs(peak[0] - fn) < 2 * (low.freqs[1] - low.freqs[0]) + 0.5
    assert peak[1] > peak[0] + 1.0
    assert low.multiple_coherence[np.abs(low.freqs - fn) > 10].min() > 0.95


def test_stepped_report_with_hbm_and_diagnosis(tmp_path):
    path = stepped_run(tmp_path / "s.h5")
    est = {"kind": "hysteresis", "w": [1.0], "params": {"kd": 2.3e7, "fd": 250.0, "n": 3.0},
           "ci95": {"kd": [2.2e7, 2.4e7], "fd": [240.0, 260.0], "n": [2.5, 3.5]}}
    store.save_result(path, "analyze-hbm", {"elements": [est], "cost": 0.01, "warnings": []})
    store.save_result(path, "diagnose", {"verdict": "discrepancy", "explanation": "friction",
                                         "fit": {"metric": "nrmse", "before": 0.4,
                                                 "after": 0.03}})
    run = load_run(path)
    frf = level_frf(run.recordings[0])
    assert frf.coherence is None and frf.freqs.size == 17
    out = write_report(run, tmp_path / "rep", estimators=methods)
    assert {"Hysteresis loop", "Measured vs estimated model", "Diagnosis"} <= \
        set(out.sections)
    assert not any("Reverse path" in s for s in out.sections)     # no random levels
    html = Path(out.html).read_text()
    assert "2.3e+07" in html and "analyze-hbm" in html
    for name in out.figures:
        assert_real_image(tmp_path / "rep" / name)


def test_report_command(tmp_path, capsys):
    path = random_run(tmp_path / "r.h5", seconds=8.0)
    assert main(["report", str(path), "--out", str(tmp_path / "o"), "--json", "-"]) == 0
    assert (tmp_path / "o" / "index.html").exists()
    assert main(["report", str(tmp_path / "none.h5"), "--out", str(tmp_path / "o")]) == 2


@pytest.mark.parametrize("bad", ["model.toml"])
def test_report_bad_candidate(tmp_path, bad):
    path = random_run(tmp_path / "r.h5", seconds=4.0)
    assert main(["report", str(path), "--out", str(tmp_path), "--model",
                 str(tmp_path / bad)]) == 2


def test_analyze_store_then_report(tmp_path):
    """campaign -> analyze hbm --store RUN -> report shows the fitted-model section."""
    from nlid_lab.campaign import run_campaign
    from nlid_lab.campaign import load_campaign

    examples = Path(__file__).resolve().parents[3] / "examples"
    run = tmp_path / "stepped.h5"
    run_campaign(load_campaign(examples / "campaign-sim-stepped.toml"), run)
    cand = Model.load(examples / "models" / "sdof-cubic-quaddamp.toml")
    cand_file = tmp_path / "cand.toml"
    cand.with_elements([type(e)(e.kind, e.w, {}) for e in cand.elements]).save(cand_file)
    assert main(["analyze", "hbm", str(run), "--model", str(cand_file), "--store",
                 str(run)]) == 0
    stored = store.open_run(run).results["analyze-hbm"]
    p = {e["kind"]: e["params"]["p"] for e in stored["elements"]}
    assert p["cubic_spring"] == pytest.approx(6e10, rel=0.02)
    out = write_report(load_run(run), tmp_path / "rep", estimators=methods)
    assert any("hbm_fit" in str(f) for f in out.figures)
    assert main(["analyze", "hbm", str(run), "--model", str(cand_file), "--store",
                 str(cand_file)]) == 2


def test_periodic_random_report_shows_the_bla_and_its_distortion(tmp_path):
    """A periodic-random run (one block per realization, layout in excitation_settings):
    FRFs are the robust BLA and the distortion section gives the detection verdict (the first
    level is driven through the linear part only: no distortion to find)."""
    from analysis.plant import multisine, periodic
    model, fs, n, m, p, t = Model.load(QUAD), 1024.0, 2048, 4, 3, 2
    settings = {"kind": "random", "periodic": True, "block_size": n, "periods": p,
                "transient_periods": t}
    path = tmp_path / "periodic.h5"
    with store.RunWriter(path, fs=fs, excitation=settings, force_dofs=[0], n_dof=1,
                         model_toml=QUAD.read_text(), mode="overwrite") as run:
        for i, rms in enumerate((1.0, 20.0)):
            f = np.concatenate([periodic(multisine(n, fs, (5, 150), rms, seed=s), t + p)
                                for s in range(m)])[:, None]
            plant = Plant(model.with_elements([]) if i == 0 else model, fs, [0])
            x = plant.run(f).displacement
            x += 1e-3 * x.std() * np.random.default_rng(i).standard_normal(x.shape)
            lv = run.level(i, rms)
            for k in range(m):
                rows = slice(k * (t + p) * n, (k + 1) * (t + p) * n)
                lv.append_block(f[rows], x[rows])
            lv.complete()
    data = load_run(path)
    assert data.recordings[0].layout.realizations == m
    out = write_report(data, tmp_path / "report", estimators=methods)
    assert "bla_distortion_out0.png" in out.figures
    html = (tmp_path / "report" / "index.html").read_text()
    assert "20 N rms, response DOF 0: nonlinear distortion" in html
    assert "1 N rms, response DOF 0: no distortion above the noise" in html
