"""Backbones: amplitude-dependent natural frequency and damping of one mode from
stepped-sine levels (response-controlled: a single-mode fit per held amplitude;
force-controlled: phase resonance of the step-wise inverse FRF).

Modules behind this API: ``_single_mode`` (the single-mode rational fit with its intervals),
``_backbone`` (levels to a `Backbone`). Code inside this package imports its siblings by their
private module path.
"""

from ._single_mode import ModeFit, fit_single_mode, frf_noise
from ._backbone import (FORCE_METHOD, RESPONSE_METHOD, SCHEMA_VERSION, Backbone, BackbonePoint,
                        backbone, stepwise_modal)

__all__ = ["Backbone", "BackbonePoint", "FORCE_METHOD", "ModeFit", "RESPONSE_METHOD",
           "SCHEMA_VERSION", "backbone", "fit_single_mode", "frf_noise", "stepwise_modal"]
