"""What a measurement is: a recording of one level, its sensor map, the law of its sweep (given
or estimated from the force), its period when a file names none, response kinds and their
conversion (integration, differentiation, bands, hold images), stepped-sine tables (phasors
per step).

Modules behind this API: ``_recording``, ``_sensors``, ``_signals``, ``_sweep_law``,
``_sweep_estimate``, ``_periodicity``, ``_table``, ``_daq_artifacts`` (what a real DAQ export
adds, for simulated twins). Code inside this package imports its siblings by their
private module path.
"""

from ._recording import (DEFAULT_TRANSIENT_PERIODS, EXCITATIONS, FORCE_HOLDS, MAX_FS, MAX_SAMPLE,
                         MIN_FS, PeriodicLayout, RESPONSE_KINDS, Recording)
from ._sensors import (KEYS, MIXED, SensorMap, at_points, channel_labels, model_at_sensors, names,
                       one_kind, sensor_map, table_keys)
from ._signals import (HOLD_IMAGE_LOOKAHEAD, KIND_ORDER, change_kind, excitation_band,
                       flat_ends, hold_image_gain, hold_image_response, hold_image_taps,
                       hold_images, period_spectra, periodic_kinematics, remove_dc,
                       remove_hold_images, signal_bandwidth, steady_periods, to_kinematics)
from ._sweep_law import LAW_KEYS, SWEEP_KEYS, SWEEP_LAWS, Sweep, SweepLaw
from ._sweep_estimate import active_span, estimate_sweep
from ._periodicity import SHARE_MIN, find_period, whole_periods
from ._table import STEP_TABLE_KEYS, Control, StepTable
from ._daq_artifacts import (ARTIFACTS, Artifact, DaqArtifacts, Shaker, apply_daq_artifacts,
                             shaker_force)

__all__ = ["ARTIFACTS", "Artifact", "DaqArtifacts", "Shaker", "apply_daq_artifacts",
           "shaker_force", "Control", "StepTable", "STEP_TABLE_KEYS", "DEFAULT_TRANSIENT_PERIODS", "EXCITATIONS", "FORCE_HOLDS", "HOLD_IMAGE_LOOKAHEAD",
           "KEYS", "KIND_ORDER", "LAW_KEYS", "MAX_FS", "MAX_SAMPLE", "MIN_FS", "MIXED",
           "PeriodicLayout", "RESPONSE_KINDS", "Recording", "SHARE_MIN", "SWEEP_KEYS", "SWEEP_LAWS",
           "SensorMap", "Sweep", "SweepLaw", "active_span", "at_points", "change_kind",
           "channel_labels", "estimate_sweep", "excitation_band", "find_period", "flat_ends", "hold_image_gain",
           "hold_image_response", "hold_image_taps", "hold_images", "model_at_sensors", "names",
           "one_kind", "period_spectra", "periodic_kinematics", "remove_dc", "remove_hold_images",
           "sensor_map", "signal_bandwidth", "steady_periods", "table_keys", "to_kinematics", "whole_periods"]
