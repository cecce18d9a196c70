"""Hyperspectral scenes: the structure, loaders, readers of the field's formats, photos and charts."""

from ._intake import DEFAULT_ANGULAR_RESOLUTION, DEFAULT_DISTANCE, MAX_SCENE_VALUES, SceneNotice
from .charts import CHART_NAMES, chart, munsell_scene, slanted_edge_scene, uniform_scene, zone_plate_scene
from .load import SCENE_NAMES, load_scene, read_npz_scene, read_simg, save_npz_scene
from .photo import SAMPLE_PHOTOS, read_photo, scene_from_rgb
from .scene import LIGHT_RANGE, Scene, check_radiance, scale_light
from .synthetic import DEFAULT_WAVELENGTHS, macbeth_scene, patch_centers, stripe_scene

__all__ = [
    "Scene",
    "check_radiance",
    "scale_light",
    "LIGHT_RANGE",
    "load_scene",
    "read_simg",
    "read_npz_scene",
    "save_npz_scene",
    "read_photo",
    "scene_from_rgb",
    "macbeth_scene",
    "stripe_scene",
    "patch_centers",
    "slanted_edge_scene",
    "zone_plate_scene",
    "uniform_scene",
    "munsell_scene",
    "chart",
    "CHART_NAMES",
    "SAMPLE_PHOTOS",
    "SCENE_NAMES",
    "DEFAULT_WAVELENGTHS",
    "DEFAULT_DISTANCE",
    "DEFAULT_ANGULAR_RESOLUTION",
    "MAX_SCENE_VALUES",
    "SceneNotice",
]
