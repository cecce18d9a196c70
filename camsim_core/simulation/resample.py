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
this arctan mapping nor with exact area weights.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ._stage import stage

__all__ = ["resample", "resampled_size", "axis_matrix"]


def _to_camera(P, Phi, phi, D, d):
    return phi * np.degrees(np.arctan((D / d) * np.tan(np.radians(P / Phi))))


def _to_scene(p, Phi, phi, D, d):
    return Phi * np.degrees(np.arctan((d / D) * np.tan(np.radians(p / phi))))


def resampled_size(N, Phi, phi, D, d):
    """Eq. 1.2: pixels ``n`` that ``N`` scene pixels subtend on the camera (before rounding)."""
    return 2.0 * phi * np.degrees(np.arctan((D / d) * np.tan(np.radians(N / (2.0 * Phi)))))


@lru_cache(maxsize=64)
def axis_matrix(N, Phi, phi, D, d, limit=None):
    """(n, N) matrix that resamples one axis of N pixels; n <= ``limit``. Cached, read-only."""
    n_full = int(round(resampled_size(N, Phi, phi, D, d)))
    n_full = max(n_full, 1)
    if n_full == N and abs(Phi / phi - 1) < 1e-12 and abs(D / d - 1) < 1e-12:
        m = np.eye(N)
    elif n_full < N:
        # area weights: output pixel j spans [j - n/2, j + 1 - n/2] in camera pixels
        edges = _to_scene(np.arange(n_full + 1) - n_full / 2.0, Phi, phi, D, d) + N / 2.0
        lo, hi = edges[:-1, None], edges[1:, None]
        k = np.arange(N)[None, :]
        m = np.clip(np.minimum(hi, k + 1) - np.maximum(lo, k), 0.0, None)
        s = m.sum(axis=1, keepdims=True)
        m = np.divide(m, s, out=np.zeros_like(m), where=s > 0)
    else:
        centres = _to_scene(np.arange(n_full) + 0.5 - n_full / 2.0, Phi, phi, D, d) + N / 2.0 - 0.5
        centres = np.clip(centres, 0, N - 1)
        i0 = np.floor(centres).astype(int)
        i1 = np.minimum(i0 + 1, N - 1)
        f = centres - i0
        m = np.zeros((n_full, N))
        rows = np.arange(n_full)
        np.add.at(m, (rows, i0), 1 - f)
        np.add.at(m, (rows, i1), f)
    if limit is not None and m.shape[0] > limit:
        start = (m.shape[0] - limit) // 2
        m = m[start : start + limit]
    m = np.ascontiguousarray(m)
    m.flags.writeable = False
    return m


@stage("angular_resolution", "distance", "height", "width")
def resample(camera, image):
    """Resample the image from its own geometry to the camera's (Eq. 1.2 per axis)."""
    H, W = image.data.shape[:2]
    Phi_x, Phi_y = image.angular_resolution
    phi_x, phi_y = camera.angular_resolution
    D = image.distance
    d = camera.distance if camera.distance is not None else D
    my = axis_matrix(H, float(Phi_y), float(phi_y), float(D), float(d), int(camera.height))
    mx = axis_matrix(W, float(Phi_x), float(phi_x), float(D), float(d), int(camera.width))
    data = image.data
    squeeze = data.ndim == 2
    if squeeze:
        data = data[:, :, None]
    h, w, k = my.shape[0], mx.shape[0], data.shape[2]
    if not _is_identity(my):
        data = (my @ data.reshape(H, W * k)).reshape(h, W, k)
    if not _is_identity(mx):
        # rows of (pixel row, plane) against the x matrix: one 2-D product
        data = (data.transpose(0, 2, 1).reshape(h * k, W) @ mx.T).reshape(h, k, w).transpose(0, 2, 1)
    data = np.ascontiguousarray(data)
    if squeeze:
        data = data[:, :, 0]
    return image.then("resample", data=data, angular_resolution=camera.angular_resolution, distance=d)


def _is_identity(m):
    return m.shape[0] == m.shape[1] and np.array_equal(m, np.eye(m.shape[0]))
