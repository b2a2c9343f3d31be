"""A default Welch segment that resolves the modes (issue #23 item 5)."""

import numpy as np
import pytest

from analysis.models import Element, Model
from analysis.plant import Plant, random_gaussian
from analysis.reverse_path import reverse_path
from analysis.spectral import (LINES_PER_BANDWIDTH, narrowest_peak, pole_resolution,
                               resolving_nperseg)

PAPER = "examples/models/three-dof-paper.toml"


def test_narrowest_peak_reads_the_half_power_bandwidth():
    """|H|^2 of two modes (0.5 % at 70 Hz, 2 % at 200 Hz) on 0.01 Hz lines: the narrower one,
    its bandwidth 2 zeta f_n within the lines' interpolation (a few 1e-4 relative)."""
    f = np.arange(1.0, 400.0, 0.01)
    h = sum(1 / (fn ** 2 - f ** 2 + 2j * z * fn * f) for fn, z in ((70.0, 0.005), (200.0, 0.02)))
    peak, bw = narrowest_peak(f, np.abs(h) ** 2)
    assert peak == pytest.approx(70.0, abs=0.01)
    assert bw == pytest.approx(2 * 0.005 * 70.0, rel=2e-3)


def test_resolving_nperseg_spans_the_bandwidth_of_a_lightly_damped_mode():
    """Linear SDOF at 0.5 % (0.5 Hz bandwidth at 50 Hz), 64 s at 1024 Hz: the default
    (4096 samples, 0.25 Hz lines) gives 2 lines; the segment is doubled until the bandwidth
    spans LINES_PER_BANDWIDTH lines (16384: 8), and the bandwidth read there is the true one
    within 10 % (at 8192, 4 lines, it read 0.64 Hz)."""
    fs, fn, z = 1024.0, 50.0, 0.005
    k = (2 * np.pi * fn) ** 2
    model = Model([[1.0]], [[2 * z * np.sqrt(k)]], [[k]], [])
    force = random_gaussian(1 << 16, fs, (5, 200), 1.0, seed=3)[:, None]
    y = Plant(model, fs, [0]).run(force).displacement
    res = resolving_nperseg(force, y, fs, (5, 200))
    assert res.nperseg == 16384 and res.resolved
    assert res.bandwidth_hz * res.nperseg / fs >= LINES_PER_BANDWIDTH
    assert res.bandwidth_hz == pytest.approx(2 * z * fn, rel=0.1)


def _paper(scale: float, n: int, oversample: int | None = None):
    model = Model.load(PAPER)
    structure = Model(model.mass, model.damping * scale, model.stiffness, model.elements)
    force = random_gaussian(n, 4096.0, (5, 400), 8.0, seed=11)[:, None]
    out = Plant(structure, 4096.0, [0], **({} if oversample is None else
                                            {"oversample": oversample})).run(force)
    cand = model.with_elements([Element(e.kind, e.w, {}) for e in model.elements])
    return model, reverse_path((force, out.displacement), cand, fs=4096.0, force_dofs=[0],
                               force_hold="linear")


def test_paper_case_with_defaults_resolves_its_modes():
    """Paper 3.3.2, noise-free, 8 s at 4096 Hz, default settings: the old default segment
    (2048 samples, 2 Hz lines for the 82 Hz peak's ~2.2 Hz bandwidth) gave the cubic +1.44 %
    and coherence 0.989; the resolving segment (8192) gives -0.002 % and >= 0.99 (paper fig
    3.9); 4.3 lines still fall short of 5, and the warning says which --nperseg would do."""
    model, res = _paper(1.0, 1 << 15)
    assert res.spectra.nperseg == 8192
    for c in res.coefficients:
        assert c.value == pytest.approx(model.elements[c.element].params["p"], rel=2e-3)
    assert res.coherence_nonlinear.min() > 0.99
    assert any("--nperseg 16384 would resolve it" in w for w in res.warnings)


def test_too_short_a_record_says_which_nperseg_would_resolve():
    """The same structure at 0.28x its damping (0.5 % for the first mode), 8 s: the segment
    is capped at a quarter of the record; the warning names the resonance (84 Hz at this
    level) and an --nperseg (and record length) that would resolve it: 16384, from the 1.87 Hz
    read with 2 Hz lines (an upper bound: 7 averages at 8192 leave no trusted reading).

    Simulated at 256 substeps per sample, not the plant's automatic choice: at this damping
    the trajectory is so sensitive that 256 and 2604 substeps per sample give responses 32 %
    rms apart, and the plant's automatic check refines to 2604 (11.7 CPU s against 0.9);
    the spectra the warning reads agree (bandwidth 1.87 Hz at 256, 1.72 Hz at 64, 1.76 Hz at
    2604 substeps: 16384 is the answer for any from 1.25 to 2.5 Hz)."""
    _, res = _paper(0.281, 1 << 15, oversample=256)
    assert res.spectra.nperseg == 8192
    (w,) = [w for w in res.warnings if "half-power bandwidth" in w]
    assert "resonance at 84 Hz" in w
    assert "--nperseg 16384 would resolve it with a record of 65536 samples" in w


def _light(seconds: int):
    """The paper's structure at 0.28x its damping (0.5 % on the first mode, 0.71 Hz wide at
    70.8 Hz), 4 N rms, noise-free, and a candidate with that linear part. Simulated at 64
    substeps per sample: at this damping the trajectory amplifies differences (x1e7 in
    0.25 s, against solve_ivp), so step doubling over its chunks raises the substeps to
    2604-4096 without changing the spectra (8 N, 8 s: minimum coherence 0.945 at 2604,
    0.947 at 64; element forces at the samples equal the model's laws to 3e-14)."""
    model = Model.load(PAPER)
    light = Model(model.mass, model.damping * 0.281, model.stiffness, model.elements)
    force = random_gaussian(seconds * 4096, 4096.0, (5, 400), 4.0, seed=11)[:, None]
    x = Plant(light, 4096.0, [0], oversample=64).run(force).displacement
    cand = light.with_elements([Element(e.kind, e.w, {}) for e in light.elements])
    return light, reverse_path((force, x), cand, fs=4096.0, force_dofs=[0],
                               force_hold="linear")


def test_pole_resolution_reads_the_narrowest_mode_of_the_linear_part():
    """The paper's linear part at 0.28x damping: mode 1 at 70.83 Hz, 2 zeta f_n = 0.709 Hz;
    10 lines of it at 4096 Hz need 57770 samples: 65536."""
    model = Model.load(PAPER)
    res = pole_resolution(model.mass, 0.281 * model.damping, model.stiffness, (5, 400),
                          8192, 4096.0)
    zeta_f = 0.5 * 8e-5 * 0.281 * (2 * np.pi * res.peak_hz) * res.peak_hz
    assert res.peak_hz == pytest.approx(70.83, abs=0.01)
    assert res.bandwidth_hz == pytest.approx(2 * zeta_f, rel=1e-3)
    assert res.needed == 65536 and not res.resolved


def test_short_record_names_the_nperseg_that_resolves_the_linear_mode():
    """16 s of the lightly damped case: the measured FRF shows the first mode stiffened to
    ~82 Hz; the candidate's linear part sets the advice (the measured FRF alone read 82 Hz,
    1.02 Hz wide, and named 32768: minimum coherence 0.983 at 64 s, against 0.991)."""
    _, res = _light(16)
    (w,) = [w for w in res.warnings if "half-power bandwidth" in w]
    assert "resonance at 70.83 Hz (half-power bandwidth 0.709 Hz)" in w
    assert "--nperseg 65536 would resolve it with a record of 262144 samples" in w


@pytest.mark.slow
def test_lightly_damped_case_with_defaults_resolves_its_modes():
    """64 s of the lightly damped case with default settings: segments of 65536 samples
    (0.0625 Hz, 11 lines of the first mode; the measured FRF alone chose 32768: coherence
    0.983), minimum multiple coherence > 0.99 (0.991), both coefficients inside their 95 %
    intervals (-0.002 % and -0.003 %, intervals +-0.013 %)."""
    model, res = _light(64)
    assert res.spectra.nperseg == 65536
    assert not [w for w in res.warnings if "half-power bandwidth" in w]
    assert res.coherence_nonlinear.min() > 0.99
    for c in res.coefficients:
        assert c.ci95[0] <= model.elements[c.element].params["p"] <= c.ci95[1]
