"""Private helpers shared by the demosaicing methods: tiles, sample masks, phase-keeping padding."""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..image import check_tile

__all__ = []


def n_classes(image):
    """Number of sensor classes: from the sensitivities if known, else from the tile."""
    if image.n_sensors:
        return image.n_sensors
    if image.sensor_names:
        return len(image.sensor_names)
    return int(np.max(image.tile)) + 1


def check_mosaiced(image, method):
    """The tile (n, m, T) of a mosaiced image, with planes (H, W, T); else a ParameterError."""
    if not image.mosaiced or image.tile is None:
        raise ParameterError(
            "demosaic",
            f"the image is not mosaiced (space {image.space!r}, mosaiced={image.mosaiced}): "
            f"there is nothing to demosaic with {method!r}",
        )
    k = n_classes(image)
    tile = check_tile(image.tile, k, "tile")
    data = np.asarray(image.data)
    if data.dtype not in (np.float32, np.float64):  # float32 raws stay float32
        data = data.astype(np.float64)
    if tile.ndim == 2:
        tile = tile[:, :, None]
    if data.ndim == 2:
        data = data[:, :, None]
    if data.shape[2] != tile.shape[2]:
        raise ParameterError("tile", f"has {tile.shape[2]} tiers but the mosaic has {data.shape[2]} planes")
    missing = sorted(set(range(k)) - set(np.unique(tile).tolist()))
    if missing:
        raise ParameterError("tile", f"never samples sensor class(es) {missing}: they cannot be demosaiced")
    return data, tile, k


def index_map(tile, shape):
    """(H, W, T) sensor index at every pixel and tier."""
    n, m, _ = tile.shape
    H, W = shape
    return np.tile(tile, (-(-H // n), -(-W // m), 1))[:H, :W]


def class_masks(tile, shape, k):
    """(H, W, T, K) boolean: tier t of pixel (i, j) samples class k."""
    idx = index_map(tile, shape)
    return idx[..., None] == np.arange(k)


def sampled(data, tile, k):
    """Per class: values (H, W, K) (zero where not sampled) and sample counts (H, W, K), summed over tiers."""
    idx = index_map(tile, data.shape[:2])
    vals = np.zeros(data.shape[:2] + (k,))
    count = np.zeros(data.shape[:2] + (k,))
    for t in range(tile.shape[2]):
        for c in np.unique(tile[:, :, t]):
            mask = idx[:, :, t] == c
            vals[:, :, c] += np.where(mask, data[:, :, t], 0.0)
            count[:, :, c] += mask
    return vals, count


def phase_pad_index(size, pad, period):
    """Indices of a padded axis that reflect about the edge while keeping the tile phase.

    Index ``-k`` maps to ``-k + period * ceil(2k / period)`` (the sample of the
    same phase nearest to the mirror image ``k``), and symmetrically at the far end.
    """
    i = np.arange(-pad, size + pad)
    lo = i < 0
    hi = i >= size
    k = -i[lo]
    i[lo] = -k + period * (-(-2 * k // period))
    k = i[hi] - (size - 1)
    i[hi] = (size - 1) + k - period * (-(-2 * k // period))
    if i.min() < 0 or i.max() >= size:
        raise ParameterError("image", f"is too small ({size} pixels) for a neighbourhood of {2 * pad + 1}")
    return i


def bayer_pattern(tile, k):
    """'RGGB'-style pattern string and the class order (R, G, B) for a 2 x 2 Bayer tile, else None.

    A Bayer tile has 3 classes, one of them twice on a diagonal. The other
    two are called R and B in index order (the Bayer methods treat them alike).
    """
    t = np.asarray(tile)
    if t.ndim == 3:
        if t.shape[2] != 1:
            return None
        t = t[:, :, 0]
    if t.shape != (2, 2) or k != 3:
        return None
    vals, counts = np.unique(t, return_counts=True)
    if vals.size != 3 or counts.max() != 2:
        return None
    g = int(vals[counts == 2][0])
    if t[0, 0] != t[1, 1] and t[0, 1] != t[1, 0]:
        return None
    r, b = (int(v) for v in vals if v != g)
    letter = {r: "R", g: "G", b: "B"}
    return "".join(letter[int(v)] for v in t.ravel()), (r, g, b)
