"""The real-DAQ artifact catalogue adds each artifact at its stated level (issue #23 item 2)."""

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.models import Model
from analysis.recordings import (ARTIFACTS, DaqArtifacts, PeriodicLayout, Recording,
                                 apply_daq_artifacts, shaker_force)

FS, PERIOD = 1000.0, 1000


def _clean() -> Recording:
    rng = np.random.default_rng(1)
    t = np.arange(5 * PERIOD) / FS
    force = np.sin(2 * np.pi * 7 * t)[:, None] + 0.1 * rng.standard_normal((t.size, 1))
    resp = np.column_stack([np.sin(2 * np.pi * 7 * t + 0.3), 0.5 * np.cos(2 * np.pi * 13 * t)])
    return Recording(FS, "random", [0], force, resp, "acceleration",
                     layout=PeriodicLayout(PERIOD, 1, 4, 1))


def _with(**fields) -> tuple[Recording, Recording]:
    clean = _clean()
    return clean, apply_daq_artifacts(clean, DaqArtifacts(**fields), np.random.default_rng(2))


def test_mains_line_at_its_level_in_every_channel():
    clean, rec = _with(mains_hz=50.0, mains_db=-40.0, mains_harmonics=2)
    data = np.column_stack([rec.force, rec.response]) - np.column_stack([clean.force,
                                                                         clean.response])
    spec = np.abs(np.fft.rfft(data, axis=0)) / data.shape[0] * 2 / np.sqrt(2)   # line rms
    f = np.fft.rfftfreq(data.shape[0], 1 / FS)
    rms = np.column_stack([clean.force, clean.response]).std(axis=0)
    np.testing.assert_allclose(20 * np.log10(spec[f == 50.0][0] / rms), -40.0, atol=1e-6)
    np.testing.assert_allclose(20 * np.log10(spec[f == 100.0][0] / rms), -46.0, atol=1e-6)


def test_offset_drift_delay_and_channels():
    clean, rec = _with(dc_offset=0.05, delay=1, dead_channel=-1)
    rms = clean.response.std(axis=0)
    assert abs((rec.force - clean.force).mean()) == pytest.approx(0.05 * clean.force.std())
    # responses one sample behind the force
    np.testing.assert_allclose(np.diff(rec.response[1:, 0]), np.diff(clean.response[:-1, 0]),
                               atol=1e-12)        # (the offset cancels in differences)
    assert rec.response[:, 1].std() < 1e-4 * rms[1]             # dead
    _, drift = _with(drift=0.1)
    assert np.ptp(drift.force[:, 0] - clean.force[:, 0]) == pytest.approx(
        0.1 * clean.force.std(), rel=1e-3)


def test_converter_clips_a_few_samples_and_quantises_to_16_bits():
    clean, rec = _with(clipped=5, bits=16, full_scale=2.0)
    peak = np.abs(np.column_stack([clean.force, clean.response])).max(axis=0)
    step = 4 * peak / 2 ** 16
    for j, x in enumerate(np.column_stack([rec.force, rec.response]).T):
        levels = np.unique(np.round(x / step[j], 6))
        assert np.allclose(levels, np.round(levels))       # every sample on the grid
    clipped = [np.sum(np.abs(x) >= np.abs(x).max() - 1e-9 * np.abs(x).max())
               for x in rec.response.T]
    assert max(clipped) >= 6                               # 5 cut to the 6th largest


def test_zeros_and_partial_period_drop_the_layout():
    clean, rec = _with(lead_in=100, trailing=50, partial_period=0.37)
    assert rec.force.shape[0] == 5 * PERIOD - 370 + 150 and rec.layout is None
    assert not np.any(rec.force[:100]) and not np.any(rec.response[-50:])
    np.testing.assert_array_equal(rec.force[100:-50], clean.force[:5 * PERIOD - 370])


def test_catalogue_names_and_a_wrong_one():
    for name in ARTIFACTS:
        DaqArtifacts.of([name], FS)
    assert DaqArtifacts.of(["mains", "zeros"], FS).lead_in == 500
    with pytest.raises(InputError, match="not one of mains"):
        DaqArtifacts.of(["hum"], FS)


def test_shaker_force_dips_at_the_resonance():
    """SDOF at 20 Hz driven by a flat multisine through the armature: the measured force
    dips at the resonance by 1 / |1 + Z_a H| (about 1/30 here) and is flat far from it."""
    model = Model([[10.0]], [[2 * 0.01 * np.sqrt(10 * 1.6e5)]], [[1.6e5]], [])
    n = 4000
    f = np.fft.rfftfreq(n, 1 / FS)
    flat = np.fft.irfft(np.where((f > 5) & (f < 100), 1.0, 0.0) * np.exp(1j * f), n)
    measured = shaker_force(flat, FS, model.linear_frf(f, [0])[:, 0, 0])
    gain = np.abs(np.fft.rfft(measured)) / np.maximum(np.abs(np.fft.rfft(flat)), 1e-300)
    fn = np.sqrt(1.6e5 / 10) / 2 / np.pi
    at = np.argmin(np.abs(f - fn))
    assert gain[at] < 0.1 and gain[at] == gain[(f > 5) & (f < 100)].min()
    assert gain[np.argmin(np.abs(f - 90))] > 0.5
