"""The simulation pipeline: the chapter's five stages (section 3.1) and an optional blur.

``DEFAULT_ARCHITECTURE`` is the chapter's order: sensor responses,
resampling, mosaic, noise, digitization.
"""

from .blur import optical_blur
from .digitize import apply_nonlinearity, digitize
from .mosaic import BAYER, FOUR_SENSOR_GRID, bayer, mosaic, tile_index_map
from .noise import noise
from .resample import axis_matrix, resample, resampled_size
from .sensor import exposure_gain, sensor_responses, sensor_weights

DEFAULT_ARCHITECTURE = (sensor_responses, resample, mosaic, noise, digitize)

from .exposure import auto_exposure  # noqa: E402
from .pipeline import run_stages, simulate  # noqa: E402

__all__ = [
    "DEFAULT_ARCHITECTURE",
    "sensor_responses",
    "resample",
    "mosaic",
    "noise",
    "digitize",
    "optical_blur",
    "simulate",
    "run_stages",
    "auto_exposure",
    "exposure_gain",
    "sensor_weights",
    "resampled_size",
    "axis_matrix",
    "apply_nonlinearity",
    "bayer",
    "BAYER",
    "FOUR_SENSOR_GRID",
    "tile_index_map",
]
