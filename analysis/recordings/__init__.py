"""What a measurement is: a recording of one level, its sensor map, the law of its sweep (given
or estimated from the force), its period when a file names none, response kinds and their
conversion (integration, differentiation, bands, hold images), stepped-sine tables (phasors
per step).

Modules behind this API: ``_recording``, ``_keys`` (a recording file's keys), ``_sensors``,
``_signals``, ``_sweep_law``, ``_sweep_estimate``, ``_periodicity``, ``_bursts`` (realizations recorded between quiet gaps), ``_level`` (a recording's
level), ``_table``, ``_daq_artifacts`` (what a real DAQ export adds, for simulated twins), ``_cleaning``
(an export's padding dropped and its period found, as ``nlid-lab import`` does),
``_clipping`` (clipped samples: a channel held at its range, the caveat every command prints).
Code inside this package imports its siblings by their private module path.
"""

from ._recording import (CHANNEL_UNITS, DEFAULT_TRANSIENT_PERIODS, EXCITATIONS, FORCE_HOLDS, MAX_FS, MAX_SAMPLE,
                         MIN_FS, Excitation, PeriodicLayout, RESPONSE_KINDS, Recording,
                         ResponseKind)
from ._keys import RecordingKeys
from ._sensors import (KEYS, MIXED, SensorMap, at_points, channel_labels, model_at_sensors, names,
                       one_kind, sensor_map, table_keys)
from ._signals import (HOLD_IMAGE_LOOKAHEAD, KIND_ORDER, change_kind, excitation_band,
                       flat_ends, hold_image_gain, hold_image_response, hold_image_taps,
                       hold_images, period_spectra, periodic_kinematics, remove_dc,
                       remove_hold_images, signal_bandwidth, steady_periods, to_kinematics)
from ._sweep_law import LAW_KEYS, SWEEP_KEYS, SWEEP_LAWS, Sweep, SweepLaw
from ._sweep_estimate import active_span, estimate_sweep, looks_like_sweep
from ._periodicity import SHARE_MIN, find_period, whole_periods
from ._bursts import Bursts, find_bursts
from ._cleaning import CleanedExport, clean_export
from ._clipping import ClippedChannel, ClippingCaveat, clipping, recording_clipping
from ._level import measured_level, record_level
from ._table import STEP_TABLE_KEYS, Control, StepTable
from ._daq_artifacts import (ARTIFACTS, Artifact, DaqArtifacts, Shaker, apply_daq_artifacts,
                             shaker_force)

__all__ = ["active_span", "CHANNEL_UNITS", "apply_daq_artifacts", "Artifact", "ARTIFACTS", "at_points", "Bursts",
           "change_kind", "channel_labels", "clean_export", "CleanedExport", "ClippedChannel", "ClippingCaveat", "clipping", "Control", "DaqArtifacts", "DEFAULT_TRANSIENT_PERIODS",
           "estimate_sweep", "Excitation", "excitation_band", "EXCITATIONS", "find_bursts", "find_period", "flat_ends",
           "FORCE_HOLDS", "hold_image_gain", "HOLD_IMAGE_LOOKAHEAD", "hold_image_response",
           "hold_image_taps", "hold_images", "KEYS", "KIND_ORDER", "LAW_KEYS", "looks_like_sweep", "MAX_FS",
           "MAX_SAMPLE", "measured_level", "MIN_FS", "MIXED", "model_at_sensors", "names",
           "one_kind", "period_spectra", "periodic_kinematics", "PeriodicLayout", "record_level", "recording_clipping",
           "Recording", "RecordingKeys", "remove_dc", "remove_hold_images", "RESPONSE_KINDS",
           "ResponseKind",
           "sensor_map", "SensorMap", "Shaker", "shaker_force", "SHARE_MIN", "signal_bandwidth",
           "steady_periods", "STEP_TABLE_KEYS", "StepTable", "Sweep", "SWEEP_KEYS", "SWEEP_LAWS",
           "SweepLaw", "table_keys", "to_kinematics", "whole_periods"]
