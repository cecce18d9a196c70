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

import functools

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


#: Pixels per band of rows (about 1 MiB of float32 per plane: a band's passes stay in the CPU's cache).
BAND_PIXELS = 1 << 18


def _class_plan(tile, c, shape, dtype):
    """What every band needs of class ``c``: its tile positions, the row types and inverse denominators.

    Kept for the last few tiles and image shapes (:func:`_cached_plan`): they depend on nothing else, and
    the explorer demosaics images of one shape and tile move after move (the plan is a third of a
    bilinear demosaic of the default scene: a Python loop over the rows).
    """
    t = np.ascontiguousarray(tile)
    return _cached_plan(t.tobytes(), t.shape, t.dtype.str, int(c), tuple(int(v) for v in shape), np.dtype(dtype).str)


@functools.lru_cache(maxsize=32)
def _cached_plan(tile_bytes, tile_shape, tile_dtype, c, shape, dtype):
    tile = np.frombuffer(tile_bytes, tile_dtype).reshape(tile_shape)
    row_type, rows = _row_denominators(tile, c, shape, tent(tile_shape[0]), tent(tile_shape[1]))
    inv = (1.0 / np.where(rows > 0, rows, 1.0)).astype(dtype)
    row_type.flags.writeable = inv.flags.writeable = False
    return _positions(tile, c), row_type, inv


def _interpolate_rows(data, tile, plan, ky, kx, out, a, b):
    """Rows a..b of one class's bilinear estimate into ``out`` (H, W), a view of any strides.

    The class's samples of rows a - r .. b + r (r the tent's reach; zero
    outside the image, as the whole image's constant-mode passes see) are
    placed in a zero band, passed vertically then horizontally (the second
    pass written straight into the output rows), multiplied by the inverse
    sample-count convolution of each row, and the sampled values put back:
    the numbers of the whole image's passes, one band of rows at a time.
    """
    pos, row_type, inv = plan
    H, W = out.shape
    n, m, _ = tile.shape
    r = (ky.size - 1) // 2
    lo, hi, top = max(0, a - r), min(H, b + r), a - r  # image rows the band reaches; band row 0 is image row top
    vals = np.zeros((b - a + 2 * r, W), out.dtype)
    for py, px, t in pos:
        s = lo + (py - lo) % n
        vals[s - top : hi - top : n, px::m] += data[s:hi:n, px::m, t]
    v = ndimage.correlate1d(vals, ky, axis=0, mode="constant")[r : r + b - a]
    ndimage.correlate1d(v, kx, axis=1, mode="constant", output=out[a:b])
    # the denominator repeats with the tile's row phase away from the top and bottom edges
    ia, ib = max(a, min(r, H)), min(b, max(min(r, H), H - r))
    for p in range(n):
        start = ia + (p - ia) % n
        if start < ib:
            out[start:ib:n] *= inv[row_type[start]]
    for i in [i for i in range(a, b) if not ia <= i < ib]:
        out[i] *= inv[row_type[i]]
    # sampled values are kept unchanged (the mean over tiers where several sample c)
    done = set()
    for py, px, _t in pos:
        if (py, px) in done:
            continue
        done.add((py, px))
        tiers = [t for (qy, qx, t) in pos if (qy, qx) == (py, px)]
        s = a + (py - a) % n
        v = data[s:b:n, px::m, tiers[0]].astype(out.dtype)
        for t in tiers[1:]:
            v = v + data[s:b:n, px::m, t]
        out[s:b:n, px::m] = v / len(tiers) if len(tiers) > 1 else v


def bilinear_planes(data, tile, k):
    """(H, W, K) bilinear estimate from planes ``data`` (H, W, T) and tile (n, m, T), in ``data``'s dtype.

    Per class: its samples placed in a zero plane, two 1-D tent passes
    (the second written straight into the output plane), then one multiply
    per row by the inverse of the sample-count convolution, which repeats
    with the tile except near the top and bottom edges
    (:func:`_row_denominators`), so the counts are never convolved at full size.
    By bands of rows (:data:`BAND_PIXELS`, a whole tile's rows at least):
    a band's passes stay in the CPU's cache, so the time is linear in the
    pixel count, and the temporaries are a band's, not a frame's.
    """
    dtype = data.dtype if data.dtype in (np.float32, np.float64) else np.float64
    ky, kx = tent(tile.shape[0]), tent(tile.shape[1])
    H, W = data.shape[:2]
    out = np.empty((H, W, k), dtype)
    plans = [_class_plan(tile, c, (H, W), dtype) for c in range(k)]
    n = tile.shape[0]
    band = max(n, -(-max(1, BAND_PIXELS // max(W, 1)) // n) * n)
    count = -(-H // band)

    def bands(i, j):
        for bi in range(i, j):
            a, b = bi * band, min(H, (bi + 1) * band)
            for c in range(k):
                _interpolate_rows(data, tile, plans[c], ky, kx, out[:, :, c], a, b)

    # the bands on the machine's cores (scipy.ndimage's filters release the GIL; each band is written alone)
    run_blocks(bands, split(count, CORES), values=out.size)
    return out


def demosaic_bilinear(image):
    """Bilinear interpolation of each sensor class (the chapter's baseline demosaicing)."""
    data, tile, k = check_mosaiced(image, "bilinear")
    return bilinear_planes(data, tile, k)
