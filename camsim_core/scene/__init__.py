"""Hyperspectral scenes: the structure, loaders and synthetic generators."""

from .load import SCENE_NAMES, load_scene, read_npz_scene, read_simg, save_npz_scene
from .scene import Scene, check_radiance
from .synthetic import DEFAULT_WAVELENGTHS, macbeth_scene, patch_centers, stripe_scene

__all__ = [
    "Scene",
    "check_radiance",
    "load_scene",
    "read_simg",
    "read_npz_scene",
    "save_npz_scene",
    "macbeth_scene",
    "stripe_scene",
    "patch_centers",
    "SCENE_NAMES",
    "DEFAULT_WAVELENGTHS",
]
