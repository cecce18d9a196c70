"""Images at screen resolution: what a viewer needs of a sensor-size result.

A 12-megapixel camera image is 4000 x 3000 pixels; a browser shows perhaps
1600 x 1000 of them. :func:`to_screen` returns the part of an image a view
shows, averaged over square blocks of whole pixels (area averaging, so no
aliasing) until it fits the screen, and the block size, so a viewer can map
screen coordinates back to image pixels and ask for the full-resolution
detail of a smaller region when zoomed in.

Hand-written with ``numpy.add.reduceat`` (block sums of any size, the last
block partial): a view needs exactly this and nothing of an image library.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import ParameterError

__all__ = ["to_screen"]


def to_screen(data, max_shape=(1080, 1920), region=None):
    """The block-mean view of ``data[region]`` that fits ``max_shape``; and the block size.

    Parameters
    ----------
    data : array (H, W) or (H, W, C)
        An image (any numeric dtype; the view is float, float32 kept).
    max_shape : (rows, columns)
        The largest view wanted, screen pixels.
    region : (top, left, height, width), optional
        The part of the image shown, in image pixels (clipped to the image);
        default the whole image.

    Returns
    -------
    view : ndarray (h, w[, C])
        Each pixel the mean of a ``block x block`` square of image pixels
        (fewer at the region's right and bottom edges), h <= rows, w <= columns.
    block : int
        Image pixels per view pixel along each axis (1: the region's own pixels).
    """
    a = np.asarray(data)
    if a.ndim not in (2, 3) or a.shape[0] == 0 or a.shape[1] == 0:
        raise ParameterError("data", f"must be an (H, W) or (H, W, C) image, got shape {a.shape}")
    try:
        rows, cols = (int(v) for v in max_shape)
    except (TypeError, ValueError):
        raise ParameterError("max_shape", f"must be (rows, columns), got {max_shape!r}") from None
    if rows < 1 or cols < 1:
        raise ParameterError("max_shape", f"rows and columns must be >= 1, got {max_shape!r}")
    H, W = a.shape[:2]
    if region is None:
        top, left, height, width = 0, 0, H, W
    else:
        try:
            top, left, height, width = (int(v) for v in region)
        except (TypeError, ValueError):
            raise ParameterError("region", f"must be (top, left, height, width), got {region!r}") from None
    top, left = min(max(top, 0), H - 1), min(max(left, 0), W - 1)
    height, width = min(height, H - top), min(width, W - left)
    if height < 1 or width < 1:
        raise ParameterError("region", f"must hold at least one pixel of the {H} x {W} image, got {region!r}")
    part = a[top : top + height, left : left + width]
    block = max(1, math.ceil(height / rows), math.ceil(width / cols))
    dtype = part.dtype if part.dtype in (np.float32, np.float64) else np.float64
    if block == 1:
        return part.astype(dtype, copy=True), 1
    ry, rx = np.arange(0, height, block), np.arange(0, width, block)
    acc = np.float64 if dtype == np.float64 else np.float32
    sums = np.add.reduceat(np.add.reduceat(part.astype(acc, copy=False), ry, axis=0), rx, axis=1)
    ny = np.minimum(block, height - ry).astype(acc)
    nx = np.minimum(block, width - rx).astype(acc)
    counts = ny[:, None] * nx[None, :]
    if sums.ndim == 3:
        counts = counts[:, :, None]
    return (sums / counts).astype(dtype, copy=False), block
