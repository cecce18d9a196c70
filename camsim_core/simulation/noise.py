"""Stage 4: noise (chapter 3.1 "Noise")."""

from __future__ import annotations

import numpy as np

from .._parallel import PARALLEL_VALUES, run_blocks
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
    a different random stream than a float64 image of the same seed). A
    float32 image of more than :data:`~camsim_core._parallel.PARALLEL_VALUES`
    values (a sensor-size raw) draws them by blocks of rows of about
    :data:`NOISE_BLOCK_VALUES` values, block i from child i of the seed's
    ``SeedSequence``, on the machine's cores: the same noise for the same
    seed and shape on any number of cores.
    """
    if camera.noise_model == "gaussian-range":
        return _range_noise(camera, image, np.asarray(image.data, float), np.random.default_rng(camera.seed))
    if camera.noise_model == "photon":
        return electron_sensor(camera, image)
    if camera.noise_sigma == 0:
        return image
    rng = np.random.default_rng(camera.seed)
    data = np.asarray(image.data)
    if data.dtype == np.float32 and data.size >= PARALLEL_VALUES and data.ndim >= 2:
        out = _block_noise(data, camera.seed, np.float32(camera.noise_sigma), np.float32(camera.noise_mean))
    elif data.dtype == np.float32:
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


#: Values per block of a large float32 image's noise (each block its own child stream of the seed).
NOISE_BLOCK_VALUES = 1 << 20


def _block_noise(data, seed, sigma, mean):
    """data + mean + sigma x N(0, 1), float32, drawn by blocks of rows from child streams of ``seed``
    (numpy's generators release the GIL while they fill, so the blocks run on the machine's cores)."""
    data = np.ascontiguousarray(data)
    out = np.empty_like(data)
    row = int(np.prod(data.shape[1:]))
    rows = max(1, NOISE_BLOCK_VALUES // max(row, 1))
    edges = list(range(0, data.shape[0], rows)) + [data.shape[0]]
    streams = dict(zip(edges[:-1], np.random.SeedSequence(seed).spawn(len(edges) - 1)))

    def fill(a, b):
        block = out[a:b]
        np.random.Generator(np.random.PCG64(streams[a])).standard_normal(out=block, dtype=np.float32)
        block *= sigma
        block += data[a:b]
        block += mean

    run_blocks(fill, edges, values=data.size)
    return out


def _range_noise(camera, image, data, rng):
    """Noise in fractions of the image's own range, clipped to that range (``gaussianIIDpercent``)."""
    lo, hi = float(np.min(data)), float(np.max(data))
    span = hi - lo
    if span <= 0 or (camera.noise_sigma == 0 and camera.noise_mean == 0):
        return image
    x = (data - lo) / span + camera.noise_mean + rng.normal(0.0, camera.noise_sigma, size=data.shape)
    out = np.clip(x, 0.0, 1.0) * span + lo
    return image.then("noise", data=out, noise_sigma=float(np.hypot(image.noise_sigma, camera.noise_sigma * span)))
