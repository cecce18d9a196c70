"""Bilinear demosaicing of any periodic mosaic (chapter section 4.1, the simulator's baseline).

Each sensor class is interpolated on its own: a normalized convolution of
its samples with the bilinear (tent) kernel of the tile's period. For
classes sampled on a rectangular lattice (the 2 x 2 grid of Figure 1.15, R
and B of a Bayer tile) this is bilinear interpolation; for the quincunx G of
a Bayer tile it is the mean of the four nearest G samples; on a Bayer tile
the result equals the standard Bayer bilinear filters (e.g.
``colour_demosaicing.demosaicing_CFA_Bayer_bilinear``) away from the
border. At the border the mean is over the samples that exist (no padding).
Sampled values are kept unchanged.

Hand-written: colour-demosaicing handles Bayer tiles only.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ._masks import check_mosaiced, sampled

__all__ = ["demosaic_bilinear", "tent"]


def tent(period):
    """The 1-D linear-interpolation kernel of a lattice of ``period`` pixels: ``period - |k|``."""
    k = np.arange(-(period - 1), period)
    return (period - np.abs(k)).astype(float)


def _separable(plane, ky, kx):
    out = ndimage.correlate1d(plane, ky, axis=0, mode="constant")
    return ndimage.correlate1d(out, kx, axis=1, mode="constant")


def bilinear_planes(data, tile, k):
    """(H, W, K) bilinear estimate from planes ``data`` (H, W, T) and tile (n, m, T)."""
    vals, count = sampled(data, tile, k)
    ky, kx = tent(tile.shape[0]), tent(tile.shape[1])
    out = np.empty(data.shape[:2] + (k,))
    for c in range(k):
        num = _separable(vals[:, :, c], ky, kx)
        den = _separable(count[:, :, c], ky, kx)
        est = num / np.where(den > 0, den, 1.0)
        have = count[:, :, c] > 0
        out[:, :, c] = np.where(have, vals[:, :, c] / np.where(have, count[:, :, c], 1.0), est)
    return out


def demosaic_bilinear(image):
    """Bilinear interpolation of each sensor class (the chapter's baseline demosaicing)."""
    data, tile, k = check_mosaiced(image, "bilinear")
    return bilinear_planes(data, tile, k)
