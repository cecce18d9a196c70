"""Running a camera's architecture on a scene."""

from __future__ import annotations

from ..image import image_from_scene

__all__ = ["simulate", "run_stages"]


def run_stages(camera, image, stages=None):
    """Apply ``stages`` (default: the camera's architecture) in order."""
    for stage in camera.architecture if stages is None else stages:
        image = stage(camera, image)
    return image


def simulate(scene, camera, *, distance=None, exposure=None, f_stop=None, seed=None):
    """Predict the camera image of ``scene``: the camera's stages applied in order.

    Keyword arguments override the camera's own settings for this picture.
    Returns a :class:`~camsim_core.image.CameraImage` whose ``.data`` is the array.
    """
    changes = {k: v for k, v in dict(distance=distance, exposure=exposure, f_stop=f_stop, seed=seed).items() if v is not None}
    if changes:
        camera = camera.replace(**changes)
    return run_stages(camera, image_from_scene(scene))
