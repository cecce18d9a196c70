"""Optional stage: optical blur by a Gaussian point spread function.

Not one of the chapter's five stages ("this stage ... could also incorporate
models of optical blur", section 3.1); insert it where it belongs in the
architecture. Before ``sensor_responses`` it acts on the spectral planes and
may vary with wavelength (``blur_sigma`` a Spectrum: chromatic aberration).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter

from ..errors import ParameterError
from ..spectra import Spectrum
from ._stage import stage

__all__ = ["optical_blur"]


def _pixels_per_camera_pixel(camera, image):
    """How many of the image's pixels one camera pixel spans (x, y), near the axis."""
    d = camera.distance if camera.distance is not None else image.distance
    return tuple((Phi / phi) * (d / image.distance) for Phi, phi in zip(image.angular_resolution, camera.angular_resolution))


@stage("blur_sigma", "angular_resolution", "distance")
def optical_blur(camera, image):
    """Gaussian blur of standard deviation ``camera.blur_sigma`` camera pixels, per plane.

    The width is converted to the image's own pixels, so the stage can run
    before or after resampling. A Spectrum ``blur_sigma`` gives the width at
    each wavelength and needs spectral planes.
    """
    sx, sy = _pixels_per_camera_pixel(camera, image)
    sig = camera.blur_sigma
    data = np.asarray(image.data, float)
    if isinstance(sig, Spectrum):
        if image.space != "spectral":
            raise ParameterError("blur_sigma", "a per-wavelength blur needs spectral planes: put optical_blur before sensor_responses")
        per_plane = np.interp(image.wavelengths, sig.wavelengths, sig.values)
    else:
        if sig == 0:
            return image
        per_plane = np.full(1 if data.ndim == 2 else data.shape[2], float(sig))
    if image.mosaiced:
        raise ParameterError("optical_blur", "blur acts on light before the mosaic; put it before the mosaic stage")
    if data.ndim == 2:
        out = gaussian_filter(data, (per_plane[0] * sy, per_plane[0] * sx), mode="nearest")
    else:
        out = np.empty_like(data)
        for k in range(data.shape[2]):
            s = per_plane[k]
            out[:, :, k] = gaussian_filter(data[:, :, k], (s * sy, s * sx), mode="nearest") if s > 0 else data[:, :, k]
    return image.then("optical_blur", data=out)
