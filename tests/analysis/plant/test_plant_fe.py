"""The plant on an FE-like structure (21 DOFs, five measurable points): exact in the linear case."""

import numpy as np

from analysis.plant import Plant, multisine, periodic
from structures import beam_with_payload

FS, N = 2048.0, 2048


def test_linear_fe_plant_matches_exact_periodic_response_at_sensors():
    s = beam_with_payload()
    model, sensors = s.model, list(s.points.values())
    drive = s.points["drive"]
    period = multisine(N, FS, (2.0, 200.0), 5.0, seed=4)
    force = periodic(period, 60)              # 1 % damping of the 6.6 Hz mode: ~16 s to settle
    x = Plant(model, FS, [drive]).run(force[:, None]).response[-N:, sensors]
    # exact: the plant holds the force linearly between samples, whose spectrum is the line
    # spectrum times sinc^2 (f / fs), folded back from every alias f + m fs
    lines = np.fft.rfftfreq(N, 1 / FS)
    F = np.fft.rfft(period)
    X = np.zeros((lines.size, len(sensors)), dtype=complex)
    for m in range(-3, 4):
        f = lines + m * FS
        f[f == 0] = 1e-9
        X += (model.linear_frf(np.abs(f), [drive])[:, sensors, 0].conj() if m < 0 else
              model.linear_frf(f, [drive])[:, sensors, 0]) * (np.sinc(f / FS) ** 2 * F)[:, None]
    exact = np.fft.irfft(X, N, axis=0)
    err = np.abs(x - exact).max(0) / np.abs(exact).max(0)
    assert err.max() < 1e-6, err
