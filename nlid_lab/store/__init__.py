"""HDF5 run store: one file per run, schema in docs/run-format.md (the only h5py importer).

Crash safety: after its header is built (in a temporary file renamed into place) a run file
is only ever modified in HDF5 SWMR mode, and each block is written data first, flushed, then
indexed in ``/segments`` and flushed again. SWMR orders metadata writes so that the file on
disk is always readable, hence a writer killed at any moment (SIGKILL included) leaves a file
holding every block whose index row was flushed. Such a file still carries the "open by a
SWMR writer" superblock flag: `open_run` reads it in SWMR mode (``Run.left_open``), and
``mode="resume"`` or `repair_run` (``nlid-lab repair``) rebuilds it into a clean file (temporary
file + atomic rename) that any HDF5 tool opens. Appending opens a file directly in SWMR-write
mode, and a writer holds a shared advisory lock on its file so that a repair never touches a
file a live process writes. A writer killed while the header is being built (before its first
block) leaves no run file, only ``RUN.h5.tmp``: nothing was recorded yet.

Modules: `writer` (RunWriter, LevelWriter), `reader` (open_run, Run, whole-recording helpers),
`tables` (result tables of reanalysis), `_estimates` (the elements of a stored estimate,
typed), `_verified` (the samples a check read, kept for
the read that follows), `_common` (schema constants and HDF5 helpers).
"""

from ._common import SCHEMA_VERSION, STATUSES, StoreError, utc_now
from ._reader import (DamagedRunError, Level, Run, check_result_target, open_run,
                     repair_run, save_recording, save_result)
from ._integrity import LeftOut, LeftOutReason, Repaired, RunCheck, left_out_text
from ._space import DiskFullError, require_room
from ._verified import release_checked
from ._tables import TableError, TableRow, read_table, write_table
from ._estimates import EstimatedElement, elements_from_json
from ._mat73 import read_mat73
from ._writer import LevelWriter, RunWriter

__all__ = [
    "SCHEMA_VERSION", "STATUSES", "StoreError", "utc_now", "DiskFullError", "require_room",
    "DamagedRunError", "LeftOut", "LeftOutReason", "Repaired", "RunCheck",
    "left_out_text", "release_checked",
    "Level", "Run", "check_result_target", "open_run", "repair_run", "save_recording",
    "save_result",
    "TableError", "TableRow", "read_table", "write_table",
    "EstimatedElement", "elements_from_json",
    "read_mat73",
    "LevelWriter", "RunWriter",
]
