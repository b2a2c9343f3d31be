"""Recordings in and out of files: NPZ/CSV/MAT recordings, the sweep keys of a file, channel
units, FE modes from UFF, stepped-sine tables (phasors per step) and controller exports of them.

Modules behind this API: ``_recordings_io``, ``_monitors``, ``_sensor_files``, ``_drives``,
``_mat_io``, ``_mat_recording``, ``_sweep_keys``, ``_units``, ``_fe_modes``, ``_tables``. Code inside this package imports its siblings by their private
module path.
"""

from ._recordings_io import load_recordings, write_npz
from ._drives import read_drive
from ._mat_io import ChannelMap, apply_map, read_mat_tree
from ._mat_recording import read_mat_recording, write_mat
from ._sweep_keys import describe, parse_sweep_option
from ._units import G0, split_label
from ._tables import TableMap
from ._fe_modes import FEModes, parse_point, read_modes, to_model

__all__ = ["ChannelMap", "FEModes", "G0", "apply_map", "describe", "load_recordings", "parse_point",
           "parse_sweep_option", "read_drive", "read_mat_recording", "read_mat_tree", "read_modes", "split_label", "TableMap",
           "to_model", "write_mat", "write_npz"]
