"""Freeman's demosaicing (chapter section 4.1, reference 21): median-filtered colour differences.

Bilinear interpolation first; then, for every class ``k`` other than the
reference class (the one the tile samples most often, G on a Bayer tile),
the difference image ``X_k - X_ref`` is median filtered and added back to
``X_ref``: ``X_k = X_ref + median(X_k - X_ref)``. Samples the mosaic holds
are kept unchanged. Colour differences vary slowly, so the median removes
the colour fringes bilinear interpolation leaves at luminance edges.

Reference: W. T. Freeman, "Median filter for reconstructing missing color
samples", US patent 4,724,395 (1988). The median is
``scipy.ndimage.median_filter``'s (mirrored edges), computed by a pruned
sorting network (:mod:`._median`, ~20x faster on sensor-size planes), by
bands of rows on the machine's cores (the difference, its median and the
sum for a band at a time: the numbers of whole planes, in cache); the rest
is hand-written for any tile.
"""

from __future__ import annotations

import numpy as np

from .._parallel import CORES, run_blocks, split
from ..errors import ParameterError
from ._masks import check_mosaiced
from ._median import median_filter, median_of_rows
from .bilinear import BAND_PIXELS, bilinear_planes

__all__ = ["demosaic_freeman", "reference_class"]


def reference_class(tile, k):
    """The class sampled most often by the tile (the lowest index on a tie)."""
    counts = np.bincount(np.asarray(tile).ravel(), minlength=k)
    return int(np.argmax(counts))


def demosaic_freeman(image, size=5):
    """Bilinear, then median-filtered differences to the most numerous class (``size`` x ``size`` median)."""
    if int(size) < 1:
        raise ParameterError("size", f"the median filter size must be >= 1, got {size}")
    data, tile, k = check_mosaiced(image, "freeman")
    est = bilinear_planes(data, tile, k)
    ref = reference_class(tile, k)
    size = int(size)
    H, W = est.shape[:2]
    if size % 2 == 0 or min(H, W) <= size // 2 or est.dtype not in (np.float32, np.float64):
        return _by_planes(est, tile, k, ref, size)
    n, m, _ = tile.shape
    r = size // 2
    out = np.empty_like(est)
    out[:, :, ref] = est[:, :, ref]
    mirror = np.pad(np.arange(H), r, mode="reflect")  # the row of the image each mirrored row repeats
    classes = [(c, sorted({(int(a), int(b)) for a, b, _ in np.argwhere(tile == c)})) for c in range(k) if c != ref]
    band = max(1, BAND_PIXELS // max(W, 1))

    def bands(i, j):
        for bi in range(i, j):
            a, b = bi * band, min(H, (bi + 1) * band)
            take = mirror[a : b + 2 * r]
            whole = take[-1] - take[0] == take.size - 1  # no mirrored row: slices, not copies
            for c, positions in classes:
                rows = slice(take[0], take[-1] + 1) if whole else take
                med = median_of_rows(est[rows, :, c] - est[rows, :, ref], size, np.empty((b - a, W), est.dtype))
                med += est[a:b, :, ref]
                # where the mosaic samples c, the bilinear estimate is the sample itself: keep it
                for py, px in positions:
                    s0 = a + (py - a) % n
                    med[s0 - a :: n, px::m] = est[s0:b:n, px::m, c]
                out[a:b, :, c] = med

    # bands of rows on the machine's cores (the median kernel releases the GIL; each band writes its own rows)
    run_blocks(bands, split(-(-H // band), CORES), values=est.size * size)
    return out


def _by_planes(est, tile, k, ref, size):
    """Freeman's step on whole planes (median sizes or images the banded path does not take)."""
    n, m, _ = tile.shape
    out = est.copy()
    for c in range(k):
        if c == ref:
            continue
        diff = median_filter(est[:, :, c] - est[:, :, ref], size)
        diff += est[:, :, ref]
        for py, px in {(int(a), int(b)) for a, b, _ in np.argwhere(tile == c)}:
            diff[py::n, px::m] = est[py::n, px::m, c]
        out[:, :, c] = diff
    return out
