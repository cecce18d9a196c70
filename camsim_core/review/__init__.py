"""Design review: camera designs side by side, parameter sweeps, and a self-contained HTML report.

* :mod:`.design` - a design's parameters (the explorer's), the Camera and Processing they
  describe, and its evaluation (rendered image, CIELAB and S-CIELAB maps, their statistics);
* :mod:`.sweep` - one parameter over a list of values for several designs, points as they arrive;
* :mod:`.difference` - two designs' renderings against each other (A/B difference);
* :mod:`.report` - the HTML report (``camsim report``).

The chapter's section 5: simulation lets one compare camera designs and algorithms.
No GUI imports: this package is engine code.
"""

from .design import (DESIGN_DEFAULTS, DESIGN_PARAMETERS, QUALITY_LABELS, DesignResult, camera_from_params, check_params,
                     differing_parameters, evaluate_design, measures, processing_from_params, quality_measures,
                     read_design_file)
from .sweep import MAX_SWEEP_DESIGNS, MAX_SWEEP_VALUES, SWEEP_PARAMETERS, SweepPoint, design_at, iter_sweep, run_sweep

__all__ = [
    "DESIGN_DEFAULTS", "DESIGN_PARAMETERS", "DesignResult", "camera_from_params", "check_params",
    "differing_parameters", "evaluate_design", "measures", "processing_from_params", "read_design_file",
    "QUALITY_LABELS", "quality_measures",
    "MAX_SWEEP_DESIGNS", "MAX_SWEEP_VALUES", "SWEEP_PARAMETERS", "SweepPoint", "design_at", "iter_sweep", "run_sweep",
]
