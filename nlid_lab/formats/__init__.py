"""Recordings in and out of files: NPZ/CSV/MAT recordings, the sweep keys of a file, channel
units, FE modes from UFF, stepped-sine tables (phasors per step) and controller exports of them.

Modules behind this API: ``_recording_keys`` (a file's keys and their checks), ``_npz``,
``_csv`` (with ``_csv_text`` and ``_csv_header``), ``_formats`` (the formats by suffix:
`FORMATS`), ``_load`` (any file by suffix), ``_monitors``, ``_sensor_files``, ``_drives``,
``_mat_io``, ``_mat_recording``, ``_sweep_keys``, ``_units``, ``_fe_modes``, ``_tables``. Code
inside this package imports its siblings by their private module path.
"""

from ._recording_keys import LAYOUT_KEYS, RecordingFileError
from ._npz import load_npz_keys, read_npz, recording_from_keys, recording_keys, write_npz
from ._csv import read_csv, read_csv_columns, write_csv
from ._formats import (FORMATS, ReadOptions, RecordingFormat, format_of, register_format,
                       suffix_list, unregister_format)
from ._load import load_recordings
from ._sensor_files import read_sensors, with_sensors
from ._drives import Drive, read_drive
from ._mat_io import ChannelMap, apply_map, read_mat_tree
from ._mat_recording import is_recording, read_mat_recording, write_mat
from ._sweep_keys import SweepOption, describe, parse_sweep_option
from ._units import G0, split_label
from ._tables import TableMap
from ._fe_modes import FEModes, parse_point, read_modes, to_model

__all__ = [
    # the formats by suffix
    "FORMATS", "ReadOptions", "RecordingFormat", "format_of", "register_format", "suffix_list",
    "unregister_format", "load_recordings",
    # recordings, maps and tables
    "ChannelMap", "Drive", "FEModes", "G0", "LAYOUT_KEYS", "RecordingFileError", "SweepOption",
    "TableMap", "apply_map", "describe", "is_recording", "load_npz_keys", "parse_point",
    "parse_sweep_option", "read_csv", "read_csv_columns", "read_drive", "read_mat_recording",
    "read_mat_tree", "read_modes", "read_npz", "read_sensors", "recording_from_keys",
    "recording_keys", "split_label", "to_model", "with_sensors", "write_csv", "write_mat",
    "write_npz"]
