"""Stage 4: noise (chapter 3.1 "Noise")."""

from __future__ import annotations

import numpy as np

from ._stage import stage
from .electrons import electron_sensor

__all__ = ["noise"]


@stage("noise_model", "noise_mean", "noise_sigma", "read_noise", "electrons_per_dn", "seed", "full_well", "dark_current",
       "dsnu", "prnu", "analog_gain", "pattern_seed", "exposure")
def noise(camera, image):
    """Add noise from a ``numpy.random.Generator`` seeded with ``camera.seed``.

    * "gaussian" (the chapter's model): independent Gaussian noise of mean
      ``noise_mean`` and standard deviation ``noise_sigma``, digital units.
    * "photon": the electron-level sensor
      (:func:`~camsim_core.simulation.electrons.electron_sensor`): the mean
      signal in electrons (``data x electrons_per_dn``) is replaced by a
      Poisson draw (shot noise), Gaussian read noise of ``read_noise``
      electrons is added, with PRNU, dark current, DSNU and full-well
      clipping when set, and the result is converted to digital units by
      the system gain; ``noise_mean`` is added as an offset.

    * "gaussian-range" (SimToolbox's ``gaussianIIDpercent``): the image is
      scaled so that its own minimum and maximum map to 0 and 1, Gaussian
      noise of mean ``noise_mean`` and standard deviation ``noise_sigma``
      (fractions of that range) is added, the result clipped to [0, 1] (as
      MATLAB's ``imnoise`` does) and scaled back. The noise in digital units
      thus depends on the image's range.

    ``noise_sigma == 0`` (and, for the photon model, ``read_noise == 0``
    with no shot noise wanted) means a noiseless camera: the stage does nothing.

    A float32 image gets float32 Gaussian deviates (the same distribution,
    a different random stream than a float64 image of the same seed).
    """
    if camera.noise_model == "gaussian-range":
        return _range_noise(camera, image, np.asarray(image.data, float), np.random.default_rng(camera.seed))
    if camera.noise_model == "photon":
        return electron_sensor(camera, image)
    if camera.noise_sigma == 0:
        return image
    rng = np.random.default_rng(camera.seed)
    data = np.asarray(image.data)
    if data.dtype == np.float32:
        # float32 image: float32 normal deviates (numpy's float32 ziggurat, a different stream than
        # float64's for the same seed, about 2x faster), added in place without float64 temporaries
        out = rng.standard_normal(size=data.shape, dtype=np.float32)
        out *= np.float32(camera.noise_sigma)
        out += data
        out += np.float32(camera.noise_mean)
    else:
        data = np.asarray(data, float)
        out = data + camera.noise_mean + rng.normal(0.0, camera.noise_sigma, size=data.shape)
    return image.then("noise", data=out, noise_sigma=float(np.hypot(image.noise_sigma, camera.noise_sigma)))


def _range_noise(camera, image, data, rng):
    """Noise in fractions of the image's own range, clipped to that range (``gaussianIIDpercent``)."""
    lo, hi = float(np.min(data)), float(np.max(data))
    span = hi - lo
    if span <= 0 or (camera.noise_sigma == 0 and camera.noise_mean == 0):
        return image
    x = (data - lo) / span + camera.noise_mean + rng.normal(0.0, camera.noise_sigma, size=data.shape)
    out = np.clip(x, 0.0, 1.0) * span + lo
    return image.then("noise", data=out, noise_sigma=float(np.hypot(image.noise_sigma, camera.noise_sigma * span)))
