"""Private: the odd-size square median filter of Freeman's method, by a pruned sorting network.

``scipy.ndimage.median_filter`` selects each pixel's median on its own
(about 1 us a pixel for 5 x 5); Freeman's method needs it on whole
sensor-size planes. Here the window's samples at every pixel of an output
row sit in ``size^2`` row buffers, and Batcher's odd-even merge sorting
network, pruned to the comparators the middle output depends on, runs on
those rows: each compare-exchange is a min/max over a whole row, which
vectorizes. Written with numba because numpy would need one full-frame
temporary per comparator (about 100 for 5 x 5). The same values as
``median_filter(..., mode="mirror")`` (a median is a selection, no
arithmetic); even sizes go to scipy.

Reference: K. E. Batcher, "Sorting networks and their applications",
AFIPS Spring Joint Computer Conference (1968).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy import ndimage

from .._compiled import compiled
from .._parallel import CORES, run_blocks, split

__all__ = []


def _batcher_pairs(n):
    """Comparators (i, j), i < j, of Batcher's odd-even merge sort on n wires (wires >= n never touched)."""
    pairs = []
    size = 1
    while size < n:
        size *= 2
    p = 1
    while p < size:
        k = p
        while k >= 1:
            for j in range(k % p, size - k, 2 * k):
                for i in range(min(k, size - j - k)):
                    a, b = i + j, i + j + k
                    if (a // (2 * p)) == (b // (2 * p)) and b < n:
                        pairs.append((a, b))
            k //= 2
        p *= 2
    return pairs


@lru_cache(maxsize=8)
def median_network(n):
    """(C, 2) comparators that bring the median of n (odd) values to wire n // 2."""
    need = {n // 2}
    kept = []
    for a, b in reversed(_batcher_pairs(n)):
        if a in need or b in need:
            kept.append((a, b))
            need.update((a, b))
    out = np.array(kept[::-1], dtype=np.int64).reshape(-1, 2)
    out.flags.writeable = False
    return out


def _median_rows(padded, size, pairs, out):
    h, w = out.shape
    n = size * size
    v = np.empty((n, w), dtype=out.dtype)
    for i in range(h):
        for dy in range(size):
            for dx in range(size):
                src = padded[i + dy]
                dst = v[dy * size + dx]
                for x in range(w):
                    dst[x] = src[x + dx]
        for c in range(pairs.shape[0]):
            a = v[pairs[c, 0]]
            b = v[pairs[c, 1]]
            for x in range(w):
                p = a[x]
                q = b[x]
                if q < p:
                    a[x] = q
                    b[x] = p
        mid = v[n // 2]
        for x in range(w):
            out[i, x] = mid[x]


_kernel = compiled(_median_rows)


def median_filter(plane, size):
    """``scipy.ndimage.median_filter(plane, size, mode="mirror")`` of a 2-D plane, in its dtype."""
    size = int(size)
    plane = np.asarray(plane)
    if size % 2 == 0 or min(plane.shape) <= size // 2 or plane.dtype not in (np.float32, np.float64):
        return ndimage.median_filter(plane, size=size, mode="mirror")
    if size == 1:
        return plane.copy()
    r = size // 2
    padded = np.pad(plane, r, mode="reflect")  # scipy's "mirror"
    out = np.empty(plane.shape, plane.dtype)
    kernel, pairs = _kernel(), median_network(size * size)
    # blocks of output rows on the machine's cores (the kernel releases the GIL; each row is computed alone)
    run_blocks(lambda a, b: kernel(padded[a : b + 2 * r], size, pairs, out[a:b]), split(out.shape[0], CORES),
               values=out.size * size)
    return out


def median_of_rows(rows, size, out):
    """The median of ``rows`` (h + 2 r, W), already mirrored by r = size // 2 above and below: ``out`` (h, W).

    The columns are mirrored here (scipy's "mirror"), then the compiled
    sorting network runs over the rows: for callers that filter a plane by
    bands of rows (Freeman's demosaicing) with :func:`median_filter`'s
    numbers. ``size`` odd, W > r, float32 or float64.
    """
    r = size // 2
    kernel = _kernel()
    kernel(np.pad(rows, ((0, 0), (r, r)), mode="reflect"), size, median_network(size * size), out)
    return out
