"""nlid-lab numerical core: models, element laws, simulated plant and estimators.

Pure numpy/scipy/numba on arrays; no devices, no files other than model TOML.
"""

from .elements import KINDS, restoring_force
from .errors import EstimationError, InputError, ModelError, RecordingError
from .model import Element, Model
from .recording import Recording

__all__ = [
    "KINDS", "restoring_force",
    "EstimationError", "InputError", "ModelError", "RecordingError",
    "Element", "Model", "Recording",
]
