"""Names of the dictionaries that are honestly dictionaries: documents at the edge.

Results and contracts between layers are frozen dataclasses; what stays a ``dict`` is a
document a serialiser reads or writes, whose keys the file's author (or a user) chooses:

- `JsonObject`: a JSON object at the CLI and store edge (``to_json`` / ``from_json``).
- `TomlTable`: a table as `tomllib` reads it (model, campaign and fault files).
- `MatTree`: a MAT file's variables as read, struct fields flattened to ``"a.b"`` names.
- `UffDataset`: one dataset as `pyuff` reads and writes it (dataset 58, 55, 15, 82, ...).

Where a dict has a schema, a `TypedDict` names its keys once, beside the code that writes it:
the keys of a recording file (NPZ, CSV header, a mapped MAT file),
`analysis.recordings.RecordingKeys`; a model file's tables, `analysis.models.ModelTables`; a
plant's saved state, `analysis.plant.SavedState`; what the reverse path writes into its JSON
(``noise``: ``NoiseInfo``, the screening's ranking: ``ScreeningRow``) and the Welch settings
its passes share (``WelchSettings``), in ``analysis/reverse_path/_documents.py``.
"""

from __future__ import annotations

from typing import Any

#: a JSON object at the CLI and store edge
JsonObject = dict[str, Any]
#: a TOML table as `tomllib` reads it
TomlTable = dict[str, Any]
#: a MAT file's variables as read (``scipy.io.loadmat`` / HDF5), struct fields as ``"a.b"``
MatTree = dict[str, Any]
#: one dataset of a universal file as `pyuff` reads and writes it
UffDataset = dict[str, Any]
