"""What a stored run holds for views and reports, the HTML report, its figures and UFF export.

Modules behind this API: ``_report``, ``_figures``, ``_uff``, ``_rundata``,
``_backbone_figure``. Code inside this
package imports its siblings by their private module path.
"""

from ._report import (Estimators, WrittenReport, estimate_rows, modal_fit_section,
                      stored_diagnosis, write_report)
from ._backbone_figure import backbone_figure
from ._figures import (LevelBars, ModelCurve, coherence_linear_vs_nonlinear, diagnosis_overlay,
                       fitted_frfs, hysteresis_loops, level_colours, linear_and_coefficients,
                       phase_deg, phase_lines, response_curves, stabilisation)
from ._rundata import (PARAM_UNITS, RunData, Section, all_level_frfs, candidate_model, load_run,
                       reference_model)
from ._uff import FUNC_COHERENCE, FUNC_FRF, datasets as uff_datasets, read_uff, write_uff

__all__ = [
    # what a stored run holds
    "RunData", "Section", "PARAM_UNITS", "all_level_frfs", "candidate_model", "load_run",
    "reference_model",
    # the HTML report and its sections (the estimator registry handed in: `Estimators`)
    "Estimators", "WrittenReport", "estimate_rows", "modal_fit_section", "stored_diagnosis",
    "write_report",
    # figures
    "LevelBars", "ModelCurve", "backbone_figure", "coherence_linear_vs_nonlinear",
    "diagnosis_overlay", "fitted_frfs", "hysteresis_loops", "level_colours", "linear_and_coefficients", "phase_deg", "phase_lines",
    "response_curves", "stabilisation",
    # UFF58 export
    "FUNC_COHERENCE", "FUNC_FRF", "read_uff", "uff_datasets", "write_uff",
]
