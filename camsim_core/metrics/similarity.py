"""Image similarity from scikit-image: PSNR and SSIM, beside dE and S-CIELAB.

Thin wrappers over ``skimage.metrics.peak_signal_noise_ratio`` and
``structural_similarity`` (Wang et al. 2004) that accept camera images,
take the data range from the images' bit depth when they are quantized,
and check shapes with a clear error.
"""

from __future__ import annotations

import numpy as np

from .._parallel import run_blocks
from ..errors import ParameterError

__all__ = ["psnr", "ssim"]


def _pair(image, reference, data_range):
    a = np.asarray(getattr(image, "data", image), float)
    b = np.asarray(getattr(reference, "data", reference), float)
    if a.shape != b.shape:
        raise ParameterError("reference", f"has shape {b.shape}, the image {a.shape}: compare images of one size")
    if data_range is None:
        bits = getattr(reference, "bits", None) or getattr(image, "bits", None)
        data_range = float(2**bits - 1) if bits else float(np.ptp(b))
    if not data_range > 0:
        raise ParameterError("data_range", "must be positive (the reference is flat: give data_range)")
    return a, b, float(data_range)


def psnr(image, reference, *, data_range=None):
    """Peak signal-to-noise ratio, dB: 10 log10(range^2 / MSE). Range: 2^bits - 1, else the reference's span.

    Identical images give ``inf`` (no error at all), without the divide-by-zero
    warning scikit-image would write to a server's log for it.
    """
    from skimage.metrics import peak_signal_noise_ratio

    a, b, r = _pair(image, reference, data_range)
    if np.array_equal(a, b):
        return float("inf")
    return float(peak_signal_noise_ratio(b, a, data_range=r))


def ssim(image, reference, *, data_range=None):
    """Mean structural similarity (1 for identical images); colour channels averaged."""
    from skimage.metrics import structural_similarity

    a, b, r = _pair(image, reference, data_range)
    if min(a.shape[:2]) < 7:
        raise ParameterError("image", f"is {a.shape[0]} x {a.shape[1]}; SSIM needs at least 7 x 7 pixels")
    if a.ndim != 3:
        return float(structural_similarity(b, a, data_range=r))
    # the channels' SSIMs averaged, as scikit-image's ``channel_axis`` does (the same numbers), one channel a
    # block on the machine's cores: a frame-sized chart's three channels took 0.6 s in turn, 0.3 s on two
    means = np.empty(a.shape[2])

    def channels(start, stop):
        for c in range(start, stop):
            means[c] = structural_similarity(b[..., c], a[..., c], data_range=r)

    run_blocks(channels, range(a.shape[2] + 1), values=a.size)
    return float(np.mean(means))
