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
import math

import numpy as np
from scipy import ndimage

from .._compiled import compiled
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


#: Single-tier tiles whose tent kernels cover at most this many pixels are interpolated by one pass of
#: per-phase stencils (:func:`_stencil_rows`); larger tiles, and tiers, by the separable passes.
STENCIL_TAPS = 25


@functools.lru_cache(maxsize=32)
def _stencils(tile_bytes, tile_shape, k):
    """Per tile phase and class, the taps of the normalized convolution: what :func:`_stencil_rows` reads.

    For the pixel at tile phase (pi, pj) every neighbour (a, b) within the
    tent's reach belongs to the class the tile gives at phase
    ((pi + a) mod n, (pj + b) mod m): class c's estimate there is the
    weighted sum of the neighbours of class c over the sum of their weights
    (the weights ``tent(n)[a] tent(m)[b]``). Returns (own (n, m), starts
    (n m k + 1,), dy, dx, weights, weight sums (n m k,)); the taps of phase
    p = pi m + pj and class c are ``starts[p k + c] : starts[p k + c + 1]``.
    """
    tile = np.frombuffer(tile_bytes, np.int64).reshape(tile_shape)
    n, m = tile_shape
    ky, kx = tent(n), tent(m)
    starts, dy, dx, w, wsum = [0], [], [], [], []
    for pi in range(n):
        for pj in range(m):
            for c in range(k):
                for a in range(-(n - 1), n):
                    for b in range(-(m - 1), m):
                        if tile[(pi + a) % n, (pj + b) % m] == c:
                            dy.append(a)
                            dx.append(b)
                            w.append(ky[a + n - 1] * kx[b + m - 1])
                starts.append(len(dy))
                wsum.append(sum(w[starts[-2] :]))
    out = (tile.copy(), np.array(starts, np.int64), np.array(dy, np.int64), np.array(dx, np.int64),
           np.array(w, np.float64), np.array(wsum, np.float64))
    for a in out:
        a.flags.writeable = False
    return out


def _stencil_rows(data, own, starts, dy, dx, w, wsum, out, r0, r1):
    """Rows r0..r1 of the bilinear estimate (H, W, K) of a single-tier mosaic ``data`` (H, W), one pass.

    Each pixel keeps its own class's value; every other class c is the
    weighted mean of the class-c neighbours its phase's stencil lists
    (:func:`_stencils`), accumulated in float64, a row's pixels of one
    phase at a time (each tap one strided run along the row). Within the
    tent's reach of an edge, taps outside the image are left out of both
    sums (the mean over the samples that exist, as the separable passes'
    zero padding gives). Compiled by numba (:func:`_stencil_kernel`).
    """
    H, W = data.shape
    n, m = own.shape
    K = out.shape[2]
    ry, rx = n - 1, m - 1
    acc = np.empty(W)
    for i in range(r0, r1):
        pi = i % n
        inner_row = i >= ry and i < H - ry
        for pj in range(m):
            o = own[pi, pj]
            for j in range(pj, W, m):
                out[i, j, o] = data[i, j]
            # the phase's columns away from the left and right edges: lo, lo + m, ... < hi
            lo = pj + ((rx - pj + m - 1) // m) * m if pj < rx else pj
            hi = W - rx if inner_row else lo
            if hi < lo:
                hi = lo
            for c in range(K):
                if c == o:
                    continue
                q = (pi * m + pj) * K + c
                for j in range(lo, hi, m):
                    acc[j] = 0.0
                for t in range(starts[q], starts[q + 1]):
                    wt, row, d = w[t], i + dy[t], dx[t]
                    for j in range(lo, hi, m):
                        acc[j] += wt * data[row, j + d]
                total = wsum[q]
                if total > 0 and math.frexp(total)[0] == 0.5:
                    # a power of two (Bayer's sums): dividing is multiplying by its inverse, exactly
                    inverse = 1.0 / total
                    for j in range(lo, hi, m):
                        out[i, j, c] = acc[j] * inverse
                else:
                    for j in range(lo, hi, m):
                        out[i, j, c] = acc[j] / total if total > 0 else 0.0
                # the pixels near an edge, the phase's columns before lo and from the first at or past hi
                # (all of them in the top and bottom rows): only the taps inside the image
                past = lo + ((hi - lo + m - 1) // m) * m
                for side in range(2):
                    j0, j1 = (pj, min(lo, W)) if side == 0 else (past, W)
                    for j in range(j0, j1, m):
                        s, tw = 0.0, 0.0
                        for t in range(starts[q], starts[q + 1]):
                            ii, jj = i + dy[t], j + dx[t]
                            if ii >= 0 and ii < H and jj >= 0 and jj < W:
                                s += w[t] * data[ii, jj]
                                tw += w[t]
                        out[i, j, c] = s / tw if tw > 0 else 0.0


_stencil_kernel = compiled(_stencil_rows)


def _bilinear_by_stencils(data, tile, k):
    """:func:`bilinear_planes` of a single-tier mosaic (H, W) with a small tile, by :func:`_stencil_rows`."""
    t = np.ascontiguousarray(tile, np.int64)
    own, starts, dy, dx, w, wsum = _stencils(t.tobytes(), t.shape, int(k))
    H, W = data.shape
    out = np.empty((H, W, k), data.dtype)
    kernel = _stencil_kernel()
    data = np.ascontiguousarray(data)
    # blocks of rows on the machine's cores (the kernel releases the GIL; each block writes its own rows)
    run_blocks(lambda a, b: kernel(data, own, starts, dy, dx, w, wsum, out, a, b), split(H, CORES), values=out.size)
    return out


def bilinear_planes(data, tile, k):
    """(H, W, K) bilinear estimate from planes ``data`` (H, W, T) and tile (n, m, T), in ``data``'s dtype.

    A single-tier tile of period up to 3 (Bayer, the 2 x 2 grid, 3 x 3
    tiles: :data:`STENCIL_TAPS`) takes one pass of per-phase stencils
    (:func:`_stencil_rows`), faster than the separable passes on Bayer raws
    (1.5x at 233 x 372, 2.7x at 1012 x 1317, 2.1x at 3000 x 4000, one BLAS
    thread) and 1.1-1.9x on a 3 x 3 tile; at period 4 the two cost the same. Larger tiles and tiers take the passes:
    per class, its samples placed in a zero plane, two 1-D tent passes
    (the second written straight into the output plane), then one multiply
    per row by the inverse of the sample-count convolution, which repeats
    with the tile except near the top and bottom edges
    (:func:`_row_denominators`), so the counts are never convolved at full size.
    By bands of rows (:data:`BAND_PIXELS`, a whole tile's rows at least):
    a band's passes stay in the CPU's cache, so the time is linear in the
    pixel count, and the temporaries are a band's, not a frame's.
    """
    dtype = data.dtype if data.dtype in (np.float32, np.float64) else np.float64
    if tile.shape[2] == 1 and (2 * tile.shape[0] - 1) * (2 * tile.shape[1] - 1) <= STENCIL_TAPS:
        return _bilinear_by_stencils(data[:, :, 0].astype(dtype, copy=False), tile[:, :, 0], k)
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
