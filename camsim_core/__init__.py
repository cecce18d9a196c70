"""camsim_core: simulate what a digital camera records from a hyperspectral scene.

The engine of camsim (no GUI imports). Stages of the chapter's pipeline live
in sub-packages named after them:

* :mod:`camsim_core.scene` - hyperspectral scenes, loaders, synthetic scenes;
* :mod:`camsim_core.camera` - camera parameters and presets;
* :mod:`camsim_core.simulation` - sensor, resample, mosaic, noise, digitize (and blur);
* :mod:`camsim_core.datasets` - sensors, illuminants, surfaces;
* :mod:`camsim_core.monitor` - display calibration.

Reference: Longere, P. & Brainard, D. H., "Simulation of digital camera
images from hyperspectral input" (``../shared/spec`` of the project).
"""

from .camera import CAMERA_NAMES, Camera, load_camera
from .errors import CamsimError, FileFormatError, ParameterError
from .image import CameraImage, image_from_scene
from .monitor import MONITOR_NAMES, Monitor, load_monitor
from .scene import SCENE_NAMES, Scene, load_scene
from .simulation import DEFAULT_ARCHITECTURE, auto_exposure, run_stages, simulate
from .demosaicing import demosaic
from .rendering import ideal_image, render, to_xyz
from .io.raw import raw_from_array
from .io.dng import load_raw, write_dng
from . import metrics

__version__ = "0.1.0"

__all__ = [
    "Scene",
    "Camera",
    "CameraImage",
    "Monitor",
    "load_scene",
    "load_camera",
    "load_monitor",
    "simulate",
    "run_stages",
    "auto_exposure",
    "image_from_scene",
    "demosaic",
    "render",
    "to_xyz",
    "ideal_image",
    "raw_from_array",
    "load_raw",
    "write_dng",
    "metrics",
    "DEFAULT_ARCHITECTURE",
    "SCENE_NAMES",
    "CAMERA_NAMES",
    "MONITOR_NAMES",
    "CamsimError",
    "FileFormatError",
    "ParameterError",
]
