"""Per-pixel work by chunks of pixels, so that a 12-megapixel image's temporaries stay a few MiB.

Hand-written (a loop over slices): numpy evaluates an expression over the
whole array at once, one full-size temporary per operation; dask would do
this and more, at a cost per call that the small images of the explorer
would feel.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CHUNK_PIXELS", "map_pixels"]

#: Pixels per chunk: 262,144 (about 3 MiB per float32 temporary of three channels).
CHUNK_PIXELS = 1 << 18


def map_pixels(fn, *arrays, chunk=CHUNK_PIXELS):
    """``fn(*chunks)`` over chunks of (n, C) rows of ``arrays`` (..., C), all of the same leading shape.

    ``fn`` takes and returns per-pixel rows: (n, C) -> (n, C') or (n,).
    The result has the arrays' leading shape and ``fn``'s trailing one and
    dtype (as ``fn`` returns for the first chunk). An image of at most one
    chunk is a single call of ``fn`` on the whole.
    """
    lead = arrays[0].shape[:-1]
    flats = [np.asarray(a).reshape(-1, a.shape[-1]) for a in arrays]
    n = flats[0].shape[0]
    if n <= chunk:
        first = fn(*flats)
        return first.reshape(lead + first.shape[1:])
    out = None
    for start in range(0, n, chunk):
        part = fn(*(f[start : start + chunk] for f in flats))
        if out is None:
            out = np.empty((n,) + part.shape[1:], part.dtype)
        out[start : start + chunk] = part
    return out.reshape(lead + out.shape[1:])
