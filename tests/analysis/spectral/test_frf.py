"""Level FRFs (`analysis.spectral._frf`): the one default segment length, and the live view's running
average equal to a Welch estimate over all blocks received."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.spectral import _spectral as spectral, default_nperseg, frf_from_spectra


def test_default_nperseg_rule():
    assert default_nperseg(16 * 1000) == 512          # power of two, >= 16 segments
    assert default_nperseg(16 * 1024) == 1024
    assert default_nperseg(100) == 64                 # floor
    assert default_nperseg(10**8) == 8192             # cap


def test_live_accumulator_is_the_welch_average_over_blocks():
    pytest.importorskip("PySide6")
    pytest.importorskip("pyqtgraph")
    from nlid_lab.gui._live import FrfAccumulator

    rng = np.random.default_rng(4)
    fs, nps = 512.0, 256
    blocks = [(f, 3.0 * f + 0.1 * rng.standard_normal(f.shape))
              for f in (rng.standard_normal((n, 1)) for n in (1024, 2048, 100, 768))]
    acc = FrfAccumulator(fs, 1, nps)
    for f, x in blocks:
        acc.add(f, x)
    # by hand: every segment of every long-enough block weighs the same
    specs = [spectral.spectral_matrix(np.concatenate([f, x], axis=1), fs, nperseg=nps)
             for f, x in blocks if f.shape[0] >= nps]
    n_avg = sum(s.n_avg for s in specs)
    mean = specs[0]
    mean.S = sum(s.S * s.n_avg for s in specs) / n_avg
    mean.n_avg = n_avg
    live = acc.estimate(label="l", level=None, excitation="random",
                        response_kind="displacement", force_dofs=np.array([0]))
    ref = frf_from_spectra(mean, 1, label="l", level=None, excitation="random",
                           response_kind="displacement", force_dofs=np.array([0]))
    assert live.n_averages == n_avg == 7 + 15 + 5
    np.testing.assert_allclose(live.H, ref.H, rtol=1e-12)
    np.testing.assert_allclose(live.coherence, ref.coherence, rtol=1e-12)
    assert np.allclose(np.abs(live.H), 3.0, rtol=0.05)
