"""Stage 1: sensor class responses, a weighted sum of the hyperspectral planes (chapter 3.1)."""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..spectra import check_overlap
from ._stage import stage

__all__ = ["sensor_responses", "exposure_gain", "sensor_weights", "PLANCK", "LIGHT_SPEED"]

PLANCK = 6.62607015e-34  # J s
LIGHT_SPEED = 299792458.0  # m / s


def exposure_gain(camera):
    """(exposure / calibration exposure) x (calibration f-stop / f-stop)^2."""
    return (camera.exposure / camera.cal_exposure) * (camera.cal_f_stop / camera.f_stop) ** 2


def quantal_gain(camera):
    """Digital units per (photon absorbed per unit quantum efficiency), before the lambda/hc factor.

    Radiance L (W/sr/m^2 per band) gives the sensor an irradiance
    E = pi L / (4 N^2) through a lens of f-number N (distant object, no
    vignetting or transmission loss): the focal length cancels, because the
    scene patch one pixel sees grows as f^2 while the aperture's solid angle
    shrinks as 1/f^2. Photons absorbed in the exposure t by a pixel of area A
    with quantum efficiency q: q E A t lambda / (h c), A the pixel area
    times its fill factor. Divided by the conversion gain (electrons per
    digital unit). Magnification, transmittance and relative illumination
    come from the optics stage, when the camera has one.
    """
    area = float(camera.pixel_size[0]) * float(camera.pixel_size[1]) * float(camera.fill_factor)
    return np.pi / (4.0 * camera.f_stop**2) * area * camera.exposure / camera.electrons_per_dn


def sensor_weights(camera, wavelengths):
    """(N, K) weights that take the N planes to K sensor responses, gain included; and the gain."""
    gain = _gain(camera)
    return np.ascontiguousarray(_unit_weights(camera, wavelengths) * gain), gain


def _gain(camera):
    """What takes sums of the unit weights (:func:`_unit_weights`) to digital units: :func:`quantal_gain`
    for "Quanta" sensitivities, :func:`exposure_gain` otherwise."""
    return quantal_gain(camera) if camera.sensors.unit == "Quanta" else exposure_gain(camera)


def _unit_weights(camera, wavelengths):
    """(N, K) weights at unit gain: the sensitivities on ``wavelengths`` (for "Quanta" ones times lambda / hc,
    photons per joule). These are also the sensitivities rendering inverts (Eq. 1.4)."""
    w = np.asarray(wavelengths, float)
    check_overlap(camera.sensors.wavelengths, w, f"sensitivities of {camera.name or 'the camera'}")
    t = camera.sensors.on(w)
    if camera.sensors.unit == "Quanta":
        t = t * (w * 1e-9 / (PLANCK * LIGHT_SPEED))[None, :]
    return np.ascontiguousarray(t.T)


def _weighted_planes(camera, image):
    """The sensor stage's first part: ``(image, sums, weights)``, the weighted sums of the planes at unit gain
    and the weights (:func:`_unit_weights`).

    Reads the camera's ``sensors`` only, so a cache keeps it while exposure
    and f-stop move (:func:`sensor_responses`, ``prepare``)."""
    data = _spectral_data(image)
    weights = _unit_weights(camera, image.wavelengths)
    return image, weighted_sum(data, weights), weights


def _spectral_data(image):
    """The (H, W, N) spectral planes the sensor stage reads: float32 kept, anything else float64."""
    if image.space != "spectral":
        raise ParameterError("sensor_responses", f"needs spectral planes, but the image is already in {image.space!r} space")
    data = image.data
    return data if data.dtype == np.float32 else np.asarray(data, np.float64)


def _scaled_responses(camera, prepared, *, reuse=False):
    """The sensor stage's second part: ``prepared`` (:func:`_weighted_planes`) times the exposure's gain,
    as the stage's output image. ``reuse``: the sums may be scaled in place (nothing else holds them)."""
    image, sums, weights = prepared
    gain = _gain(camera)
    if reuse:
        sums *= sums.dtype.type(gain)
    else:
        sums = sums * sums.dtype.type(gain)
    return _response_image(camera, image, sums, gain, weights)


@stage("sensors", "exposure", "f_stop", "cal_exposure", "cal_f_stop", "pixel_size", "electrons_per_dn", "fill_factor",
       prepare=(_weighted_planes, ("sensors",), _scaled_responses))
def sensor_responses(camera, image):
    """Weighted sums of the spectral planes, one per sensor class, scaled for exposure and f-stop.

    For "Watts" sensitivities the result is in digital units: the
    sensitivities were calibrated at ``cal_exposure`` and ``cal_f_stop``, and a
    linear sensor's response scales with exposure time and with the aperture
    area (1 / f-stop^2). For "Quanta" sensitivities the result is photons
    absorbed divided by ``electrons_per_dn`` (see :func:`quantal_gain`).
    Sensitivities are interpolated onto the scene's wavelengths and are zero
    outside their measured range. A float32 scene gives float32 responses
    (relative error ~1e-7, far below any sensor's noise).

    The sums are made at unit gain and then scaled, in two parts that a cache
    can keep apart (:mod:`camsim_core.cache`): an exposure or f-stop move
    then re-scales the kept sums instead of summing the cube again, with the
    numbers of this function.
    """
    return _scaled_responses(camera, _weighted_planes(camera, image), reuse=True)


def weighted_sum(data, weights):
    """(H, W, K) responses of (H, W, N) ``data``: ``data @ weights`` in the data's dtype."""
    h, w, n = data.shape
    # in the scene's own dtype: float32 weights for a float32 scene (no float64 copy of the cube)
    return (data.reshape(h * w, n) @ weights.astype(data.dtype, copy=False)).reshape(h, w, -1)


def respond(camera, image, combine):
    """The sensor stage's output image, its data ``combine(data, weights)``.

    ``data`` is the (H, W, N) spectral image (float32 kept, anything else
    float64) and ``weights`` the (N, K) sensor weights with the gain
    (:func:`sensor_weights`). :func:`sensor_responses` combines them by a
    plain weighted sum; the lens stage that fuses diffraction with the
    responses (:mod:`camsim_core.optics.fused`) by a blurred one. Everything
    else about the result (units, gain, the sensitivities rendering inverts)
    is set here, once.
    """
    data = _spectral_data(image)
    unit, gain = _unit_weights(camera, image.wavelengths), _gain(camera)
    return _response_image(camera, image, combine(data, np.ascontiguousarray(unit * gain)), gain, unit)


def _response_image(camera, image, data, gain, unit_weights):
    """The sensor stage's output image: ``data`` (H, W, K) with the gain, units and the sensitivities
    rendering inverts (Eq. 1.4): the (N, K) ``unit_weights`` (:func:`_unit_weights`), per unit radiance, the
    same units as the responses divided by the gain."""
    return image.then(
        "sensor_responses",
        data=data,
        sensitivities=unit_weights.T,
        sensor_names=camera.sensors.names,
        exposure=camera.exposure,
        f_stop=camera.f_stop,
        gain=float(gain),
        space="sensor",
        unit="digital units",
    )
