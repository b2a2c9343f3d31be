"""What `fit-linear` says of the responses' delay behind the force (issue #23): the delay
stated to the resolution its 95 % interval gives, the interval, the importer's
``response_delay=`` for a whole or fractional delay the interval separates from 0, and JSON
keys only added (``delay_samples`` kept)."""

from __future__ import annotations

import contextlib
import io
import json
import sys
from pathlib import Path

import pytest

from analysis.modal import DelayReading, LinearFitSummary
from nlid_lab.cli import main
from nlid_lab.commands.fit_linear import _delay_said
from nlid_lab.formats import write_npz

sys.path.append(str(Path(__file__).resolve().parents[1] / "analysis" / "modal"))
from test_delay import _twin  # noqa: E402


@pytest.mark.parametrize("reading, said", [
    (DelayReading(1.0321, 0.97, 1.06), "lag the force by 1 sample (95 % interval 0.97 to 1.06;"),
    (DelayReading(0.498, 0.4935, 0.5026), "lag the force by 0.5 samples (95 % interval 0.49 "
                                          "to 0.50;"),
    (DelayReading(-1.4449, -1.4460, -1.4437), "lead the force by 1.445 samples (95 % interval "
                                              "-1.4460 to -1.4437;")])
def test_delay_said_to_its_resolution_with_the_importer_entry(reading, said):
    text = _delay_said(reading)
    assert said in text
    assert text.endswith(f"import it again with response_delay={reading.stated:g} in the "
                         "--map first")


def test_no_delay_said_when_none_was_read():
    assert _delay_said(DelayReading()) == ""


def test_cli_names_a_half_sample_delay_and_its_entry(tmp_path):
    """The twin 0.5 sample late through the command: summary line and JSON."""
    write_npz(tmp_path / "run.npz", _twin(0.5, 1))
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["fit-linear", str(tmp_path / "run.npz"), "--out", str(tmp_path / "l.toml"),
                     "--json", str(tmp_path / "l.json")])
    assert code == 0, err.getvalue()
    data = json.loads((tmp_path / "l.json").read_text())
    low, high = data["delay_interval_samples"]
    assert low <= data["delay_samples"] <= high and low <= 0.5 <= high
    assert data["delay_stated_samples"] == 0.5
    first = out.getvalue().splitlines()[0]
    assert "lag the force by 0.5 samples (95 % interval" in first
    assert first.endswith("import it again with response_delay=0.5 in the --map first")
    data.pop("data_checks")                                    # the CLI's, not the fit's
    assert LinearFitSummary.from_json(data).to_json() == data
