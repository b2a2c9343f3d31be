"""Model-mismatch diagnosis: locate the mismatch, name the missing physics, model it.

`diagnose(model, recordings)` compares the model with recordings at several levels, tests
whether the structure behaves nonlinearly (homogeneity across levels), searches the one
candidate library (`candidates.library`: nonlinear elements and linear errors at every DOF
and DOF pair) by information criterion, estimates the chosen candidate's parameters (reverse
path for random data, harmonic-balance fit for stepped sine), searches again on the corrected
model for a further effect (accepted ones are refitted jointly) and shows the improvement on
a recording held back from fitting: FRFs per level and time residuals of replays of the
measured force (`replay`). See docs/diagnose.md.
"""

from .candidates import Candidate, library
from .prepare import DiagnoseInputError
from .report import Diagnosis
from .search import diagnose

__all__ = ["diagnose", "Diagnosis", "Candidate", "library", "DiagnoseInputError"]
