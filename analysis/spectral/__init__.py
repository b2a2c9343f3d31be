"""Spectra and FRFs of a level: Welch spectral matrices and H1, level FRFs, best linear
approximation, stepped-sine fits, swept-sine FRFs.

Modules behind this API: ``_spectral``, ``_frf``, ``_resolution``, ``_bla``, ``_lines`` (the
excited lines of a periodic drive, interference left out), ``_sine_fit``, ``_sweep``. Code
inside this package imports its siblings by their private module path.
"""

from ._spectral import (Spectra, conditioned_inputs, h1, multiple_coherence, ordinary_coherence,
                        spectral_matrix)
from ._frf import (FRF_UNITS, HELD_UNITS, LevelFRF, convert_frf, default_nperseg, frf_from_bla,
                   frf_from_spectra, level_frf, level_label, level_name)
from ._resolution import (LINES_PER_BANDWIDTH, Resolution,
                          longest_nperseg, narrowest_peak, pole_resolution,
                          resolving_nperseg)
from ._bla import BLA, DETECT_QUANTILE, best_linear_approximation
from ._lines import ExcitedLines, Interference, MainsCaveat, excited_lines
from ._sine_fit import (SETTLE_TOL, SteppedSineFRF, hold_gain, recording_table, sine_fit, steady_start,
                        stepped_sine_frf, table_harmonics)
from ._sweep import (NOISE_ORDERS, SweepFRF, SweepLaw, harmonic_distortion, independent_windows,
                     linear_modes,
                     max_sweep_rate, quasi_steady, recording_sweep_frf, sweep_frf, sweep_rate_check,
                     sweep_signal)

__all__ = ["best_linear_approximation", "BLA", "conditioned_inputs", "convert_frf",
           "default_nperseg", "DETECT_QUANTILE", "excited_lines", "ExcitedLines", "frf_from_bla",
           "frf_from_spectra", "FRF_UNITS", "h1", "harmonic_distortion", "HELD_UNITS", "hold_gain",
           "independent_windows", "Interference", "level_frf", "level_label", "level_name",
           "MainsCaveat", "SETTLE_TOL",
           "LevelFRF", "linear_modes", "LINES_PER_BANDWIDTH", "longest_nperseg", "max_sweep_rate",
           "multiple_coherence", "narrowest_peak", "NOISE_ORDERS", "pole_resolution", "ordinary_coherence",
           "quasi_steady", "recording_sweep_frf", "recording_table", "Resolution",
           "resolving_nperseg", "sine_fit", "Spectra", "spectral_matrix", "steady_start",
           "stepped_sine_frf",
           "SteppedSineFRF", "sweep_frf", "sweep_rate_check", "sweep_signal", "SweepFRF",
           "SweepLaw", "table_harmonics"]
