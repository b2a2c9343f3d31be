"""The report's modal-fit section says what fit-linear said (issue #23): the responses' delay
taken out of the FRF and the mains caveat of a single realization, in fit-linear's phrases
(`analysis.spectral.MainsCaveat`); neither when the run carries neither."""

from __future__ import annotations

import html
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.append(str(ROOT / "tests"))
import daq_twin as T  # noqa: E402
from analysis.modal import fit_linear  # noqa: E402
from analysis.recordings import DaqArtifacts, apply_daq_artifacts  # noqa: E402
from nlid_lab.reports import RunData, modal_fit_section  # noqa: E402


@pytest.mark.parametrize("realizations, delay", [(1, 1), (3, 0)])
def test_modal_fit_section_says_the_delay_and_the_caveat(realizations, delay):
    (rec,) = T.clean_levels(levels=T.LEVELS[:1], periods=3, realizations=realizations)
    if delay:
        rec = apply_daq_artifacts(rec, DaqArtifacts(delay=delay), np.random.default_rng(0))
    fit = fit_linear(rec)                                   # what the section runs
    text = modal_fit_section(RunData(Path("twin.h5"), [rec])).text
    said_delay = "The responses lag the force by" in text
    assert said_delay == bool(delay) == bool(fit.delay_samples)
    if delay:
        said = html.escape(fit.delay.text()[len("the responses "):])
        assert said in text                                 # as fit-linear says it
        assert abs(fit.delay_samples - delay) < 0.05
    caveat = fit.data.caveat
    assert (caveat is not None) == (realizations == 1)
    assert ("Caveat: " in text) == (caveat is not None)
    if caveat is not None:
        assert f"Caveat: {html.escape(caveat.text())}." in text
