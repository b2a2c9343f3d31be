"""Clipped samples (`analysis.recordings.clipping`): the pile-up of a channel's extreme value
found, nothing found where a signal reaches its extreme by itself (continuous, quantised,
noise-free periodic, constant); the diagnosis keeps them out of its spectra
(`analysis.diagnose._prepare`, `_compare._spectra`)."""

import numpy as np
import pytest

from analysis.diagnose._compare import _spectra
from analysis.diagnose._prepare import clipped_note, prepare_random
from analysis.recordings import Recording, clipping, recording_clipping
from analysis.spectral import spectral_matrix

N = 8192


def _random(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal((N, 1))


def _clip(a: np.ndarray, k: int) -> tuple[np.ndarray, float]:
    """``a`` with its ``k`` largest |samples| cut to the next one (the catalogue's artifact)."""
    level = np.sort(np.abs(a[:, 0]))[-k - 1]
    return np.clip(a, -level, level), level


def test_clipped_samples_found_with_their_limits():
    resp, level = _clip(_random(), 5)
    c = clipping(_random(1), resp, ["acceleration"], "level 8")
    (ch,) = c.channels
    assert ch.kind == "acceleration" and ch.channel == 0
    assert ch.samples.size == 6                   # the 5 cut and the sample they were cut to
    assert np.all(np.abs(resp[ch.samples, 0]) == level)
    text = c.text("left out")
    assert text.startswith("acceleration channel 0: 6 clipped samples at level 8, ")
    assert "; left out; raise the channel's range" in text


def test_one_sided_clip_names_its_limit():
    a = _random(2)
    top = np.sort(a[:, 0])[-4]
    a = np.minimum(a, top)
    (ch,) = clipping(a, _random(3), ["acceleration"], "2 N rms").channels
    assert ch.kind == "force" and ch.high == top and ch.low is None
    assert ch.samples.size == 4 and ch.limits() == f"{top:+.3g} N"


@pytest.mark.parametrize("signal", ["continuous", "quantised", "periodic", "constant"])
def test_no_clipping_where_the_signal_reaches_its_extreme_itself(signal):
    a = _random(4)
    if signal == "quantised":                       # 16 bits over +-2x the peak
        step = 4 * np.abs(a).max() / 2 ** 16
        a = np.round(a / step) * step
    elif signal == "periodic":                      # noise-free: every value once a period
        a = np.tile(a[:1024], (8, 1))
    elif signal == "constant":
        a = np.zeros_like(a)
    assert clipping(a, a, ["displacement"], "level 1") is None


def test_coarse_quantisation_is_not_read_as_clipping():
    """A 12-bit converter using 1/16 of its range: a few samples per step in the tails, and
    the extreme step by chance holds more than the next (with the extreme compared with the
    next value alone, 9 % of such channels read as clipped); none of 100 does."""
    rng = np.random.default_rng(5)
    step = 4.5 * 16 / 2 ** 11
    found = [clipping(a, a, ["acceleration"], "level 1")
             for a in (np.round(rng.standard_normal((4 * N, 1)) / step) * step
                       for _ in range(100))]
    assert found == [None] * 100


def _rec(resp: np.ndarray, force: np.ndarray) -> Recording:
    return Recording(256.0, "random", np.array([0]), force, resp, "acceleration")


def test_periodic_record_leaves_out_the_clipped_periods():
    """Whole periods: the period holding the clipped samples is dropped, the others kept
    as they are."""
    period = 512
    force = np.tile(_random(5)[:period], (6, 1))
    resp = np.tile(_random(6)[:period], (6, 1)) + 1e-3 * _random(7)[:6 * period]
    peak = np.abs(resp).max()
    resp[3 * period + 100: 3 * period + 103] += 5 * peak   # a shock in period 3 ...
    resp = np.clip(resp, -2 * peak, 2 * peak)              # ... past the range: a plateau
    rec = _rec(resp, force)
    c = recording_clipping(rec, "level 1")
    assert c is not None and set(c.samples // period) == {3}
    p = prepare_random(rec, (5.0, 60.0), "level 1", period=period, clipped=c)
    assert p.clipped_periods == 1 and p.x.shape[0] == 4 * period   # 1 transient, 1 clipped
    assert "(1 of 5)" in clipped_note(c, p)


def test_random_record_spectra_leave_out_the_segments_reached():
    """A random record: the Welch segments a clipped sample reaches are left out, the
    others averaged as one estimate (the same as Welch over the clean part alone)."""
    force, resp = _random(8), _random(9)
    resp, _ = _clip(resp, 3)
    rec = _rec(resp, force)
    c = recording_clipping(rec, "level 1")
    p = prepare_random(rec, (5.0, 60.0), "level 1", clipped=c)
    assert p.clipped is not None and p.clipped[c.samples - int(0.02 * N)].all()
    data = np.concatenate([p.x, p.force], axis=1)
    sp = _spectra(p, (5.0, 60.0), 256, data)
    starts, stops = np.flatnonzero(np.diff(np.r_[0, ~p.clipped, 0]) != 0).reshape(-1, 2).T
    parts = [spectral_matrix(data[a:b], 256.0, nperseg=256, band=(5.0, 60.0))
             for a, b in zip(starts, stops) if b - a >= 256]
    assert sp.n_avg == sum(q.n_avg for q in parts) < spectral_matrix(
        data, 256.0, nperseg=256).n_avg
    want = sum(q.S * q.n_avg for q in parts) / sp.n_avg
    np.testing.assert_allclose(sp.S, want, rtol=1e-12)


def test_periodic_record_clipped_in_every_period_keeps_them_and_says_so():
    """Fewer than two periods would stay: none is left out, and the warning says why."""
    period = 512
    force = np.tile(_random(10)[:period], (4, 1))
    resp = np.tile(_random(11)[:period], (4, 1)) + 1e-3 * _random(12)[:4 * period]
    peak = np.abs(resp).max()
    for k in range(4):                                     # a shock in every period
        resp[k * period + 50: k * period + 52] += 5 * peak
    rec = _rec(np.clip(resp, -2 * peak, 2 * peak), force)
    c = recording_clipping(rec, "level 1")
    p = prepare_random(rec, (5.0, 60.0), "level 1", period=period, clipped=c)
    assert p.clipped_periods == 0 and p.x.shape[0] == 3 * period and p.clipped.any()
    assert "kept: fewer than two periods would stay without them (0 of 3)" in clipped_note(c, p)
