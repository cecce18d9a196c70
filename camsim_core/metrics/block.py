"""Registered, block-averaged CIELAB comparison of two images (chapter section 3.2, Figure 1.13).

S-CIELAB is not meant to judge the small spatial differences that always
remain between a real and a simulated image, so the chapter compares their
colour block by block: register the two images, average each over N x N
blocks (50 x 50 in the chapter), and take Delta E*ab between corresponding
block means; the histogram and median summarize the result.

Registration (:func:`register`) finds one scale and one translation: for
each candidate scale the moving image is resampled to the fixed image's
pixel size and the translation is the peak of the normalized
cross-correlation (``skimage.feature.match_template``) of the central part
of the smaller image inside the larger one (so a crop is found inside a
full view). Scales are searched coarse to fine (4 % steps on images
halved in size, then 1 % and 0.25 % steps at full resolution), and the
translation is refined to 1/10 pixel with
``skimage.registration.phase_cross_correlation`` on the overlap. Block
means are taken in linear XYZ, then converted to L*a*b* (colour-science).

Hand-written: the scale search and the overlap bookkeeping (scikit-image
registers translation only; its log-polar route to scale needs images of
the same field of view, not a crop inside a larger one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.ndimage as ndi

from ..errors import ParameterError
from .cielab import _method, _xyz_to_lab, check_white, check_xyz, delta_e_lab

__all__ = ["Registration", "BlockComparison", "register", "warp_to", "block_average", "block_compare"]

#: D65 white chromaticity (x, y), used when no white is given.
_D65_XY = (0.31272, 0.32903)


@dataclass(frozen=True)
class Registration:
    """How the moving image maps onto the fixed one.

    A point at pixel coordinates ``(r, c)`` of the fixed image (pixel centres,
    (0, 0) the top-left pixel) is at ``(scale * r + shift[0], scale * c +
    shift[1])`` in the moving image: ``scale`` is moving pixels per fixed
    pixel, ``shift`` (rows, columns) in moving pixels is where the fixed
    image's top-left pixel lies in the moving image. ``score`` is the peak
    normalized cross-correlation (1 = identical up to gain and offset).
    """

    scale: float
    shift: tuple
    score: float


@dataclass(frozen=True, eq=False)
class BlockComparison:
    """Result of :func:`block_compare`.

    Attributes
    ----------
    delta_e : ndarray (rows, cols)
        Delta E between corresponding block means.
    block : int
        Block side in pixels of the first image.
    registration : Registration
    overlap : tuple (row0, row1, col0, col1)
        The compared region in the first image's pixels (half-open).
    means1, means2 : ndarray (rows, cols, 3)
        Block-mean XYZ of the two images.
    white : ndarray (3,)
    method : str
    """

    delta_e: np.ndarray
    block: int
    registration: Registration
    overlap: tuple
    means1: np.ndarray
    means2: np.ndarray
    white: np.ndarray
    method: str = "CIE 1976"
    extra: dict = field(default_factory=dict)

    @property
    def median(self):
        """Median Delta E over blocks (the chapter's summary, 6.0 for its Figure 1.13)."""
        return float(np.median(self.delta_e))

    @property
    def mean(self):
        return float(np.mean(self.delta_e))

    @property
    def n_blocks(self):
        return int(self.delta_e.size)

    def histogram(self, bins=10, range=None):
        """``numpy.histogram`` of the block Delta E values: (counts, edges)."""
        return np.histogram(self.delta_e.ravel(), bins=bins, range=range)


# ---------------------------------------------------------------------------
# registration
# ---------------------------------------------------------------------------
def _luminance(img, name):
    a = np.asarray(img, dtype=float)
    if a.ndim == 3 and a.shape[-1] == 3:
        a = a[..., 1]  # Y of XYZ
    if a.ndim != 2 or min(a.shape) < 2:
        raise ParameterError(name, f"must be an (H, W) or (H, W, 3) XYZ image, got shape {np.shape(img)}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(name, "contains NaN or infinite values")
    return a


def _resample(plane, scale, shape, shift=(0.0, 0.0), cval=0.0, order=1):
    """Sample ``plane`` at ``scale * (r, c) + shift`` for (r, c) on a ``shape`` grid.

    Downsampling (scale > 1) is preceded by a Gaussian blur of sigma
    ``(scale - 1) / 2`` pixels (scikit-image's anti-aliasing rule).
    """
    if scale > 1:
        plane = ndi.gaussian_filter(plane, (scale - 1) / 2.0, mode="nearest")
    rr = scale * np.arange(shape[0]) + shift[0]
    cc = scale * np.arange(shape[1]) + shift[1]
    coords = np.meshgrid(rr, cc, indexing="ij")
    return ndi.map_coordinates(plane, coords, order=order, mode="constant", cval=cval)


def _centre_crop(shape, size):
    """Top-left corner of a centred crop of ``size`` in ``shape``."""
    return tuple((s - z) // 2 for s, z in zip(shape, size))


def _match_at_scale(fixed, moving, scale, margin):
    """Best integer translation t (fixed pixels) and NCC for ``fixed(r) ~ moving_rescaled(r + t)``."""
    out_shape = tuple(max(2, int(math.floor((n - 1) / scale)) + 1) for n in moving.shape)
    m = _resample(moving, scale, out_shape)
    fixed_is_template = fixed.size <= m.size
    template, image = (fixed, m) if fixed_is_template else (m, fixed)
    size = tuple(
        max(2, min(int(round(t * (1 - 2 * margin))), i)) for t, i in zip(template.shape, image.shape)
    )
    r0, c0 = _centre_crop(template.shape, size)
    tpl = template[r0 : r0 + size[0], c0 : c0 + size[1]]
    if np.ptp(tpl) == 0 or np.ptp(image) == 0:
        return (0.0, 0.0), -np.inf
    from skimage.feature import match_template  # here, not at import: it loads scipy.signal (~0.6 s a process)

    ncc = match_template(image, tpl)
    i, j = np.unravel_index(np.argmax(ncc), ncc.shape)
    score = float(ncc[i, j])
    if fixed_is_template:
        t = (i - r0, j - c0)
    else:
        t = (r0 - i, c0 - j)
    return (float(t[0]), float(t[1])), score


def _scale_grid(scales, step=1.04):
    if scales is None:
        return np.array([1.0])
    s = np.asarray(scales, dtype=float).ravel()
    if s.size == 0 or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise ParameterError("scales", f"must be positive scale factors or a (min, max) range, got {scales!r}")
    if s.size == 2 and s[1] > s[0]:
        n = max(3, int(math.ceil(math.log(s[1] / s[0]) / math.log(step))) + 1)
        return np.geomspace(s[0], s[1], n)
    return s


def _halve(a):
    """2 x 2 block means (one pyramid level down)."""
    h, w = (a.shape[0] // 2) * 2, (a.shape[1] // 2) * 2
    return a[:h, :w].reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3))


def _best(f, m, candidates, margin, previous=None):
    results = [(_match_at_scale(f, m, s, margin), s) for s in candidates]
    if previous is not None:
        results.append(previous)
    return max(results, key=lambda r: r[0][1])


def register(fixed, moving, *, scales=(0.5, 2.0), margin=0.1, subpixel=True):
    """Find the scale and translation that map ``fixed`` pixels onto ``moving`` pixels.

    Parameters
    ----------
    fixed, moving : array_like (H, W) or (H, W, 3) XYZ (Y is used)
    scales : (min, max), sequence of candidates, or None
        A (min, max) pair is searched coarse to fine: 4 % steps on images
        halved in size (2 x 2 means, when both are at least 64 pixels), then
        1 % and 0.25 % steps at full resolution around the best; a longer
        sequence is taken as the candidates; ``None`` registers translation only.
    margin : float
        Fraction cut from each side of the smaller image before matching,
        so that a partial overlap is still found.
    subpixel : bool
        Refine the translation to 0.1 pixel by phase correlation.

    Returns
    -------
    Registration
    """
    f = _luminance(fixed, "fixed")
    m = _luminance(moving, "moving")
    if not 0 <= margin < 0.5:
        raise ParameterError("margin", f"must be in [0, 0.5), got {margin!r}")
    grid = _scale_grid(scales)
    if scales is not None and np.size(scales) == 2 and grid.size > 1:
        if min(f.shape + m.shape) >= 64:
            (_, _), best = _best(_halve(f), _halve(m), grid, margin)
        else:
            (_, _), best = _best(f, m, grid, margin)
        found = _best(f, m, best * np.geomspace(1 / 1.04, 1.04, 9), margin)
        (t, score), best = _best(f, m, found[1] * np.geomspace(1 / 1.01, 1.01, 9)[1:-1], margin, found)
    else:
        (t, score), best = _best(f, m, grid, margin)
    if subpixel:
        t = _refine(f, m, best, t)
    return Registration(scale=float(best), shift=(best * t[0], best * t[1]), score=float(score))


def _refine(f, m, scale, t):
    """Sub-pixel translation by phase correlation on the overlap (kept only if it moves < 2 px)."""
    r0, r1, c0, c1 = _overlap(f.shape, m.shape, scale, (scale * t[0], scale * t[1]))
    if r1 - r0 < 8 or c1 - c0 < 8:
        return t
    ref = f[r0:r1, c0:c1]
    mov = _resample(m, scale, (r1 - r0, c1 - c0), (scale * (r0 + t[0]), scale * (c0 + t[1])))
    from skimage.registration import phase_cross_correlation  # here, as match_template above

    d, _, _ = phase_cross_correlation(ref, mov, upsample_factor=10, normalization=None)
    # phase_cross_correlation returns the shift that moves ``mov`` onto ``ref``: ref(r) = mov(r - d)
    if np.all(np.abs(d) < 2):
        return (t[0] - float(d[0]), t[1] - float(d[1]))
    return t


def _overlap(fixed_shape, moving_shape, scale, shift):
    """Half-open rows/cols of ``fixed`` whose mapped points lie inside ``moving``."""
    out = []
    for n_f, n_m, s in zip(fixed_shape, moving_shape, shift):
        lo = max(0, math.ceil((0 - s) / scale - 1e-9))
        hi = min(n_f, math.floor((n_m - 1 - s) / scale + 1e-9) + 1)
        out.append((lo, max(lo, hi)))
    return out[0][0], out[0][1], out[1][0], out[1][1]


def warp_to(fixed_shape, moving, registration, cval=np.nan):
    """The moving image (H, W[, C]) resampled onto the fixed image's pixel grid (bilinear); ``cval`` outside."""
    a = np.asarray(moving, dtype=float)
    planes = a[..., None] if a.ndim == 2 else a
    out = np.stack(
        [
            _resample(planes[..., k], registration.scale, fixed_shape, registration.shift, cval=cval)
            for k in range(planes.shape[-1])
        ],
        axis=-1,
    )
    return out[..., 0] if a.ndim == 2 else out


# ---------------------------------------------------------------------------
# block averages
# ---------------------------------------------------------------------------
def block_average(img, block):
    """Means over non-overlapping ``block`` x ``block`` tiles from the top-left (partial tiles dropped).

    ``img`` (H, W) or (H, W, C) -> (H // block, W // block[, C]).
    """
    b = _check_block(block)
    a = np.asarray(img, dtype=float)
    ny, nx = a.shape[0] // b, a.shape[1] // b
    if ny == 0 or nx == 0:
        raise ParameterError("block", f"a {b} x {b} block does not fit in an image of {a.shape[0]} x {a.shape[1]} pixels")
    a = a[: ny * b, : nx * b]
    return a.reshape(ny, b, nx, b, *a.shape[2:]).mean(axis=(1, 3))


def _check_block(block):
    try:
        b = int(block)
    except (TypeError, ValueError):
        raise ParameterError("block", f"must be a positive whole number of pixels, got {block!r}") from None
    if b != block or b < 1:
        raise ParameterError("block", f"must be a positive whole number of pixels, got {block!r}")
    return b


def block_compare(img1, img2, block, white=None, *, register_images=True, registration=None, scales=(0.5, 2.0), margin=0.1,
                  method="CIE 1976"):
    """Register two XYZ images, average over blocks and compare the blocks in CIELAB (Figure 1.13).

    Parameters
    ----------
    img1 : array_like (H1, W1, 3)
        XYZ of the reference image (e.g. the real camera's); blocks are laid
        on its pixel grid, from the top-left of the overlap.
    img2 : array_like (H2, W2, 3)
        XYZ of the other image (e.g. the simulation), resampled onto ``img1``.
    block : int
        Block side in pixels of ``img1`` (the chapter: 50 at full resolution).
    white : array_like (3,), optional
        XYZ of the reference white for L*a*b*. Default: the D65 chromaticity
        at the highest block-mean luminance of the two images.
    register_images : bool
        Register ``img2`` onto ``img1`` (:func:`register`); if False the two
        must have the same shape and are compared pixel for pixel.
    registration : Registration, optional
        Use this mapping of ``img1`` pixels onto ``img2`` instead of searching
        (e.g. one found on sensor planes before rendering).
    scales, margin
        Passed to :func:`register`.
    method : {"CIE 1976", "CIE 2000"}

    Returns
    -------
    BlockComparison
        ``.delta_e`` per block, ``.median``, ``.histogram()``, ``.registration``.
    """
    method = _method(method)
    a = check_xyz(img1, "img1")
    b = check_xyz(img2, "img2")
    if a.ndim != 3 or b.ndim != 3:
        raise ParameterError("img1", f"both images must be (H, W, 3) XYZ, got shapes {a.shape} and {b.shape}")
    bsize = _check_block(block)
    if registration is not None:
        reg = registration
    elif register_images:
        reg = register(a, b, scales=scales, margin=margin)
    else:
        if a.shape != b.shape:
            raise ParameterError("img2", f"without registration the two images must have the same shape, got {a.shape} and {b.shape}")
        reg = Registration(scale=1.0, shift=(0.0, 0.0), score=float("nan"))
    r0, r1, c0, c1 = _overlap(a.shape[:2], b.shape[:2], reg.scale, reg.shift)
    if r1 - r0 < bsize or c1 - c0 < bsize:
        raise ParameterError(
            "block",
            f"the registered overlap ({r1 - r0} x {c1 - c0} pixels) holds no {bsize} x {bsize} block",
        )
    shift = (reg.shift[0] + reg.scale * r0, reg.shift[1] + reg.scale * c0)
    sub = Registration(reg.scale, shift, reg.score)
    identity = reg.scale == 1.0 and reg.shift == (0.0, 0.0) and a.shape == b.shape
    warped = b if identity else warp_to((r1 - r0, c1 - c0), b, sub, cval=0.0)
    m1 = block_average(a[r0:r1, c0:c1], bsize)
    m2 = block_average(warped, bsize)
    if white is None:
        y = max(float(m1[..., 1].max()), float(m2[..., 1].max()))
        if not y > 0:
            raise ParameterError("white", "no white given and both images are black")
        x_, y_ = _D65_XY
        w = np.array([x_ / y_ * y, y, (1 - x_ - y_) / y_ * y])
    else:
        w = check_white(white)
    de = delta_e_lab(_xyz_to_lab(m1, w), _xyz_to_lab(m2, w), method)
    return BlockComparison(
        delta_e=de, block=bsize, registration=reg, overlap=(r0, r1, c0, c1), means1=m1, means2=m2, white=w, method=method
    )
