"""The automatic analysis band of `diagnose`: its lower edge is the integration's high-pass."""

import numpy as np
import pytest

from analysis.diagnose._prepare import analysis_band, kinematic_band
from analysis.recordings import Recording


def _force_with_residual_floor(fs: float, n: int, band=(4.0, 200.0), floor_db=-18.0,
                               seed=0) -> np.ndarray:
    """White noise shaped flat in ``band`` and ``floor_db`` below it outside (the residual
    force a shaker shows below its drive band)."""
    spec = np.fft.rfft(np.random.default_rng(seed).standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / fs)
    inside = (f >= band[0]) & (f <= band[1])
    spec *= np.where(inside, 1.0, 10 ** (floor_db / 20))
    spec[f > 1.1 * band[1]] = 0.0
    return np.fft.irfft(spec, n)[:, None]


@pytest.mark.parametrize("kind, lowest", [("acceleration", 3.0), ("velocity", 3.0),
                                          ("displacement", 0.0)])
def test_lower_edge_of_an_integrated_record_is_the_drive_band(kind, lowest):
    fs, n = 1024.0, 1 << 17
    force = _force_with_residual_floor(fs, n)
    rec = Recording(fs=fs, force=force, response=np.zeros((n, 2)), force_dofs=np.array([0]),
                    excitation="random", response_kind=kind)
    lo, hi = analysis_band(rec, 4096)
    assert 195.0 <= hi <= 225.0
    if kind == "displacement":      # no integration: the residual force's bins count
        assert lo < 1.0
    else:                           # the high-pass of the integration: the drive band's edge
        assert lowest <= lo <= 4.0


@pytest.mark.parametrize("kind, periodic, lowpass", [
    ("acceleration", True, 0.9 * 200.0), ("velocity", True, 0.9 * 200.0),
    ("displacement", True, 30.0), ("acceleration", False, 30.0)])
def test_periodic_integrated_records_keep_the_harmonics_above_the_band(kind, periodic, lowpass):
    """A slider's reversals put harmonics far above the drive band into its deformation: a
    periodic integrated record keeps them up to 0.9 x Nyquist (each line Wiener-filtered by
    the period average), the others are low-passed at twice the band's upper edge."""
    hp, lp = kinematic_band(400.0, kind, (2.0, 15.0), periodic)
    assert lp == pytest.approx(lowpass)
    assert hp == (0.0 if kind == "displacement" else 2.0)
