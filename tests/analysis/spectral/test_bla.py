"""Best linear approximation and nonlinearity detection from periodic-random data."""

import numpy as np
import pytest

from analysis.spectral import best_linear_approximation
from analysis.detection import bla_summary
from analysis.errors import InputError
from analysis.plant import Plant, add_relative_noise, multisine, periodic
from analysis.models import Model

FS, N, M, P, T = 1024.0, 4096, 8, 6, 2
SDOF = Model.load("examples/models/sdof-cubic-quaddamp.toml")


def _bla(model, level, noise=0.01):
    f = np.concatenate([periodic(multisine(N, FS, (5, 150), level, seed=s), T + P)
                        for s in range(M)])[:, None]
    x = add_relative_noise(Plant(model, FS, [0], oversample=2).run(f).displacement, noise, 1)
    return best_linear_approximation(f, x, FS, N, transient_periods=T, realizations=M,
                                     force_hold="linear")


def test_linear_system_bla_is_its_frf_within_the_noise():
    """A linear plant with 1 % output noise: no distortion detected and the BLA error is the
    noise (|e| / sigma of a complex Gaussian has median sqrt(ln 2) = 0.83)."""
    lin = SDOF.with_elements([])
    b = _bla(lin, 15.0)
    assert not bla_summary(b).nonlinear
    z = np.abs(b.G[:, 0] - lin.linear_frf(b.freqs, [0])[:, 0, 0]) / np.sqrt(b.var_total[:, 0])
    assert 0.7 < np.median(z) < 1.0
    assert np.median(b.var_total / b.var_noise) == pytest.approx(1.0, abs=0.15)
    assert np.median(b.coherence) > 0.999        # 1 % noise: measured 0.99976


def test_cubic_spring_distortion_is_detected_around_resonance():
    b = _bla(SDOF, 15.0)
    out = bla_summary(b)
    assert out.nonlinear and out.median_change_db[0] > 10       # measured +17 dB
    assert out.band_hz[0] < 50.3 < out.band_hz[1]
    assert np.all(b.var_distortion >= 0)
    assert b.coherence[np.argmin(np.abs(b.freqs - 52.0)), 0] < 0.9   # distortion at resonance


def test_bla_input_errors():
    f = np.zeros((8 * N, 2))
    with pytest.raises(InputError, match="one force channel"):
        best_linear_approximation(f, f, FS, N, realizations=2)
    with pytest.raises(InputError, match="no DFT line"):
        best_linear_approximation(f[:, :1], f, FS, N, realizations=1)


def test_one_realization_gives_the_period_average_and_its_noise():
    """One realization of P periods: G is the period average, its noise variance comes from
    the spread over the periods (it covers the error of G), and the total variance - which
    needs two realizations - is not invented (NaN)."""
    u = periodic(multisine(N, FS, (5.0, 200.0), 1.0, seed=4), P + 1)
    rng = np.random.default_rng(5)
    y = np.column_stack([np.convolve(u, [0.5, 0.3, 0.2])[:u.size], np.roll(u, 3)])
    y_noisy = y + 0.01 * y.std(axis=0) * rng.standard_normal(y.shape)
    b = best_linear_approximation(u, y_noisy, FS, N, transient_periods=1, realizations=1)
    exact = best_linear_approximation(u, y, FS, N, transient_periods=1, realizations=1)
    assert b.realizations == 1 and b.periods == P and np.all(np.isnan(b.var_total))
    z = np.abs(b.G - exact.G) ** 2 / b.var_noise
    # |error|^2 / estimated var is F(2, 2 (P - 1)): mean 2 (P - 1) / (2 (P - 1) - 2)
    mean = 2 * (P - 1) / (2 * (P - 1) - 2)
    assert abs(np.mean(z) / mean - 1) < 0.15, np.mean(z)
    assert np.all(exact.var_noise < 1e-20 * np.abs(exact.G).max() ** 2)
