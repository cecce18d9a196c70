"""Images at screen resolution: what a viewer needs of a sensor-size result.

A 12-megapixel camera image is 4000 x 3000 pixels; a browser shows perhaps
1600 x 1000 of them. :func:`to_screen` returns the part of an image a view
shows, averaged over square blocks of whole pixels (area averaging, so no
aliasing) until it fits the screen, and the block size, so a viewer can map
screen coordinates back to image pixels and ask for the full-resolution
detail of a smaller region when zoomed in.

Hand-written: the image is copied once into a zero-padded buffer of whole
blocks, the k x k strided views of it are summed, and each sum is divided by
the pixels its block really holds (the last row and column of blocks may be
partial). That reads the image once; ``numpy.add.reduceat`` over the two
axes of an (H, W, 4) picture took 7x longer. An 8-bit picture (the
explorer's packed RGBA views) is summed by a compiled loop over its blocks
instead (:func:`_block_means_u8`), without the float32 copy of the whole
picture: the same numbers (whole sums divided in float32) at a fifth of the
time (a 860 x 1295 RGBA view: ~28 ms -> ~6 ms). A view needs exactly this
and nothing of an image library.
"""

from __future__ import annotations

import math

import numpy as np

from ._compiled import compiled
from .errors import ParameterError

__all__ = ["to_screen", "block_size"]


def block_size(shape, max_shape):
    """Image pixels per view pixel (along each axis) that fit an image of ``shape`` into ``max_shape``.

    Examples
    --------
    A 1000 x 3000 image in a 256 x 256 view: 12 x 12 image pixels per view pixel.

    >>> block_size((1000, 3000), (256, 256))
    12
    """
    return max(1, math.ceil(shape[0] / max_shape[0]), math.ceil(shape[1] / max_shape[1]))


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
        (fewer at the region's right and bottom edges), h <= rows, w <= columns;
        float64 for float64 data, float32 otherwise (8- and 16-bit integers
        sum exactly in float32 for blocks of up to 16 x 16 pixels).
    block : int
        Image pixels per view pixel along each axis (1: the region's own pixels).

    Examples
    --------
    >>> import numpy as np
    >>> view, block = to_screen(np.arange(16.0).reshape(4, 4), (2, 2))
    >>> view.tolist(), block
    ([[2.5, 4.5], [10.5, 12.5]], 2)
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
    block = block_size((height, width), (rows, cols))
    dtype = np.float64 if part.dtype == np.float64 else np.float32
    if block == 1:
        return part.astype(dtype, copy=True), 1
    ny, nx = math.ceil(height / block), math.ceil(width / block)
    if part.dtype == np.uint8:  # whole sums divided in float32, as below, in one pass over the picture
        pixels = part.reshape(part.shape[:2] + (-1,))
        out = np.empty((ny, nx, pixels.shape[2]), np.float32)
        _block_means_u8_kernel()(pixels, block, out)
        return out.reshape((ny, nx) + part.shape[2:]), block
    padded = np.zeros((ny * block, nx * block) + part.shape[2:], dtype)
    padded[:height, :width] = part
    sums = padded[0::block, 0::block].copy()
    for dy in range(block):
        for dx in range(block):
            if dy or dx:
                sums += padded[dy::block, dx::block]
    counts = (np.minimum(block, height - np.arange(0, height, block))[:, None]
              * np.minimum(block, width - np.arange(0, width, block))[None, :]).astype(dtype)
    sums /= counts[:, :, None] if sums.ndim == 3 else counts
    return sums, block


def _block_means_u8(pixels, block, out):
    """out[i, j, c] = mean of ``pixels[i b : (i + 1) b, j b : (j + 1) b, c]`` (b = ``block``; fewer pixels at
    the last row and column of blocks): the integer sum divided by the pixel count in float32, as
    :func:`to_screen`'s float path computes it. ``pixels`` (H, W, C) uint8, ``out`` (ny, nx, C) float32.
    Reads the picture row by row, a row of block sums at a time. Compiled by numba (:func:`_block_means_u8_kernel`)."""
    h, w, c = pixels.shape
    ny, nx = out.shape[0], out.shape[1]
    sums = np.zeros((nx, c), np.int64)
    for i in range(ny):
        y0, y1 = i * block, min(h, (i + 1) * block)
        sums[:] = 0
        for y in range(y0, y1):
            for j in range(nx):
                for x in range(j * block, min(w, (j + 1) * block)):
                    for k in range(c):
                        sums[j, k] += pixels[y, x, k]
        for j in range(nx):
            n = np.float32((y1 - y0) * (min(w, (j + 1) * block) - j * block))
            for k in range(c):
                out[i, j, k] = np.float32(sums[j, k]) / n


_block_means_u8_kernel = compiled(_block_means_u8)
