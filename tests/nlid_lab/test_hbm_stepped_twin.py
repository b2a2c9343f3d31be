"""`analyze hbm` on the stepped-sine twin of docs/daq-artifacts.md (issue #23): each step is
recorded from the change of drive, so the first part of it holds the free decay of the
previous step's motion. Before the steps' steady parts were found (`analysis.spectral.
steady_start`) the cubic came out 4.37e9 [4.22e9, 4.52e9] for the true 4e9 (+9 %, the
interval excluding the truth).

Noise-free tolerance, from the method: the fit adds harmonic orders while the next one would
move the cubic by more than a tenth of its standard error (settled 8192-sample steps: +0.14 %
with orders to 7, +0.01 % with 9 added), so what is left is the settling rule's share: it
keeps windows within 1e-3 of the last quarter's FRF, and the decay left there moves the cubic
by -0.21 % on the 2048-sample steps (5 N and 2 N, steps near the mode not settled). 0.3 %
holds it with a factor ~1.4; the interval must hold the truth too (it carries the settling
rule's 1e-3 per step: no bias the interval hides). With sensor and force noise the 95 %
interval covers the truth.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import daq_twin as T
from analysis.hbm import fit_hbm
from analysis.models import Element
from analysis.spectral import stepped_sine_frf
from nlid_lab.commands.simulate import simulate_drive
from nlid_lab.formats import read_drive

#: relative error the default method leaves on the noise-free twin (module docstring)
NOISE_FREE_TOL = 3e-3


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    """The noise-free stepped twin as `simulate --response-kind acceleration` records it."""
    drive = read_drive(T.stepped_drive(tmp_path_factory.mktemp("twin") / "drive.npz"))
    return simulate_drive(T.truth(), drive, response_kind="acceleration")


def _fit(rec):
    cand = T.truth().with_elements([Element("cubic_spring", [-1.0, 1.0], {})])
    fit = fit_hbm(cand, [stepped_sine_frf(rec)])
    (key, p), = fit.params.items()
    return p, fit.ci95[key], fit.warnings


def test_noise_free_stepped_twin_unbiased(twin):
    p, (lo, hi), _ = _fit(twin)
    assert abs(p / T.P_TRUE - 1) < NOISE_FREE_TOL
    assert lo <= T.P_TRUE <= hi


@pytest.mark.parametrize("amplitude, samples", [(5.0, 8192), (2.0, 2048)])
def test_long_steps_and_weak_drive_within_their_interval(tmp_path, amplitude, samples):
    """The two settings of docs/hbm.md that fell outside their noise-free intervals: 8192-
    sample steps (+0.14 %, harmonic truncation: orders are now added and said) and 2 N
    (-0.20 %, steps at 15 and 16 Hz not settled, warned: the interval now holds the settling
    rule's share)."""
    from analysis.plant import sine_block

    force = np.stack([sine_block(f, amplitude, samples, T.FS)[:, None] for f in T.STEPS])
    path = tmp_path / "drive.npz"
    np.savez(path, fs=T.FS, force=force, force_dofs=np.array([0]), freqs=T.STEPS,
             level=amplitude)
    rec = simulate_drive(T.truth(), read_drive(path), response_kind="acceleration")
    p, (lo, hi), warnings = _fit(rec)
    assert abs(p / T.P_TRUE - 1) < NOISE_FREE_TOL and lo <= T.P_TRUE <= hi, (p, lo, hi)
    added = [w for w in warnings if w.startswith("harmonic orders")]
    unsettled = [w for w in warnings if "have not settled" in w]
    assert bool(added) == (samples == 8192) and bool(unsettled) == (amplitude == 2.0)


def test_transient_lead_is_dropped(twin):
    """Every step loses its lead (the previous step's decay), never its last quarter."""
    frf = stepped_sine_frf(twin)
    n = twin.force.shape[1]
    assert np.all(frf.steady_from > 0) and np.all(frf.steady_from <= 3 * n // 4)


def test_settled_steps_are_kept_whole():
    """A step that is steady from its start keeps all of it (a sine with no decay)."""
    from analysis.spectral import steady_start

    fs, f, n = 512.0, 15.0, 2048
    t = np.arange(n) / fs
    force = np.sin(2 * np.pi * f * t)
    resp = np.column_stack([0.3 * np.sin(2 * np.pi * f * t - 0.4)
                            + 0.01 * np.sin(6 * np.pi * f * t), 0.1 * force])
    assert steady_start(force, resp, fs, f, (1, 3)) == 0


def test_noisy_stepped_twin_covered(twin):
    """1 % sensor and force noise (of each channel's rms), four draws: at least three of the
    95 % intervals cover the truth (two or more miss with probability 1.4 %; measured
    over 20 draws: 19 cover, mean -0.09 %, spread 0.11 %, half-widths ~0.3 %), each wider
    than the noise-free bias."""
    covered = 0
    for seed in range(4):
        rng = np.random.default_rng(seed)
        resp, force = twin.response, twin.force
        noisy = dataclasses.replace(
            twin, response=resp + 0.01 * resp.std() * rng.standard_normal(resp.shape),
            force=force + 0.01 * force.std() * rng.standard_normal(force.shape))
        p, (lo, hi), _ = _fit(noisy)
        covered += lo <= T.P_TRUE <= hi
        assert (hi - lo) / 2 / T.P_TRUE > 1e-3
    assert covered >= 3


def test_channel_delay_is_read_taken_out_and_named(twin):
    """The `delay` artifact (responses one sample behind the force, 1.953 ms at 512 Hz)
    turned the FRF phase by ``w tau`` and took the cubic to 2.59e9 [1.75e9, 3.43e9]; the fit
    now reads the delay, takes it out and names it: the cubic as without the delay (the
    noise-free tolerance) and no delay named on the clean twin."""
    r = twin.response
    late = dataclasses.replace(twin, response=np.concatenate([r[:, :1], r[:, :-1]], axis=1))
    p, (lo, hi), warnings = _fit(late)
    assert abs(p / T.P_TRUE - 1) < NOISE_FREE_TOL and lo <= T.P_TRUE <= hi
    (said,) = [w for w in warnings if "lag the force" in w]
    ms = float(said.split("by ")[1].split(" ms")[0])
    assert ms == pytest.approx(1e3 / T.FS, rel=0.02)
    assert not any("lag the force" in w for w in _fit(twin)[2])
