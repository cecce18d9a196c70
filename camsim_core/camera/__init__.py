"""Cameras: the parameter structure, presets and the ``.Scam`` reader."""

from .camera import NOISE_MODELS, Camera
from .load import CAMERA_NAMES, camera_preset, load_camera, read_scam

__all__ = ["Camera", "NOISE_MODELS", "load_camera", "read_scam", "camera_preset", "CAMERA_NAMES"]
