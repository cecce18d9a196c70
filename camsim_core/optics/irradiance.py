"""Irradiance at the sensor from scene radiance through a lens (camera equation).

For a lens of f-number N, transmittance T and magnification m, a scene
patch of radiance L (W/sr/m^2, here per wavelength band) gives the sensor
the irradiance (Smith, *Modern Optical Engineering*; ISO 12232 notes;
Wandell, *Foundations of Vision*, ch. 2)

    E = pi L T cos^4(theta) V / (4 N^2 (1 + m)^2)      [W/m^2 per band]

where theta is the field angle of the patch, cos^4 the natural fall-off of
relative illumination, and V an optional extra (mechanical) vignetting.
N (1 + m) is the working f-number; m = f / (d - f) for a thin lens focused
at the object distance d. Hand-written: a handful of closed formulas.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .diffraction import check_f_number

__all__ = [
    "magnification",
    "image_distance",
    "image_irradiance",
    "cos4",
    "field_angles",
    "sample_pitch",
]


def magnification(focal_length, distance):
    """Lateral magnification m = f / (d - f) of a thin lens focused at ``distance``.

    ``focal_length`` in mm, ``distance`` (object to lens) in m; m is a
    positive number (the image is inverted, which camsim does not model).
    """
    f = float(focal_length) * 1e-3
    d = float(distance)
    if not (np.isfinite(f) and f > 0):
        raise ParameterError("focal_length", f"must be a positive number of mm, got {focal_length!r}")
    if not (np.isfinite(d) and d > f):
        raise ParameterError("distance", f"the object must lie beyond the focal length ({f:g} m) to form an image, got {distance!r} m")
    return f / (d - f)


def image_distance(focal_length, distance):
    """Lens-to-sensor distance s' = f (1 + m), metres, for ``focal_length`` mm focused at ``distance`` m."""
    return float(focal_length) * 1e-3 * (1.0 + magnification(focal_length, distance))


def image_irradiance(radiance, f_number, *, magnification=0.0, transmittance=1.0, relative_illumination=1.0):
    """E = pi L T RI / (4 N^2 (1 + m)^2): irradiance (W/m^2) at the sensor from radiance L (W/sr/m^2).

    Units follow ``radiance`` (per band in, per band out). All factors broadcast.
    """
    n = check_f_number(f_number, "f_stop")
    m = float(magnification)
    if not (np.isfinite(m) and m >= 0):
        raise ParameterError("magnification", f"must be a non-negative number, got {magnification!r}")
    return np.pi * np.asarray(radiance, float) * transmittance * relative_illumination / (4.0 * n * n * (1.0 + m) ** 2)


def cos4(theta):
    """Natural relative illumination cos^4(theta), ``theta`` the field angle in radians."""
    return np.cos(np.asarray(theta, float)) ** 4


def field_angles(shape, angular_resolution, scene_distance, camera_distance):
    """(H, W) field angle (radians) of each pixel centre of an image seen by a camera.

    The image was sampled at ``angular_resolution`` (x, y) pixels per degree
    from ``scene_distance`` m: pixel offset P (from the centre) lies at
    lateral position D tan(P / Phi) on the object plane, which the camera at
    ``camera_distance`` d sees at theta = atan(r / d).
    """
    h, w = shape
    ax, ay = angular_resolution
    y = scene_distance * np.tan(np.radians((np.arange(h) + 0.5 - h / 2.0) / ay))
    x = scene_distance * np.tan(np.radians((np.arange(w) + 0.5 - w / 2.0) / ax))
    return np.arctan(np.hypot(y[:, None], x[None, :]) / camera_distance)


def sample_pitch(angular_resolution, scene_distance, camera_distance, focal_length):
    """(dy, dx): the size, in metres at the sensor, of one pixel of an image.

    An image pixel of 1/Phi degree seen from ``scene_distance`` D spans
    D tan(1/Phi) on the object; the lens images it with magnification
    m = f / (d - f) for the camera at ``camera_distance`` d.
    """
    m = magnification(focal_length, camera_distance)
    ax, ay = angular_resolution
    return (scene_distance * np.tan(np.radians(1.0 / ay)) * m, scene_distance * np.tan(np.radians(1.0 / ax)) * m)
