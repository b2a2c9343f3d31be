"""nlid-lab numerical core: models, element laws, simulated plant and estimators.

Pure numpy/scipy/numba on arrays; no devices, no files other than model TOML.
"""

from .elements import KINDS, restoring_force
from .errors import EstimationError, InputError, ModelError, RecordingError
from .model import Element, Model
from .plant import Plant, PlantOutput, add_relative_noise, simulate
from .recording import Recording
from .reverse_path import ReversePathResult, reverse_path

__all__ = [
    "KINDS", "restoring_force",
    "EstimationError", "InputError", "ModelError", "RecordingError",
    "Element", "Model", "Recording",
    "Plant", "PlantOutput", "add_relative_noise", "simulate",
    "ReversePathResult", "reverse_path",
]
