"""An export made ready as ``nlid-lab import`` would (`analysis.recordings.clean_export`): the
catalogue's zeros and partial period (`apply_daq_artifacts`) taken out exactly, the layout
found again; random and laid-out records left as they are."""

import numpy as np

from analysis.plant import multisine, periodic
from analysis.recordings import (DaqArtifacts, PeriodicLayout, Recording, apply_daq_artifacts,
                                 clean_export)

FS, N = 256.0, 512


def _multisine(periods: int = 6) -> Recording:
    rng = np.random.default_rng(0)
    f = periodic(multisine(N, FS, (2.0, 60.0), 1.0, seed=3), periods)[:, None]
    x = np.column_stack([np.roll(f[:, 0], 3), np.roll(f[:, 0], 7)])      # periodic responses
    x = x + 1e-3 * rng.standard_normal(x.shape)
    return Recording(FS, "random", [0], f, x, layout=PeriodicLayout(N, 0, periods, 1))


def test_zeros_and_a_partial_period_are_taken_out_and_the_layout_found():
    clean = _multisine()
    spec = DaqArtifacts.of(["zeros", "partial-period"], FS)
    dirty = apply_daq_artifacts(clean, spec, np.random.default_rng(1))
    assert dirty.layout is None
    out = clean_export(dirty)
    assert (out.lead_in, out.trailing) == (spec.lead_in, spec.trailing)
    assert out.layout_found
    lay = out.recording.layout
    assert (lay.period, lay.transient_periods + lay.periods, lay.realizations) == (N, 5, 1)
    assert np.array_equal(out.recording.force, clean.force[:5 * N])      # the sixth was cut
    assert np.array_equal(out.recording.response, clean.response[:5 * N])
    notes = out.notes("level 1")
    assert len(notes) == 2 and "128 lead-in and 128 trailing" in notes[0]
    assert "512-sample period" in notes[1]


def test_random_and_laid_out_records_are_left_as_they_are():
    clean = _multisine()
    assert clean_export(clean).recording is clean                      # a layout: as given
    rng = np.random.default_rng(2)
    f = rng.standard_normal((4096, 1))
    rec = Recording(FS, "random", [0], f, np.cumsum(f, axis=0))
    out = clean_export(rec)
    assert out.recording is rec and not out.layout_found and out.notes("x") == []
    padded = Recording(FS, "random", [0], np.vstack([np.zeros((100, 1)), f]),
                       np.vstack([np.zeros((100, 1)), np.cumsum(f, axis=0)]))
    cut = clean_export(padded)
    assert (cut.lead_in, cut.trailing) == (100, 0) and not cut.layout_found
    assert np.array_equal(cut.recording.force, f)
