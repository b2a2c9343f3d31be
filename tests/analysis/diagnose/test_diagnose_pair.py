"""The held pair (`analysis.diagnose._policy.held_pair`): a best first effect rejected only on
the worst-level check is re-judged with the library held in; any other loss keeps today's
verdict. The accepted pair itself is the zoo row ``chain-mass1+cubic01-disp-random-z7``
(`test_diagnose_zoo.py`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from analysis.diagnose._outofsample import Z as OOS_Z, Score
from analysis.diagnose._policy import held_pair
from analysis.diagnose._select import Fit
from analysis.models import Candidate


def _fit(kind: str, dofs: tuple[int, ...]) -> Fit:
    return Fit(Candidate(kind, dofs, 2), {"p": 1.0}, {"p": [0.5, 1.5]}, 0.0, 100.0)


HARMED = Score(100.0, 1.0, (-50.0, 80.0), (5.0, 5.0), True)
"""Gain 100 deviations, level 0 predicted worse by 10 of its deviations."""


@pytest.mark.parametrize("kind, s", [
    ("mass_error", Score(100.0, 1.0, (40.0, 80.0), (5.0, 5.0), True)),    # wins: no harm
    ("mass_error", Score(3.0, 1.0, (-50.0, 80.0), (5.0, 5.0), True)),     # gain not beyond
    ("mass_error", Score(100.0, 1.0, (-50.0, 80.0), (5.0, 5.0), False)),  # holds zero
    ("mass_error", Score(100.0, 1.0, (-50.0, 80.0), (5.0, 5.0), True, left=200.0)),
    ("cubic_spring", HARMED),                    # nonlinear: the search's model lacks it
])
def test_only_a_worst_level_loss_is_rejudged(kind, s):
    assert s.gain < OOS_Z * s.deviation or s.gain <= s.left or not s.distinct \
        or s.harmed is None or kind != "mass_error"
    # search None: the rule must decide before judging anything
    assert held_pair(None, None, [(_fit(kind, (1,)), s)], 1.0) is None


def test_no_second_winner_keeps_the_verdict():
    assert HARMED.harmed == 0 and HARMED.gain > OOS_Z * HARMED.deviation
    search = SimpleNamespace(H0s=[np.zeros(3)])
    lead = _fit("mass_error", (1,))
    # the only other candidate is the lead's own kind and location: nothing is re-judged
    assert held_pair(None, search, [(lead, HARMED), (_fit("mass_error", (1,)), HARMED)],
                     1.0) is None
