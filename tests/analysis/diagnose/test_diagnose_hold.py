"""The diagnosis honours the recording's force hold: its measured FRF and basis transfers are
per unit of the force that acted (simulated data: the first-order hold of the drive)."""

import numpy as np
import pytest

from analysis.diagnose._compare import level_frf
from analysis.diagnose._prepare import prepare_random
from analysis.plant import random_gaussian, simulate
from analysis.recordings import Recording
from diagnose_scenarios import chain

FS, N = 256.0, 1 << 15


@pytest.mark.parametrize("hold", ["linear", "none"])
def test_measured_frf_is_per_unit_of_the_force_that_acted(hold):
    truth = chain([1.0, 1.0], [1e4], [2e4, 1e4])        # modes at 18.7 and 30.3 Hz
    force = random_gaussian(N, FS, (2.0, 70.0), 1.0, seed=5)[:, None]
    x = simulate(truth, force, FS, [0])                # the drive acts as its linear hold
    rec = Recording(FS, "random", [0], force, x, force_hold=hold)
    band = (2.0, 70.0)
    lf = level_frf(prepare_random(rec, band, "l0"), band, 1024, {})
    far = (lf.freqs > 45.0) & (lf.freqs < 70.0)        # no leakage of the light modes here
    ratio = np.abs(lf.H[far] / truth.linear_frf(lf.freqs[far], [0]))[:, :, 0]
    acted = np.sinc(lf.freqs[far] / FS) ** 2            # 0.83 at 60 Hz
    expected = 1.0 if hold == "linear" else acted[:, None]
    np.testing.assert_allclose(ratio, np.broadcast_to(expected, ratio.shape), rtol=5e-3)
