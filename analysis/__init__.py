"""nlid-lab numerical core: models, element laws, simulated plant and estimators.

Pure numpy/scipy/numba on arrays; no devices, no files other than model TOML. The public names
below are imported lazily (PEP 562), so ``import analysis.errors`` (as the CLI does for every
command) does not pay for numba and scipy start-up.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "KINDS": "models", "restoring_force": "models",
    "EstimationError": "errors", "InputError": "errors", "ModelError": "errors",
    "RecordingError": "errors",
    "Element": "models", "Model": "models", "Recording": "recordings",
    "Plant": "plant", "PlantOutput": "plant", "add_relative_noise": "plant",
    "simulate": "plant",
    "ReversePathResult": "reverse_path", "reverse_path": "reverse_path",
    "ScreeningResult": "reverse_path", "screen_candidates": "reverse_path",
    "HBMSystem": "hbm", "FitResult": "hbm", "fit_hbm": "hbm",
    "sine_fit": "spectral", "stepped_sine_frf": "spectral",
    "Diagnosis": "diagnose",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'analysis' has no attribute '{name}'")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
