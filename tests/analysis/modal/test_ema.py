"""Experimental modal analysis on an FE-like structure: more modes than sensors, noise,
accelerometers (analysis.modal._ema)."""

import numpy as np
import pytest
from scipy.linalg import eigh

from analysis.modal import fit_modes, mac
from analysis.plant import Plant, add_relative_noise, multisine, periodic
from analysis.spectral import hold_gain
from structures import beam_with_payload

BAND = (2.0, 200.0)
NAMES = ("drive", "joint", "tip", "payload")


@pytest.fixture(scope="module")
def beam():
    s = beam_with_payload()
    lam, phi = eigh(s.model.stiffness, s.model.mass)
    sensors = [s.points[k] for k in NAMES]
    in_band = np.sqrt(lam) / (2 * np.pi) < BAND[1]
    return s, sensors, np.sqrt(lam[in_band]) / (2 * np.pi), phi[sensors][:, in_band].T


def exact(s, sensors, freqs):
    return s.model.linear_frf(freqs, [s.points["drive"]])[:, sensors, 0]


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_modes_shapes_and_synthesis_from_a_receptance_column(beam, noise):
    s, sensors, fn, shapes = beam
    freqs = np.arange(0.25, 250.01, 0.25)
    h = exact(s, sensors, freqs)
    rng = np.random.default_rng(1)
    h = h * (1 + noise * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
             / np.sqrt(2))
    fit, stab = fit_modes(freqs, h, BAND, driving_point=0)
    assert fit.freqs_hz.size == fn.size == 4               # found without being told
    tight = noise == 0
    np.testing.assert_allclose(fit.freqs_hz, fn, rtol=2e-5 if tight else 5e-4)
    np.testing.assert_allclose(fit.damping, 0.01, rtol=0.005 if tight else 0.05)
    assert np.diag(mac(fit.shapes, shapes)).min() > 0.999
    # mass-normalised through the driving point: the FE shapes themselves (up to sign)
    sign = np.sign(np.sum(fit.shapes * shapes, axis=1))[:, None]
    np.testing.assert_allclose(fit.shapes * sign, shapes, atol=0.03 * np.abs(shapes).max())
    assert np.all(fit.support == 1.0) and np.all(fit.frf_error < 0.002 + 1.5 * noise)
    dense = np.arange(BAND[0], BAND[1], 0.05)
    truth = exact(s, sensors, dense)
    err = np.linalg.norm(fit.receptance(dense) - truth, axis=0) / np.linalg.norm(truth, axis=0)
    assert err.max() < (0.01 if tight else 0.02), err
    assert len(stab.orders) == len(stab.freqs_hz) and stab.stable[-1].any()


def test_periodic_multisine_with_accelerometers_and_sensor_noise(beam):
    """What fit-linear sees on a ground vibration test: four accelerometers with 1 % noise,
    force at one of them measured as it acted (``force_hold = "none"``), a periodic multisine
    averaged over periods, weighted by the noise measured from the spread over the periods
    (without it the weak low-frequency accelerance lines give the 6.6 Hz mode -7 % damping
    and the synthesis 7 % error). The structure is simulated 8 x faster than the DAQ samples it (a
    smooth force; the first-order hold between fine samples leaves <= 0.24 % at 220 Hz)."""
    s, sensors, fn, shapes = beam
    fs, n, up = 1024.0, 2048, 8
    fine = multisine(n * up, fs * up, (1.0, 220.0), 10.0, seed=7)
    out = Plant(s.model, fs * up, [s.points["drive"]], response_kind="acceleration").run(
        periodic(fine, 26)[:, None]).response[::up, sensors]
    acc = add_relative_noise(out, 0.01, np.random.default_rng(2))
    steady = acc[-16 * n:].reshape(16, n, len(sensors))
    lines = np.fft.rfftfreq(n, 1 / fs)
    spectra = np.fft.rfft(steady, axis=1)
    A, A_std = spectra.mean(0), spectra.std(0, ddof=1) / np.sqrt(spectra.shape[0])
    F = np.fft.rfft(fine[::up])
    use = (lines >= 1.0) & (lines <= 220.0)
    f = lines[use]
    to_receptance = 1 / np.abs(F[use, None] * (2 * np.pi * f[:, None]) ** 2)
    receptance = -A[use] / F[use, None] / (2 * np.pi * f[:, None]) ** 2
    fit, _ = fit_modes(f, receptance, BAND, driving_point=0, std=A_std[use] * to_receptance)
    np.testing.assert_allclose(fit.freqs_hz, fn, rtol=0.005)
    np.testing.assert_allclose(fit.damping, 0.01, rtol=0.10)
    assert np.diag(mac(fit.shapes, shapes)).min() > 0.99
    dense = np.arange(BAND[0], BAND[1], 0.05)
    truth = exact(s, sensors, dense)
    err = np.linalg.norm(fit.receptance(dense) - truth, axis=0) / np.linalg.norm(truth, axis=0)
    assert err.max() < 0.05, err
