"""Reverse path / NIFO estimation of nonlinear coefficients from random and multisine data
(paper chapter 3), with its sensor-noise treatment, sequential refinement, residual-force
linear FRF and candidate screening.

Modules behind this API: ``_core`` (records, channels, the conditioned-input estimate and its
intervals), ``_estimator`` (the entry point), ``_noise`` (noise floor), ``_iv``
(instrumental variables), ``_periodic``/``_periodic_lines`` (period averaging), ``_low_band``
(the integrated displacement's lowest band from the model), ``_stages`` (sequential
refinement), ``_linear`` (residual-force FRF), ``_screening`` (ranking candidate terms).
"""

from ._core import Z95, Coefficient, ReversePathResult
from ._estimator import ReversePathOptions, reverse_path
from ._linear import residual_force_frf
from ._noise import noise_floor
from ._screening import ScreeningResult, screen_candidates
from ._stages import sequential

__all__ = ["Coefficient", "ReversePathOptions", "ReversePathResult", "ScreeningResult", "Z95",
           "noise_floor", "residual_force_frf", "reverse_path", "screen_candidates",
           "sequential"]
