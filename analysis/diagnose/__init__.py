"""Model-mismatch diagnosis: locate the mismatch, name the missing physics, model it.

`diagnose(model, recordings)` compares the model with recordings at several levels, tests
whether the structure behaves nonlinearly (homogeneity across levels), searches the one
candidate library (`analysis.models.library`: nonlinear elements and linear errors at every DOF
and DOF pair) by information criterion, estimates the chosen candidate's parameters (reverse
path for random data, harmonic-balance fit for stepped sine), searches again on the corrected
model for a further effect (accepted ones are refitted jointly) and shows the improvement on
a recording held back from fitting: FRFs per level and time residuals of replays of the
measured force (`_replay`). The stages are one engine for random and stepped-sine data
(`_engine`); the result is typed (`Diagnosis`, ``to_json`` / ``from_json``). See
docs/diagnose.md.
"""

from ._alignment import ResponseDelay
from ._prepare import DiagnoseInputError, level_name
from ._evidence import Evidence, LocationRow, Misfit, PairThrough, PassSummary, Rejection
from ._result import (RESULT_NAME, SCHEMA_VERSION, Alternative, CandidateFit, Diagnosis,
                      FitSummary, KindAlternative, KindSeparation, LevelError, LevelResiduals,
                      Location, TimeResidual, Verdict)
from ._search import diagnose

__all__ = [
    # entry point and input errors
    "diagnose", "DiagnoseInputError",
    # a level as the diagnosis names it (``level 30``, else its measured force)
    "level_name",
    # the result (frozen dataclasses; Diagnosis.to_json / from_json)
    "Diagnosis", "SCHEMA_VERSION", "RESULT_NAME", "Verdict", "Location", "Alternative", "CandidateFit",
    "KindAlternative", "KindSeparation",
    "FitSummary", "LevelError", "TimeResidual", "Evidence", "PassSummary", "Rejection",
    "LocationRow", "PairThrough", "Misfit", "LevelResiduals", "ResponseDelay",
]
