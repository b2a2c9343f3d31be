"""Harmonic balance: the balance equations with their AFT loop, arc-length continuation through
folds, and the fit of element parameters to stepped-sine FRFs.

Modules behind this API: ``_hbm``, ``_aft``, ``_held`` (a held response amplitude, the
force unknown), ``_continuation``, ``_hbm_fit``. Code inside this
package imports its siblings by their private module path.
"""

from ._hbm import HBMError, HBMSystem, loop, parse_harmonics
from ._aft import aft_tables, periodic_forces
from ._held import sweep_held
from ._continuation import Branch, continue_frf, response_curves
from ._hbm_fit import FitResult, HBMFit, MeasuredReceptance, fit_hbm

__all__ = ["Branch", "FitResult", "HBMError", "HBMFit", "HBMSystem", "MeasuredReceptance",
           "aft_tables", "continue_frf", "fit_hbm", "loop", "parse_harmonics", "periodic_forces",
           "response_curves", "sweep_held"]
