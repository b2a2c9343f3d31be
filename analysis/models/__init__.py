"""What a structure is: model files, element kinds (one descriptor each) and their numba laws,
the reverse-path basis functions of a kind, the candidate library (locations x kinds) that the
diagnosis searches and reverse-path screening locates, bounded text reading.

Modules behind this API: ``_model`` (the `Model`), ``_element`` (`Element`), ``_support``
(`Support`), ``_receptance`` (the linear part's FRF), ``_model_checks`` (physics checked on
construction), ``_model_toml`` (the file's tables and text), ``_model_file`` (TOML values,
element placement), ``_model_tables`` (validated tables and bounds), ``_kinds``, ``_elements``,
``_memory_series`` (a memory law along a long series, its state in registers), ``_basis``,
``_candidates``, ``_textfile``. Code inside this package imports its siblings by their
private module path.
"""

from ._element import Element
from ._model import Model
from ._model_toml import ModelTables
from ._support import Support
from ._model_tables import MAX_DOF, MAX_ELEMENTS, MAX_ENTRY, MAX_PARAM
from ._kinds import KINDS, Kind, Param, Refs, coefficient_units, lookup, search_order
from ._elements import (N_BUILTIN, N_PARAM, N_STATE, element_force, element_tangent,
                        memoryless_force, pack_params, register_kind, restoring_force,
                        unregister_kind)
from ._memory_series import memory_force_series
from ._basis import (FAMILIES, LIBRARY, Basis, alias_error, aliasing_factor, deformation,
                     element_basis, evaluate)
from ._candidates import (LINEAR_KINDS, LINEAR_PARAM, Candidate, grounded_allowed, library,
                          locations)
from ._textfile import MAX_TOML_BYTES, MAX_TOML_DEPTH, parse_toml, read_text, unknown_keys

__all__ = ["alias_error", "aliasing_factor", "Basis", "Candidate", "coefficient_units", "deformation",
           "Element", "element_basis", "element_force", "element_tangent", "evaluate", "FAMILIES",
           "grounded_allowed", "Kind", "KINDS", "LIBRARY", "library", "LINEAR_KINDS", "LINEAR_PARAM",
           "locations", "lookup", "MAX_DOF", "MAX_ELEMENTS", "MAX_ENTRY", "ModelTables",
           "MAX_PARAM", "MAX_TOML_BYTES", "MAX_TOML_DEPTH", "memory_force_series",
           "memoryless_force", "Model",
           "N_BUILTIN", "N_PARAM", "N_STATE", "pack_params", "Param", "parse_toml", "read_text",
           "Refs", "register_kind", "restoring_force", "search_order", "Support", "unknown_keys",
           "unregister_kind"]
