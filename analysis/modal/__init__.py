"""Modal analysis: modal parameters of FRF columns, experimental modal analysis (LSCF,
refinement, MAC) and the linear modal fit of a measured level.

Modules behind this API: ``_modal``, ``_ema``, ``_linear_fit``, ``_fit_result`` (fit-linear's
typed result and its JSON), ``_delay`` (the responses' delay behind the force). Code inside
this package imports its siblings by their private module path.
"""

from ._modal import modal_fit, modal_summary, welch_smoothing
from ._ema import fit_modes, mac
from ._delay import DelayReading, response_delay
from ._linear_fit import LinearFit, fit_linear, measured_receptance, model_error
from ._fit_result import LinearFitSummary, ModalMode, ModalSummary, ModeSummary

__all__ = ["DelayReading", "LinearFit", "LinearFitSummary", "ModalMode", "ModalSummary", "ModeSummary", "fit_linear", "fit_modes", "mac",
           "measured_receptance", "modal_fit", "modal_summary", "model_error", "response_delay",
           "welch_smoothing"]
