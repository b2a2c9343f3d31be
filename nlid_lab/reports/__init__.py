"""What a stored run holds for views and reports, the HTML report, its figures and UFF export.

Modules behind this API: ``_report``, ``_figures``, ``_uff``, ``_rundata``,
``_backbone_figure``. Code inside this
package imports its siblings by their private module path.
"""

from ._report import (estimate_rows, modal_fit_section, stored_diagnosis,
                      write_report)
from ._backbone_figure import backbone_figure
from ._figures import ModelCurve, phase_deg, phase_lines, response_curves, stabilisation
from ._rundata import (PARAM_UNITS, RunData, Section, all_level_frfs, candidate_model, load_run,
                       reference_model)

__all__ = ["ModelCurve", "backbone_figure", "PARAM_UNITS", "RunData", "Section", "all_level_frfs", "candidate_model",
           "estimate_rows", "load_run", "modal_fit_section", "phase_deg", "phase_lines",
           "reference_model", "response_curves", "stabilisation", "stored_diagnosis", "write_report"]
