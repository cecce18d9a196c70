"""Stage 2: geometric resampling to the camera's resolution and size (chapter Eqs. 1.1, 1.2).

A point seen at pixel offset ``P`` from the optical axis by the hyperspectral
camera (angular resolution ``Phi``, distance ``D``) lies at lateral position
``x = D tan(P / Phi)`` (angles in degrees) and falls at offset
``p = phi arctan((D / d) tan(P / Phi))`` on the simulated camera (``phi``,
``d``): Eq. 1.2 applied to each pixel edge. Each axis uses its own angular
resolutions. Where the camera is coarser, each output pixel is the
area-weighted mean of the input pixels it covers (no aliasing); where it is
finer, values are interpolated linearly between input pixel centres. The
output is cropped (centred) to the camera's pixel array.

Hand-written: scikit-image and scipy resize with a uniform scale, not with
this arctan mapping nor with exact area weights. Each axis is a band of
weights (:func:`axis_weights`), applied by one numba loop that fuses the two
passes (see :func:`_resample_rows` for why numpy does not get there):
linear in the pixel count, in the image's own dtype.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._compiled import compiled
from .._parallel import CORES, run_blocks, split
from ._stage import stage

__all__ = ["resample", "resampled_size", "axis_matrix", "axis_weights"]


def _to_camera(P, Phi, phi, D, d):
    return phi * np.degrees(np.arctan((D / d) * np.tan(np.radians(P / Phi))))


def _to_scene(p, Phi, phi, D, d):
    return Phi * np.degrees(np.arctan((d / D) * np.tan(np.radians(p / phi))))


def resampled_size(N, Phi, phi, D, d):
    """Eq. 1.2: pixels ``n`` that ``N`` scene pixels subtend on the camera (before rounding)."""
    return 2.0 * phi * np.degrees(np.arctan((D / d) * np.tan(np.radians(N / (2.0 * Phi)))))


@lru_cache(maxsize=64)
def axis_weights(N, Phi, phi, D, d, limit=None):
    """The resampling of one axis of N pixels as a band: (index, weight), each (n, L); n <= ``limit``.

    Output pixel ``j`` is ``sum_t weight[j, t] * input[index[j, t]]`` (unused
    slots have weight 0). The same weights as :func:`axis_matrix`, without
    its zeros: L is 2 when interpolating and about N / n + 1 when area
    averaging, so building and applying it is linear in the pixel count.
    Cached, read-only.
    """
    n_full = max(int(round(resampled_size(N, Phi, phi, D, d))), 1)
    if n_full == N and abs(Phi / phi - 1) < 1e-12 and abs(D / d - 1) < 1e-12:
        idx = np.arange(N)[:, None]
        wts = np.ones((N, 1))
    elif n_full < N:
        # area weights: output pixel j spans [j - n/2, j + 1 - n/2] in camera pixels
        edges = _to_scene(np.arange(n_full + 1) - n_full / 2.0, Phi, phi, D, d) + N / 2.0
        lo, hi = edges[:-1], edges[1:]
        first = np.clip(np.floor(lo).astype(np.intp), 0, N - 1)
        span = int(np.max(np.ceil(hi) - np.floor(lo))) + 1
        k = first[:, None] + np.arange(span)[None, :]
        wts = np.clip(np.minimum(hi[:, None], k + 1) - np.maximum(lo[:, None], k), 0.0, None)
        wts[k >= N] = 0.0
        idx = np.minimum(k, N - 1)
        s = wts.sum(axis=1, keepdims=True)
        wts = np.divide(wts, s, out=np.zeros_like(wts), where=s > 0)
    else:
        centres = _to_scene(np.arange(n_full) + 0.5 - n_full / 2.0, Phi, phi, D, d) + N / 2.0 - 0.5
        centres = np.clip(centres, 0, N - 1)
        i0 = np.floor(centres).astype(np.intp)
        i1 = np.minimum(i0 + 1, N - 1)
        f = centres - i0
        idx = np.stack([i0, i1], axis=1)
        wts = np.stack([1 - f, f], axis=1)
    if limit is not None and idx.shape[0] > limit:
        start = (idx.shape[0] - limit) // 2
        idx, wts = idx[start : start + limit], wts[start : start + limit]
    idx, wts = np.ascontiguousarray(idx, dtype=np.intp), np.ascontiguousarray(wts)
    idx.flags.writeable = False
    wts.flags.writeable = False
    return idx, wts


@lru_cache(maxsize=8)
def axis_matrix(N, Phi, phi, D, d, limit=None):
    """(n, N) matrix that resamples one axis of N pixels; n <= ``limit``. Cached, read-only.

    The dense form of :func:`axis_weights` (for inspection and tests; the
    stage applies the band form).
    """
    idx, wts = axis_weights(N, Phi, phi, D, d, limit)
    m = np.zeros((idx.shape[0], N))
    np.add.at(m, (np.arange(idx.shape[0])[:, None], idx), wts)
    m.flags.writeable = False
    return m


def _resample_rows(src, iy, wy, ixk, wxk, out):
    """out[r, q] = sum_s wy[r, s] sum_t wxk[q, t] src[iy[r, s], ixk[q, t]]: both axis passes, fused.

    ``src`` (H, W K) and ``out`` (h, w K) are the images with each pixel's K
    values side by side; ``ixk``, ``wxk`` (w K, L) the x band spread over them.
    Compiled by numba (:func:`_kernel`): per output row, the y pass
    accumulates whole input rows into one row buffer (contiguous, it
    vectorizes), then the x pass gathers from that buffer. numpy cannot do
    the x pass of an (H, W, K) image without transposing it (strided copies
    of K-value pixels: 5-10x the time of the arithmetic, measured) or one
    full-size temporary per band term; fused, the stage reads its input once
    and writes its output once.
    """
    h, n = out.shape
    row = np.empty(src.shape[1], dtype=out.dtype)
    taps = ixk.shape[1]
    for r in range(h):
        row[:] = 0
        for s in range(iy.shape[1]):
            a = wy[r, s]
            if a != 0:
                line = src[iy[r, s]]
                for x in range(line.size):
                    row[x] += a * line[x]
        o = out[r]
        if taps == 2:  # interpolation (the camera finer than the scene): the two taps written out, 1.4-1.8x
            # faster at 2048^2 -> 3000 x 4000. Summed in the image's dtype: two products of its dtype add
            # exactly in float64, so float64's sum rounded once is the dtype's own correctly rounded sum (the
            # same numbers as the general loop's float64 accumulator; the stage at 1024^2 -> 1012 x 1317: 9.7 -> 7.4 ms)
            for q in range(n):
                o[q] = wxk[q, 0] * row[ixk[q, 0]] + wxk[q, 1] * row[ixk[q, 1]]
        else:
            for q in range(n):
                acc = 0.0
                for t in range(taps):
                    acc += wxk[q, t] * row[ixk[q, t]]
                o[q] = acc


_kernel = compiled(_resample_rows)


@stage("angular_resolution", "distance", "height", "width")
def resample(camera, image):
    """Resample the image from its own geometry to the camera's (Eq. 1.2 per axis).

    Works in the image's floating dtype (float32 stays float32).
    """
    H, W = image.data.shape[:2]
    Phi_x, Phi_y = image.angular_resolution
    phi_x, phi_y = camera.angular_resolution
    D = image.distance
    d = camera.distance if camera.distance is not None else D
    iy, wy = axis_weights(H, float(Phi_y), float(phi_y), float(D), float(d), int(camera.height))
    ix, wx = axis_weights(W, float(Phi_x), float(phi_x), float(D), float(d), int(camera.width))
    data = np.asarray(image.data)
    if data.dtype not in (np.float32, np.float64):
        data = data.astype(np.float64)
    squeeze = data.ndim == 2
    if squeeze:
        data = data[:, :, None]
    if not (_is_identity(iy, H) and _is_identity(ix, W)):
        data = np.ascontiguousarray(data)
        (h, k), w, dt = (iy.shape[0], data.shape[2]), ix.shape[0], data.dtype
        ixk, wxk = _spread(ix, wx, k)
        out = np.empty((h, w, k), dt)
        kernel, src, dst, wyd, wxd = _kernel(), data.reshape(H, W * k), out.reshape(h, w * k), wy.astype(dt), wxk.astype(dt)
        # blocks of output rows on the machine's cores (the kernel releases the GIL; each row is computed alone)
        run_blocks(lambda a, b: kernel(src, iy[a:b], wyd[a:b], ixk, wxd, dst[a:b]), split(h, CORES), values=dst.size)
        data = out
    if squeeze:
        data = data[:, :, 0]
    return image.then("resample", data=data, angular_resolution=camera.angular_resolution, distance=d)


def _spread(ix, wx, k):
    """The x band over pixels of K values side by side: index x K + c, weight repeated."""
    ixk = (ix[:, None, :] * k + np.arange(k)[None, :, None]).reshape(ix.shape[0] * k, ix.shape[1])
    return ixk.astype(np.int32 if ixk.size and ixk.max() < 2**31 else np.intp), np.repeat(wx, k, axis=0)


def _is_identity(idx, n):
    return idx.shape == (n, 1) and np.array_equal(idx[:, 0], np.arange(n))
