"""The responses' delay behind the force, read and taken out before the diagnosis
(`analysis.diagnose._alignment`): found on a zoo row that carries it, in either direction,
a fraction of a sample with its resolution; never on the same data aligned, on a start model
that holds, or on a slider acting at the lowest level (where a shift does lower the start
model's misfit at every level)."""

from dataclasses import replace

import numpy as np
import pytest

import diagnose_zoo as Z
from analysis.diagnose import Evidence, ResponseDelay
from analysis.diagnose._alignment import _line_delay, shifted
from analysis.diagnose._compare import FLOOR
from analysis.diagnose._prepare import Prepared, split_segment
from analysis.diagnose._search import RandomFlow, _misfit, _ratio
from analysis.recordings import DaqArtifacts, apply_daq_artifacts, model_at_sensors, one_kind


def _fraction_twin(delay: float) -> list:
    """``chain-cubic01-disp-random-delay`` with its responses ``delay`` samples late (a
    fraction: a band-limited phase ramp, `DaqArtifacts.delay`)."""
    def add(recs, artifacts, seed):
        return [apply_daq_artifacts(r, DaqArtifacts(delay=delay),
                                    np.random.default_rng(seed + 200 + i))
                for i, r in enumerate(recs)]
    return Z._lumped(Z.chain3, 0, Z.RANDOM, "displacement", ("cubic_spring", ("0", "1")), (),
                     3, add)


def _flow(name: str, move: int = 0, levels: slice = slice(None),
          delay: float | None = None) -> RandomFlow:
    """The diagnosis' random flow (preparation only) on zoo row ``name`` (its ``levels``),
    its responses moved ``move`` samples earlier first (or ``delay`` samples late: the row's
    twin, `_fraction_twin`)."""
    (case,) = [c for c in Z.zoo(name) if c.name == name]
    built = case.build() if delay is None else _fraction_twin(delay)
    recs = [one_kind(r) for r in built.recordings][levels]
    if move:
        recs = [replace(r, force=r.force[:-move], response=r.response[move:]) for r in recs]
    model = model_at_sensors(built.start, recs, "diagnose")
    return RandomFlow(model, recs, holdout=None, band=built.band, nperseg=None, period=None,
                      floor=FLOOR)


def test_delay_found_taken_out_and_said():
    flow = _flow("chain-cubic01-disp-random-delay")
    d = flow.delay
    assert d is not None and d.samples == 1
    assert d.misfit_before[0] > d.limit >= d.misfit_after[0]          # within its floor
    assert d.misfit_before[1] - d.misfit_after[1] > d.noise             # confirmed
    assert any("lag the force by 1 sample" in w and "response_delay=1" in w
               for w in flow.warnings)
    model = flow.model
    assert _misfit(model, flow.preps[0], flow.band, flow.nps, FLOOR)[0] == pytest.approx(
        d.misfit_after[0])                                              # the levels aligned


@pytest.mark.parametrize("move, expected", [(1, None), (2, -1)])
def test_delay_follows_the_data(move, expected):
    """The same records aligned by hand: no delay; moved one sample too far: a lead."""
    flow = _flow("chain-cubic01-disp-random-delay", move)
    assert (None if flow.delay is None else flow.delay.samples) == expected


def test_delay_of_one_level_confirmed_on_its_held_back_segment():
    flow = _flow("chain-cubic01-disp-random-delay", levels=slice(0, 1))
    assert flow.delay is not None and flow.delay.samples == 1
    assert flow.delay.confirmed_on.endswith("(held-back segment)")


@pytest.mark.slow
def test_half_sample_delay_read_line_by_line():
    """A 0.5-sample delay (zoo row ``chain-cubic01-disp-random-delay-half``): no whole-sample
    shift brings the lowest level within its floor (0 and 1 sample leave it 1.2x and 1.6x),
    the line-by-line reading on the level's first 70 % does, confirmed on its last 30 %;
    its 95 % interval holds 0.5 (0.4968 +- 0.0032; the start model's misfit read 0.446, a
    modal fit of the level 0.444: both weighted to the resonances, where the simulated
    plant's own phase error sits), said to that resolution."""
    flow = _flow("chain-cubic01-disp-random-delay-half")
    d = flow.delay
    assert d is not None and 0 < d.resolution < 0.05
    assert abs(d.samples - (0.5 + _own_offset())) <= d.resolution
    assert d.decided_on.endswith("(fit segment)") and d.confirmed_on.endswith("(held-back "
                                                                               "segment)")
    assert d.misfit_before[0] > d.limit >= d.misfit_after[0]
    note = next(w for w in flow.warnings if "lag the force" in w)
    assert f"by {d.stated:g} samples (95 % interval {d.samples - d.resolution:.3f}" in note
    assert f"response_delay={d.stated:g}`" in note


def _own_offset() -> float:
    """The line-by-line reading of the `-delay` row's data with its delay taken out by hand
    (the same simulation the fractional twins delay): the simulated plant's own phase,
    -0.003 sample."""
    flow = _flow("chain-cubic01-disp-random-delay", 1)
    fit = split_segment(flow.preps[0])[0]
    return _line_delay(fit, lambda p: _ratio(flow.model, p, flow.band, flow.nps, FLOOR), 0)[0]


@pytest.mark.slow
@pytest.mark.parametrize("delay, held", [(0.3, True), (0.5, False), (0.7, False)])
def test_fractions_read_line_by_line(delay, held):
    """The `-delay` row's twin at 0.3 sample (the start model holds the lowest level within
    its floor with it: read at 99.9 % on both segments), 0.5 and 0.7 (no whole shift
    serves): each read within its 95 % interval of the delay plus the data's own offset
    (0.2968 +- 0.0034, 0.4968 +- 0.0032, 0.6967 +- 0.0032; offset -0.003)."""
    offset = _own_offset()
    assert abs(offset) < 0.01
    flow = _flow("chain-cubic01-disp-random-delay", delay=delay)
    d = flow.delay
    assert d is not None and abs(d.samples - (delay + offset)) <= d.resolution < 0.01
    assert (d.misfit_before[0] <= d.limit) == held


@pytest.mark.parametrize("delay", [0.5, -0.3, 1.7])
def test_line_by_line_reading_ignores_the_resonances(delay):
    """A pure delay on 400 lines x 3 DOFs with 1 % noise, and a phase error of 0.3 rad on the
    40 lines of two resonances (a start model's error, a plant's): the median reads the
    delay, its interval holds it; a mean of the lines would miss it."""
    rng = np.random.default_rng(4)
    fs, freqs = 256.0, np.linspace(2.0, 60.0, 400)
    ratio = np.exp(-2j * np.pi * freqs * delay / fs)[:, None, None] * np.ones((1, 3, 1))
    ratio = ratio * (1 + 0.01 * (rng.standard_normal(ratio.shape)
                                 + 1j * rng.standard_normal(ratio.shape)))
    ratio[100:120] *= np.exp(-0.3j)
    ratio[300:320] *= np.exp(0.3j * np.sign(delay))
    p = Prepared(np.zeros((8, 3)), np.zeros((8, 3)), np.zeros((8, 1)), np.array([0]), fs, 1.0,
                 None, "level 1")
    got, half = _line_delay(p, lambda _: (freqs, ratio, 1.5), int(round(delay)))
    assert abs(got - delay) <= half < 0.01
    lines = -np.angle(ratio * np.exp(2j * np.pi * freqs * round(delay) / fs)[:, None, None])
    mean = round(delay) + np.mean(lines * fs / (2 * np.pi * freqs[:, None, None]))
    assert abs(mean - delay) > half


def test_fractional_shift_of_a_periodic_record_is_exact():
    """Band-limited motion moved by a fraction of a sample, period by period: the same
    waves a fraction later, to rounding."""
    period, n_per = 64, 3
    t = np.arange(period * n_per)
    wave = lambda s: np.column_stack([np.sin(2 * np.pi * 3 * s / period),
                                      np.cos(2 * np.pi * 5 * s / period)])
    p = Prepared(wave(t), wave(t), np.ones((t.size, 1)), np.array([0]), 64.0, 1.0, period,
                 "level 1")
    np.testing.assert_allclose(shifted(p, 0.4).x, wave(t + 0.4), atol=1e-12)
    r = shifted(replace(p, period=None, x=np.tile(wave(t[:period]), (8, 1)),
                        v=np.tile(wave(t[:period]), (8, 1)),
                        force=np.ones((8 * period, 1))), 0.4)
    edge = 33                                     # `FRACTION_EDGE` + the whole sample
    np.testing.assert_allclose(r.x, wave(np.arange(edge, 8 * period - edge) + 0.4), atol=1e-9)


def test_no_delay_where_the_start_model_holds():
    assert _flow("sdof-none-disp-random").delay is None


def test_no_delay_on_a_slider_at_the_lowest_level():
    """A Jenkins element acting at every level: a one-sample lead lowers the start model's
    misfit at every level (a phase like the slider's dissipation), but leaves the lowest far
    outside its floor, so no delay is read."""
    flow = _flow("sdof-jenkins-disp-random")
    assert flow.delay is None
    before = [_misfit(flow.model, p, flow.band, flow.nps, FLOOR) for p in flow.preps]
    after = [_misfit(flow.model, shifted(p, -1), flow.band, flow.nps, FLOOR)
             for p in flow.preps]
    assert all(a[0] < b[0] - b[1].noise for a, b in zip(after, before))
    assert min(a[0] / a[1].limit for a in after) > 10


def test_shift_of_a_periodic_record_is_exact():
    period, n_per, fs = 64, 3, 64.0
    t = np.arange(period * n_per)
    wave = lambda s: np.column_stack([np.sin(2 * np.pi * 3 * s / period),
                                      np.cos(2 * np.pi * 5 * s / period)])
    p = Prepared(wave(t), 2 * wave(t), np.ones((t.size, 1)), np.array([0]), fs, 1.0, period,
                 "level 1")
    for d in (1, -2):
        q = shifted(p, d)
        np.testing.assert_allclose(q.x, wave(t + d), atol=1e-12)
        np.testing.assert_allclose(q.v, 2 * wave(t + d), atol=1e-12)
        assert q.force is p.force
    r = shifted(replace(p, period=None), 2)                       # random: two samples fewer
    np.testing.assert_array_equal(r.x, p.x[2:])
    assert r.force.shape[0] == r.x.shape[0] == t.size - 2


def test_delay_in_the_evidence_json():
    d = ResponseDelay(1, "level 1", "level 4", (0.31, 0.26), (0.076, 0.16), 0.106, 0.064)
    data = Evidence(response_delay=d).to_json()
    assert data["response_delay"]["samples"] == 1
    assert Evidence.from_json(data).response_delay == d
    assert "response_delay" not in Evidence().to_json()             # goldens: not written
