"""The chapter's section 5 experiments, one task per configuration, on Dask.

* :mod:`.sensors` - effect of sensor choice (Figure 1.14): S-CIELAB error
  against alpha for the baseline and illuminant-based renderings;
* :mod:`.mosaic` - three sensors on a Bayer tile versus four on a 2 x 2 grid
  (Table 1.16);
* :mod:`.table_1_16_study` - Table 1.16's unstated choices (exposure, sensor centres and
  scaling, demosaic prior and noise model, rendering, S-CIELAB viewing) swept on Dask, resumable;
* :mod:`.pixel_size` - section 6's question: S-CIELAB error against pixel
  pitch for a fixed sensor size, at several light levels;
* :mod:`.grid` - validation of the parameter grid, the common exposure, task seeds;
* :mod:`.runner` - in-process loop, local Dask cluster or existing scheduler;
* :mod:`.results` - mean and std over seeds, CSV, text tables;
* :mod:`.plot` - the two-panel figure (matplotlib, Agg).

Command line: ``camsim experiment sensors``, ``camsim experiment mosaic``, ``camsim experiment table-1-16-study``
and ``camsim experiment pixel-size``.
"""

from . import grid, mosaic, pixel_size, results, runner, sensors, table_1_16_study  # plot (matplotlib) is imported on use

__all__ = ["grid", "mosaic", "pixel_size", "results", "runner", "sensors", "table_1_16_study"]
