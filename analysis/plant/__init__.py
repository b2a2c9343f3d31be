"""The simulated plant (exact linear discretisation, element hold, numba kernels) and the
drives it is run with.

Modules behind this API: ``_plant``, ``_plant_kernels`` (the loop), ``_substep`` (its
stages), ``_hold``, ``_records``, ``_excitation``. Code inside this
package imports its siblings by their private module path.
"""

from ._plant import (HOLD_DEGREE, Plant, PlantError, PlantOutput, SavedState,
                     add_relative_noise, auto_oversample, hold_image_response,
                     remove_hold_images, simulate)
from ._excitation import (ExcitationError, burst_random, multisine, periodic, random_gaussian,
                          sine_block, stepped_sine_plan, swept_sine)

__all__ = ["ExcitationError", "HOLD_DEGREE", "Plant", "PlantError", "PlantOutput",
           "SavedState", "add_relative_noise", "auto_oversample", "burst_random", "hold_image_response",
           "multisine", "periodic", "random_gaussian", "remove_hold_images", "simulate",
           "sine_block", "stepped_sine_plan", "swept_sine"]
