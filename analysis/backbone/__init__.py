"""Backbones: amplitude-dependent natural frequency and damping of one mode from
stepped-sine levels (response-controlled: a single-mode fit per held amplitude;
force-controlled: phase resonance of the step-wise inverse FRF).

Modules behind this API: ``_single_mode`` (the single-mode rational fit with its intervals),
``_backbone`` (levels to a `Backbone`), ``_joint`` (a joint element fitted to a backbone,
single nonlinear mode), ``_free`` (unbounded fit coordinates of a kind's parameters),
``_simulated`` (a model through the same test, as tables). Code inside this package imports
its siblings by their private module path.
"""

from ._single_mode import ModalEstimate, ModeFit, fit_single_mode, frf_noise
from ._free import free_bounds, free_interval, from_free, to_free
from ._backbone import (FORCE_METHOD, RESPONSE_METHOD, SCHEMA_VERSION, Backbone, BackbonePoint,
                        backbone, stepwise_modal)
from ._joint import (JointFit, LinearMode, describing, fit_joint, held_out, joint_backbone,
                     reference_correction, reference_residuals, stuck_form)
from ._simulated import ModelTables, model_tables

__all__ = ["Backbone", "BackbonePoint", "FORCE_METHOD", "JointFit", "LinearMode", "ModeFit",
           "ModalEstimate", "ModelTables", "RESPONSE_METHOD", "SCHEMA_VERSION", "backbone",
           "describing", "fit_joint", "fit_single_mode", "free_bounds", "free_interval",
           "from_free", "frf_noise", "held_out", "joint_backbone", "model_tables",
           "reference_correction", "reference_residuals", "stepwise_modal", "stuck_form",
           "to_free"]
