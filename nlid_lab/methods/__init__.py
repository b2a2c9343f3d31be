"""Estimators known to `analyze`, `reanalyze`, `report` and `view`: the method registry.

`_registry` defines `Method` and the look-ups; each further module defines one method and
registers it on import. A new estimator is one new module here and no other edit: the
built-in methods are imported first, in order (``reanalyze --method auto`` takes the first
method of a level's excitation), then `discover` imports every other module of this package.
"""

from __future__ import annotations

from ._registry import (ESTIMATOR_KEY, BatchOptions, Estimate, LevelEstimate, Method,
                       StoredEstimate, StoredResult, add_batch_options, add_options,
                       batch_values, discover, find_stored, for_excitation, get, methods,
                       option, register, stored_estimates, unregister)
from . import _reverse_path, _hbm  # noqa: E402,F401 - register the built-in methods, in order
from ._reverse_path import (ReversePathEstimate, ReversePathOptions,
                            estimate as reverse_path_estimate,
                            format_table as reverse_path_table)

discover(__name__, __path__)       # every further method module registers itself

__all__ = ["ESTIMATOR_KEY", "BatchOptions", "Estimate", "LevelEstimate", "Method",
           "StoredEstimate", "StoredResult",
           "add_batch_options", "add_options", "batch_values", "discover", "find_stored",
           "for_excitation", "get", "methods", "option", "register", "stored_estimates",
           "unregister",
           # the reverse path's own entry points (the demo)
           "ReversePathEstimate", "ReversePathOptions", "reverse_path_estimate",
           "reverse_path_table"]
