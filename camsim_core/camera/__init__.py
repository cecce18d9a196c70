"""Cameras: the parameter structure, presets and the ``.Scam`` reader."""

from .camera import NOISE_MODELS, Camera
from .load import CAMERA_NAMES, camera_preset, load_camera, read_scam
from .physical import PHYSICAL_NAMES, physical_camera

__all__ = ["Camera", "NOISE_MODELS", "load_camera", "read_scam", "camera_preset", "CAMERA_NAMES", "PHYSICAL_NAMES", "physical_camera"]
