"""Choosing an exposure: the time that puts a scene's bright end near full scale."""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .sensor import sensor_weights

__all__ = ["auto_exposure", "recordable_level"]


def auto_exposure(scene, camera, *, target=0.9, percentile=99.5):
    """The exposure time that puts the scene's bright end at ``target`` x what the camera can record.

    Parameters
    ----------
    scene : Scene
        The scene (its radiance planes are read directly, without the blur or the resampling; the lens's
        transmittance and its working f-number at the focus distance, N (1 + m), are counted as on its axis).
    camera : Camera
        The camera; its current ``exposure`` (s) is the reference the response is scaled from.
    target : float
        Fraction in (0, 1] of :func:`recordable_level` the bright end reaches (default 0.9).
    percentile : float
        Percentile (0-100) of the brightest sensor's noiseless response, per scene pixel, that defines
        the bright end (default 99.5: the brightest 0.5 % of the pixels reach the target).

    Returns
    -------
    float
        Exposure time, s. What the camera can record (:func:`recordable_level`): the ADC's full scale
        ``2**bits - 1`` DN; for an electron-level camera (``noise_model="photon"``) the full well's level
        when that comes first, and unquantized the full well's level alone (the top of its range, as
        the exposure measures read it); 255 DN for an unquantized camera in digital units (the chapter's).

    Notes
    -----
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

    An unquantized imx174 is exposed for its full well, as at its 12 bits (whose ADC spans the well):

    >>> imx = cs.load_camera("imx174")
    >>> round(auto_exposure(scene, imx.replace(bits=None)) / auto_exposure(scene, imx), 6)
    1.0
    """
    if not 0 < target <= 1:
        raise ParameterError("target", f"must lie in (0, 1], got {target}")
    from ..optics.stage import on_axis, optics_active

    weights, _ = sensor_weights(camera, scene.wavelengths)
    if optics_active(camera):  # the lens's transmittance and (1 + m)^-2 as the optics stage applies them on axis
        spectral, scalar = on_axis(camera, scene)
        weights = weights * scalar if spectral is None else weights * (scalar * spectral[:, None])
    h, w, n = scene.data.shape
    step = max(1, int(np.sqrt(h * w / 65536)))
    sample = scene.data[::step, ::step].reshape(-1, n) @ weights
    level = float(np.percentile(sample.max(axis=1), percentile))
    if level <= 0:
        raise ParameterError("scene", "gives no response in this camera's sensors; cannot choose an exposure")
    return camera.exposure * target * recordable_level(camera) / level


def recordable_level(camera):
    """The highest response the camera records, in the units of the sensor stage's noiseless output.

    Parameters
    ----------
    camera : Camera
        Any camera.

    Returns
    -------
    float
        Digital units (DN) before the analog gain, above the black level for an electron-level camera:

        * a camera in digital units (the chapter's): its full scale, ``2**bits - 1``, or 255 unquantized
          (the engine's display convention);
        * an electron-level camera (``noise_model="photon"``), quantized: the ADC's headroom above the
          black level, ``(2**bits - 1 - black_level) / analog_gain``, or its full well's level
          (:func:`~camsim_core.simulation.electrons.full_well_level` / ``analog_gain`` =
          ``full_well / electrons_per_dn``), whichever comes first;
        * an electron-level camera, unquantized: its full well's level (no ADC clips it; the exposure
          measures and the explorer read its range up to the same level), or 255 / ``analog_gain``
          above the black level for a sensor without a full well.

    Examples
    --------
    A 16-bit imx174 saturates at its full well, 4,095 DN, long before 65,535; unquantized too:

    >>> import camsim_core as cs
    >>> imx = cs.load_camera("imx174")
    >>> round(recordable_level(imx.replace(bits=16))), round(recordable_level(imx.replace(bits=None)))
    (4095, 4095)
    """
    from .electrons import full_well_level

    full = camera.full_scale
    if camera.noise_model != "photon":
        return full or 255.0
    gain = float(camera.analog_gain)
    well = full_well_level(camera)
    if well is not None and full is None:  # unquantized: the sensor's range ends at its full well
        return well / gain
    ceiling = ((full or 255.0) - float(camera.black_level)) / gain  # the ADC's headroom above black, before the analog gain
    if well is not None:
        ceiling = min(ceiling, well / gain)
    return ceiling
