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

from .._parallel import CORES, run_blocks, split
from ._masks import check_mosaiced

__all__ = ["demosaic_bilinear", "tent"]


def tent(period):
    """The 1-D linear-interpolation kernel of a lattice of ``period`` pixels: ``period - |k|``."""
    k = np.arange(-(period - 1), period)
    return (period - np.abs(k)).astype(float)


def _separable(plane, ky, kx, output=None):
    out = ndimage.correlate1d(plane, ky, axis=0, mode="constant")
    return ndimage.correlate1d(out, kx, axis=1, mode="constant", output=output)


def _positions(tile, c):
    """(py, px, tier) of every tile position and tier that samples class ``c``."""
    return [tuple(int(v) for v in p) for p in np.argwhere(np.asarray(tile) == c)]


def _row_denominators(tile, c, shape, ky, kx):
    """The normalized convolution's denominator, compactly: (row_type (H,), rows (R, W)).

    The denominator ``sum ky[a] kx[b] count(i + a, j + b)`` (zero outside the
    image) depends on the row only through its tile phase, except within a
    kernel's reach of the top and bottom edges: ``rows[row_type[i]]`` is row
    ``i`` of it, so it never takes a full frame.
    """
    H, W = shape
    n, m, _ = tile.shape
    counts = np.zeros((n, W))
    for py, px, _t in _positions(tile, c):
        counts[py, px::m] += 1.0
    cx = ndimage.correlate1d(counts, kx, axis=1, mode="constant")  # (n, W): per row phase
    r = (ky.size - 1) // 2
    keys, rows, row_type = {}, [], np.empty(H, np.intp)
    for i in range(H):
        lo, hi = max(0, i - r), min(H, i + r + 1)
        near_edge = i - r < 0 or i + r >= H
        key = (i % n,) if not near_edge else ("edge", i)
        if key not in keys:
            den = np.zeros(W)
            for ii in range(lo, hi):
                den += ky[ii - i + r] * cx[ii % n]
            keys[key] = len(rows)
            rows.append(den)
        row_type[i] = keys[key]
    return row_type, np.array(rows)


def _interpolate(data, tile, c, ky, kx, out):
    """Class ``c`` of the bilinear estimate into ``out`` (H, W), a view of any strides."""
    H, W, _ = data.shape
    n, m, _ = tile.shape
    pos = _positions(tile, c)
    vals = np.zeros((H, W), out.dtype)
    for py, px, t in pos:
        vals[py::n, px::m] += data[py::n, px::m, t]
    _separable(vals, ky, kx, output=out)
    row_type, rows = _row_denominators(tile, c, (H, W), ky, kx)
    inv = 1.0 / np.where(rows > 0, rows, 1.0)
    inv = inv.astype(out.dtype)
    r = (ky.size - 1) // 2
    interior = range(min(r, H), max(min(r, H), H - r))
    for p in range(n):
        start = next((i for i in interior if i % n == p), None)
        if start is not None:
            stop = interior.stop
            out[start:stop:n] *= inv[row_type[start]]
    for i in list(range(0, min(r, H))) + list(range(max(min(r, H), H - r), H)):
        out[i] *= inv[row_type[i]]
    # sampled values are kept unchanged (the mean over tiers where several sample c)
    done = set()
    for py, px, _t in pos:
        if (py, px) in done:
            continue
        done.add((py, px))
        tiers = [t for (qy, qx, t) in pos if (qy, qx) == (py, px)]
        v = data[py::n, px::m, tiers[0]].astype(out.dtype)
        for t in tiers[1:]:
            v = v + data[py::n, px::m, t]
        out[py::n, px::m] = v / len(tiers) if len(tiers) > 1 else v


def bilinear_planes(data, tile, k):
    """(H, W, K) bilinear estimate from planes ``data`` (H, W, T) and tile (n, m, T), in ``data``'s dtype.

    Per class: its samples placed in a zero plane, two 1-D tent passes
    (the second written straight into the output plane), then one multiply
    per row by the inverse of the sample-count convolution, which repeats
    with the tile except near the top and bottom edges
    (:func:`_row_denominators`), so the counts are never convolved at full size.
    """
    dtype = data.dtype if data.dtype in (np.float32, np.float64) else np.float64
    ky, kx = tent(tile.shape[0]), tent(tile.shape[1])
    out = np.empty(data.shape[:2] + (k,), dtype)

    def classes(a, b):
        for c in range(a, b):
            _interpolate(data, tile, c, ky, kx, out[:, :, c])

    # the classes on the machine's cores (scipy.ndimage's filters release the GIL; each class is computed alone)
    run_blocks(classes, split(k, CORES), values=out.size)
    return out


def demosaic_bilinear(image):
    """Bilinear interpolation of each sensor class (the chapter's baseline demosaicing)."""
    data, tile, k = check_mosaiced(image, "bilinear")
    return bilinear_planes(data, tile, k)
