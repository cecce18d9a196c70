"""Choosing an exposure: the time that puts a scene's bright end near full scale."""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .sensor import sensor_weights

__all__ = ["auto_exposure", "recordable_level"]


def auto_exposure(scene, camera, *, target=0.9, percentile=99.5):
    """Exposure time (s) at which the ``percentile`` of the brightest sensor's
    noiseless response is ``target`` x what it can record (:func:`recordable_level`: the full scale,
    2**bits - 1 or 255 when unquantized; for an electron-level camera the full well when that comes first).

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
    return camera.exposure * target * recordable_level(camera) / level


def recordable_level(camera):
    """The highest response the camera records, in the units of the sensor stage's noiseless output.

    Its full scale (2**bits - 1, or 255 unquantized); for an electron-level camera
    (``noise_model="photon"``) also its full well, through the conversion gain and the analog gain,
    whichever comes first, and the black level below the full scale.

    Examples
    --------
    A 16-bit imx174 saturates at its full well, 4,095 DN, long before 65,535:

    >>> import camsim_core as cs
    >>> round(recordable_level(cs.load_camera("imx174").replace(bits=16)))
    4095
    """
    full = camera.full_scale or 255.0
    if camera.noise_model != "photon":
        return full
    gain = float(camera.analog_gain)
    ceiling = (full - float(camera.black_level)) / gain  # the ADC's headroom above black, before the analog gain
    if camera.full_well is not None:
        ceiling = min(ceiling, float(camera.full_well) / float(camera.electrons_per_dn))
    return ceiling
