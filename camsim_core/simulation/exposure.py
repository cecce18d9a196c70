"""Choosing an exposure: the time that puts a scene's bright end near full scale."""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .sensor import sensor_weights

__all__ = ["auto_exposure"]


def auto_exposure(scene, camera, *, target=0.9, percentile=99.5):
    """Exposure time (s) at which the ``percentile`` of the brightest sensor's
    noiseless response is ``target`` x full scale (2**bits - 1, or 255 when unquantized).

    Computed on the scene's own pixels (resampling averages, so it lowers the
    peak only slightly). The response is linear in exposure, so one
    evaluation at the camera's current exposure suffices.

    Examples
    --------
    The brightest patch then reaches 90 % of the 8-bit full scale:

    >>> import camsim_core as cs
    >>> scene, camera = cs.load_scene("macbeth"), cs.load_camera("kodak-dcs200")
    >>> raw = cs.simulate(scene, camera, exposure=auto_exposure(scene, camera))
    >>> round(float(raw.data.max()) / 255, 2)
    0.9
    """
    if not 0 < target <= 1:
        raise ParameterError("target", f"must lie in (0, 1], got {target}")
    weights, _ = sensor_weights(camera, scene.wavelengths)
    h, w, n = scene.data.shape
    step = max(1, int(np.sqrt(h * w / 65536)))
    sample = scene.data[::step, ::step].reshape(-1, n) @ weights
    level = float(np.percentile(sample.max(axis=1), percentile))
    if level <= 0:
        raise ParameterError("scene", "gives no response in this camera's sensors; cannot choose an exposure")
    full = camera.full_scale or 255.0
    return camera.exposure * target * full / level
