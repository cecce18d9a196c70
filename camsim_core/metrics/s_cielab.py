"""S-CIELAB: CIELAB after the eye's spatial blur (chapter section 4.3, refs 45, 46).

Zhang and Wandell's spatial extension of CIELAB, matched to the distributed
S-CIELAB code (version 1.1.1) that the chapter's simulator was checked
against:

1. XYZ (CIE 1931, 2 degree) to the Poirson-Wandell opponent space with
   :data:`XYZ_TO_OPPONENT` (luminance, red-green, blue-yellow);
2. each opponent channel is convolved with a weighted sum of Gaussians
   (:data:`GAUSSIANS`: half-width in degrees, weight). A 1-D Gaussian of
   half-width ``h`` samples is ``exp(-(a x)^2)``, ``a = 2 sqrt(ln 2) / (h - 1)``,
   at integer offsets ``x`` from the centre, normalized to sum 1; the 2-D
   filter is ``sum_k [sqrt|w_k| g_k(y)] [sign(w_k) sqrt|w_k| g_k(x)]``: one
   degree wide (``2 ceil(s/2) - 1`` samples at ``s`` samples per degree).
   Below 224 samples per degree the 1-D kernels are built at ``s u`` samples
   per degree, ``u = ceil(224 / s)``, convolved with the triangle
   ``[1, 2, .., u, .., 2, 1] / u`` and sampled every ``u``-th tap outwards
   from the centre, so filtering still runs at the image's own resolution;
   the taps kept are normalized to sum 1 again. S-CIELAB 1.1.1 does not
   renormalize them, and its channels' gains on a uniform field drift with
   the rate (luminance x1.03 and red-green x0.95 at 8 samples per degree,
   x0.69 at 2): a uniform difference then no longer scores as in CIELAB.
   ISETCam's 2-D filters (``scPrepareFilters``, ``sumGauss``) sum to 1 at
   every rate, as these now do;
3. edges are mirrored (edge sample included) by half a kernel, or half the
   image where that is smaller, and zero beyond; the original filters
   horizontally then vertically and crops;
4. back to XYZ with the inverse matrix and Delta E*ab (or CIEDE2000)
   against the white point (:mod:`.cielab`, colour-science).

Speed: the horizontal-then-vertical separable passes with their mirrored
padding are exactly one 2-D convolution of the image mirrored on all sides
(a horizontal pass acts on each row alone, so it commutes with copying rows),
so each channel is filtered here by FFT products with the summed 2-D
kernel, whose spectrum is cached, one band of output rows at a time (512,
fewer for images over 1024 pixels wide), all three channels of both
images together: each band's FFT takes the rows its kernel reaches (the
same numbers as one transform of the whole image), and its filtered values
go to Lab and the difference at once, so no filtered, opponent or (given
rendered images and their monitor) XYZ image exists at full size; a
float32 image is transformed in single precision. The conversions to
opponent planes (with the mirrored columns) and back are compiled loops
(numba: numpy's strided per-channel products were a third of the filter's
time on a megapixel image); a band's filtered channels are read where the
inverse transforms left them and go to L*a*b* in one compiled pass and
numpy's cube root, by blocks of 64 K pixels (:class:`_Band`); and a band's transforms of half a megapixel or more run on the
machine's cores. This is the fast path the explorer uses
on every slider move; ``tests/engine/test_scielab.py`` checks it against a direct
2-D convolution within 1e-9.

Samples per degree
------------------
S-CIELAB needs the number of image samples per degree of visual angle at
the observer's eye: a property of how the rendered image is viewed, chosen
with :mod:`.viewing` (the default is the chapter's: the rendered image
subtends at the eye the angle the scene subtended at the camera, so the
rate is the camera's angular resolution, :func:`samples_per_degree`, 102.6
for the Kodak DCS-200 with its 50 mm lens; the original simulator's
example divided it by 10). :func:`display_samples_per_degree` gives the
rate of a display from its pixel pitch and the viewing distance.

Hand-written: no maintained Python package implements S-CIELAB 1.1.1's
kernels and edge handling; the filtering uses ``scipy.fft``, the colorimetry
colour-science.

References
----------
Zhang, X. & Wandell, B. A. (1997), "A spatial extension of CIELAB for
digital color-image reproduction", J. Soc. Inf. Display 5(1), 61-63.
Poirson, A. B. & Wandell, B. A. (1993), "Appearance of colored patterns:
pattern-color separability", JOSA A 10(12), 2458-2470.
"""

from __future__ import annotations

import functools
import math
import threading

import numpy as np
import scipy.fft

from .._chunks import map_pixels
from .._compiled import compiled
from .._parallel import CORES, PARALLEL_VALUES, run_blocks, split
from ..errors import ParameterError
from .cielab import _lab_of_ratios, _method, check_white, check_xyz, delta_e_lab, rendered_pair

__all__ = [
    "XYZ_TO_OPPONENT",
    "OPPONENT_TO_XYZ",
    "GAUSSIANS",
    "MIN_SAMPLES_PER_DEGREE",
    "scielab",
    "scielab_filter",
    "filter_opponent",
    "samples_per_degree",
    "display_samples_per_degree",
    "filtered_lab",
]

#: XYZ (CIE 1931 2 deg) to Poirson-Wandell opponent channels (rows: luminance,
#: red-green, blue-yellow); S-CIELAB 1.1.1 ``cmatrix('xyz2opp', 2)``.
XYZ_TO_OPPONENT = np.array(
    [
        [0.2787336, 0.7218031, -0.1065520],
        [-0.4487736, 0.2898056, 0.0771569],
        [0.0859513, -0.5899859, 0.5011089],
    ]
)
XYZ_TO_OPPONENT.flags.writeable = False

#: Its inverse (back to XYZ).
OPPONENT_TO_XYZ = np.linalg.inv(XYZ_TO_OPPONENT)
OPPONENT_TO_XYZ.flags.writeable = False

#: Per opponent channel, the Gaussians of its spatial filter as
#: (half-width in degrees, weight); each channel's weights sum to 1.
GAUSSIANS = (
    ((0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)),  # luminance
    ((0.0685, 0.616725), (0.826, 0.383275)),  # red-green
    ((0.0920, 0.567885), (0.6451, 0.432115)),  # blue-yellow
)

#: Below this rate the kernels are built on a finer grid and subsampled.
MIN_SAMPLES_PER_DEGREE = 224


# ---------------------------------------------------------------------------
# viewing geometry
# ---------------------------------------------------------------------------
def samples_per_degree(image):
    """Image samples per degree of visual angle, from the camera's angular resolution.

    Following the chapter (section 4.3), differences in size between the
    scene and the displayed image are neglected: the displayed image is
    seen under the same visual angle as the camera saw the scene, so a
    pixel covers ``1 / phi`` degree at the eye and the rate is the camera's
    angular resolution ``phi`` (pixels per degree, Eq. 1.1). Where the two
    axes differ their geometric mean is returned (S-CIELAB takes one rate).

    Parameters
    ----------
    image : CameraImage, Camera, Scene, tuple (x, y) or float
        Anything with ``angular_resolution`` (pixels per degree), or the value.

    Returns
    -------
    float
        Samples per degree (> 0).
    """
    res = getattr(image, "angular_resolution", image)
    r = np.atleast_1d(np.asarray(res, dtype=float)).ravel()
    if r.size not in (1, 2) or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise ParameterError("angular_resolution", f"must be positive pixels per degree (x, y), got {res!r}")
    return float(np.sqrt(np.prod(r))) if r.size == 2 else float(r[0])


def display_samples_per_degree(pixel_pitch, viewing_distance):
    """Samples per degree of a display with pixel pitch ``pixel_pitch`` seen from ``viewing_distance``.

    ``1 / (2 atan(pitch / (2 d)))`` with the angle in degrees (Eq. 1.1 for
    one pixel); both lengths in the same unit (e.g. metres).
    """
    p, d = float(pixel_pitch), float(viewing_distance)
    if not (p > 0 and math.isfinite(p)):
        raise ParameterError("pixel_pitch", f"must be a positive length, got {pixel_pitch!r}")
    if not (d > 0 and math.isfinite(d)):
        raise ParameterError("viewing_distance", f"must be a positive length, got {viewing_distance!r}")
    return 1.0 / math.degrees(2.0 * math.atan(p / (2.0 * d)))


def _check_spd(samples_per_degree):
    if isinstance(samples_per_degree, str) or hasattr(samples_per_degree, "rate"):
        from .viewing import parse_viewing

        try:
            return parse_viewing(samples_per_degree).rate()  # a viewing that does not need the camera
        except ParameterError as exc:
            raise ParameterError("samples_per_degree", f"must be a positive number or a viewing ({exc})") from None
    try:
        s = float(samples_per_degree)
    except (TypeError, ValueError):
        raise ParameterError("samples_per_degree", f"must be a positive number, got {samples_per_degree!r}") from None
    if not (s > 0 and math.isfinite(s)):
        raise ParameterError("samples_per_degree", f"must be a positive, finite number of samples per degree, got {samples_per_degree!r}")
    return s


# ---------------------------------------------------------------------------
# kernels (S-CIELAB 1.1.1 separableFilters / gauss)
# ---------------------------------------------------------------------------
def _filter_width(rate):
    """Samples in one degree, odd: ``2 ceil(rate / 2) - 1``."""
    return 2 * math.ceil(rate / 2.0) - 1


def _upsample_rate(spd):
    """``u = ceil(224 / s)`` below 224 samples per degree, else 1."""
    return math.ceil(MIN_SAMPLES_PER_DEGREE / spd) if spd < MIN_SAMPLES_PER_DEGREE else 1


def _gauss(half_width, width):
    """1-D Gaussian of half-width ``half_width`` samples on ``width`` (odd) samples, summing to 1."""
    alpha = 2.0 * math.sqrt(math.log(2.0)) / (half_width - 1.0)
    x = np.arange(width) - (width - 1) // 2
    g = np.exp(-((alpha * x) ** 2))
    return g / g.sum()


def _subsample(kernel, u):
    """Convolve with the triangle ``[1..u..1]/u`` ('same') and keep every u-th tap from the centre."""
    tri = np.concatenate([np.arange(1, u + 1), np.arange(u - 1, 0, -1)]) / u
    up = np.convolve(kernel, tri, mode="same")
    mid = (up.size - 1) // 2
    return np.concatenate([up[mid::-u][::-1], up[mid + u :: u]])


@functools.lru_cache(maxsize=32)
def _kernels(spd):
    """Per channel, (x kernels, y kernels) arrays (n_gaussians, L): signed along x, unsigned along y."""
    u = _upsample_rate(spd)
    rate = spd * u
    width = _filter_width(rate)
    out = []
    for gaussians in GAUSSIANS:
        kx = []
        for half_deg, weight in gaussians:
            g = _gauss(half_deg * rate, width)
            if u > 1:  # the taps kept sum to 1 again: the channel's DC gain is its weights' sum, 1, at every rate
                g = _subsample(g, u)
                g = g / g.sum()
            kx.append(g * math.sqrt(abs(weight)) * math.copysign(1.0, weight))
        kx = np.array(kx)
        ky = np.abs(kx)
        kx.flags.writeable = ky.flags.writeable = False
        out.append((kx, ky))
    return tuple(out)


def _kernel_2d(kx, ky):
    """The channel's 2-D kernel ``sum_k outer(ky_k, kx_k)`` (rows = y)."""
    return np.einsum("ki,kj->ij", ky, kx)


def _pad_width(kernel_length, n):
    """Mirror margin: floor(kernel / 2), or floor(n / 2) where the kernel is not smaller than the image."""
    return min(kernel_length // 2, n // 2)


@functools.lru_cache(maxsize=16)
def _plan(spd, shape):
    """Mirror margins (py, px) and kernel half-widths (cy, cx) for images of ``shape`` (H, W).

    Taps farther from the centre than the mirrored image reaches (``n - 1 +
    pad``) only ever meet zeros, so they are dropped, which keeps a kernel
    much wider than a small image from inflating the FFT. (The kernels'
    spectra are made per band of rows, :func:`_band_spectra`: spectra the size
    of a 12-megapixel image would hold 300 MiB.)
    """
    H, W = shape
    L = _kernels(spd)[0][0].shape[1]
    c = L // 2
    py, px = _pad_width(L, H), _pad_width(L, W)
    return py, px, min(c, H - 1 + py), min(c, W - 1 + px)


# ---------------------------------------------------------------------------
# filtering
# ---------------------------------------------------------------------------
#: Output rows filtered per FFT: bounds the transform's memory on large images.
BAND_ROWS = 512
#: Pixels per band at most (fewer rows for wide images, not under 128).
BAND_PIXELS = 1 << 19
#: Transforms of at least this many points run on the machine's cores.
TRANSFORM_PIXELS_ON_CORES = 1 << 19


@functools.lru_cache(maxsize=16)
def _band_spectra(spd, cy, cx, fy, fx, dtype):
    """Kernel spectra (3, fy, fx // 2 + 1) of the channels' kernels cropped to (2 cy + 1, 2 cx + 1), in ``dtype``."""
    kernels = _kernels(spd)
    c = kernels[0][0].shape[1] // 2
    spectra = np.stack(
        [
            scipy.fft.rfft2(_kernel_2d(kx[:, c - cx : c + cx + 1], ky[:, c - cy : c + cy + 1]).astype(dtype), s=(fy, fx))
            for kx, ky in kernels
        ]
    )
    spectra.flags.writeable = False
    return spectra


def _band_rows(shape):
    """Output rows per band of an image of ``shape`` (H, W): at most :data:`BAND_ROWS`, fewer for images
    wider than :data:`BAND_PIXELS` / 512 (at least 128), so a band's temporaries stay a few tens of MiB;
    and an even number of equal bands when there are several, so that two cores get the same work
    (:func:`_band_groups`; the bands do not depend on the cores, nor do the numbers)."""
    H, W = shape
    limit = int(min(BAND_ROWS, max(128, BAND_PIXELS // max(int(W), 1))))
    count = -(-int(H) // limit)
    if count > 1:
        count += count % 2
    return max(1, -(-int(H) // count))


def _band_groups(shape):
    """Edges (output rows) of consecutive groups of whole bands (:func:`_band_rows`), one group per core, for
    :func:`_filter_image_rows`; one group when the image has a single band or too few values to pay (the
    bands are the same either way, so are the numbers)."""
    H, W = shape
    band = min(H, _band_rows((H, W)))
    count = -(-H // band)
    if CORES == 1 or count < 2 or H * W * 3 < PARALLEL_VALUES:
        return [0, H]
    return [min(H, int(e) * band) for e in split(count, CORES)]


def _filter_image_rows(image, spd, write, **kw):
    """``write(i0, i1, band)`` for every band (:class:`_Band`) of :func:`_filtered_bands`, groups of bands on the machine's
    cores (:func:`_band_groups`; each group's transforms on one thread). ``write`` must touch only rows
    i0..i1 of its output, and must not wait on the block pool (it runs on it)."""
    groups = _band_groups(image.shape[:2])
    on_cores = len(groups) > 2

    def group(r0, r1):
        for i0, i1, band in _filtered_bands(image, spd, rows=(r0, r1), split_transforms=not on_cores, **kw):
            write(i0, i1, band)

    run_blocks(group, groups, values=image.size)


def _filtered_bands(image, spd, *, opponent_in=False, to_xyz=None, rows=None, split_transforms=True):
    """Yield ``(i0, i1, band)``: output rows i0..i1 of the S-CIELAB filtered image, band by band.

    ``image`` (H, W, 3) is XYZ (or opponent channels with ``opponent_in``,
    or values that ``to_xyz`` takes, by rows (n, 3), to XYZ); each band is a
    :class:`_Band`, the three filtered opponent channels, which its caller
    takes straight to what it needs (XYZ or opponent pixels, L*a*b*). For a band of output rows, the rows its kernels reach
    (its own plus ``cy`` above and below, of the image mirrored by ``py``,
    ``px``, :func:`_plan`, zero beyond) are taken to opponent space, and
    each channel is one zero-padded FFT product with its kernel's spectrum,
    the linear convolution's valid part kept: the numbers of one FFT over
    the whole image (to rounding). No full-size temporary exists: opponent
    planes, their transforms and the filtered values are a band's worth
    (:func:`_band_rows`: ~10 MiB each for a 4000-pixel-wide image), so callers
    that turn each band into Lab or a difference at once (:func:`scielab`)
    hold nothing of the image's size but their inputs and output. In the
    image's dtype (float32 stays float32: scipy.fft transforms in single
    precision). ``rows``: only the bands starting in output rows
    ``rows[0]..rows[1]`` (``rows[0]`` a band's start; :func:`_band_groups`).
    ``split_transforms``: a large band's transforms on the machine's cores
    (the same numbers on one).
    """
    H, W = image.shape[:2]
    dt = image.dtype
    py, px, cy, cx = _plan(spd, (H, W))
    band = min(H, _band_rows((H, W)))
    fy = scipy.fft.next_fast_len(band + 2 * cy, real=True)
    # columns: the mirrored image after ``a`` zeros, where the kernel reaches past the mirror (small images);
    # a transform of W + 2 max(px, cx) points holds the valid part unaliased (the mirror is as wide as the
    # kernel's reach, so the zeros a full linear convolution would add are never reached)
    a = max(cx - px, 0)
    fx = scipy.fft.next_fast_len(W + 2 * px + 2 * a, real=True)
    spectra = _band_spectra(spd, cy, cx, fy, fx, dt.type)
    source_row = np.pad(np.arange(H), py, mode="symmetric")  # the image row of each mirrored row
    to_opp = XYZ_TO_OPPONENT.astype(dt)  # unused by opponent_in
    # one set of band buffers for the whole image: a band handed out is valid until the next is asked for;
    # the opponent planes are written (columns mirrored) into zero-padded transform inputs
    planes = np.zeros((3, fy, fx), dt)
    to_planes = _opponent_kernel()
    # transforms of half a megapixel or more on the machine's cores; smaller ones lose more to the threads
    # than they gain (the default scene's: +15 %; a 4000-wide image's: -15 to -30 %)
    workers = CORES if split_transforms and fy * fx >= TRANSFORM_PIXELS_ON_CORES else 1
    r0, r1 = (0, H) if rows is None else rows
    for i0 in range(r0, r1, band):
        i1 = min(H, i0 + band)
        # mirrored rows that output rows i0..i1 reach: [i0 + py - cy, i1 + py + cy), zero outside the mirror
        lo, hi = i0 + py - cy, i1 + py + cy
        s0, s1 = max(lo, 0), min(hi, source_row.size)
        take = source_row[s0:s1]
        if take[-1] - take[0] == take.size - 1:  # no mirrored row: a view, not a copy
            rows = image[take[0] : take[-1] + 1]
        else:
            rows = image[take]
        if to_xyz is not None:
            rows = map_pixels(to_xyz, rows)  # by chunks: the conversion's temporaries stay a few MiB
        planes[:, : s0 - lo] = 0
        planes[:, s1 - lo :] = 0
        to_planes(np.ascontiguousarray(rows), to_opp, planes, s0 - lo, a, px, not opponent_in)
        del rows
        # one zero-padded FFT product per channel (the numbers of the whole image's transform), one axis at a
        # time: the inverse's last pass (along rows) makes only the valid rows (from 2 cy), and the valid
        # columns (from a + px + cx) are read where they lie, not copied out
        filtered = []
        for ch in range(3):
            filtered.append(_band_product(planes[ch], spectra[ch], 2 * cy, i1 - i0, fx, workers))
        handed = _Band(tuple(filtered), a + px + cx, i1 - i0, W)
        del filtered
        yield i0, i1, handed
        # valid until the next band is asked for: its transforms are let go now, even where the caller's
        # loop variable still holds the band while the next one is made
        handed.planes = None


def _band_product(plane, spectrum, first, rows, fx, workers):
    """Rows ``first .. first + rows`` of the circular convolution of ``plane`` (fy, fx) with the kernel whose
    2-D real-input spectrum is ``spectrum`` (fy, fx // 2 + 1): rows ``rfft`` then columns ``fft``, the
    product, columns ``ifft``, and ``irfft`` of the wanted rows only.

    The numbers of ``irfft2(rfft2(plane) * spectrum)`` to rounding, in the plane's precision. Axis by axis
    because scipy's two-axis inverse was slower than its own two passes (5.2 against 3.2 ms for a 360 x
    1440 float32 band, 5.8 with ``overwrite_x``), and because the last pass can skip the rows in the
    band's margins (a third of a 253-row band's). A 1012 x 1317 image's filtered L*a*b* (four such bands
    a channel): 97 -> 80 ms on one core, 51 -> 42 ms on two (medians of 15 interleaved runs).
    """
    f = scipy.fft.rfft(plane, axis=1, workers=workers)
    f = scipy.fft.fft(f, axis=0, overwrite_x=True, workers=workers)
    f *= spectrum
    f = scipy.fft.ifft(f, axis=0, overwrite_x=True, workers=workers)
    return scipy.fft.irfft(f[first : first + rows], n=fx, axis=1, workers=workers)


class _Band:
    """Output rows of the filtered image: the three filtered opponent channels ``planes`` (each a C-ordered
    (rows, fx) inverse transform, :func:`_band_product`) hold them at columns ``col``.. (``rows`` x ``cols``).

    Its methods take the band straight to pixels or to L*a*b* in one compiled pass each (no copy of the
    valid part, no band of XYZ): numpy's per-channel products and the separate XYZ, ratio and copy passes
    were a fifth of a filtered L*a*b* on a megapixel image. L*a*b* is made by blocks of rows
    (:meth:`blocks`), so its temporaries stay in the CPU's cache and a few MiB at 12 megapixels.
    """

    __slots__ = ("planes", "col", "rows", "cols")

    def __init__(self, planes, col, rows, cols):
        self.planes, self.col, self.rows, self.cols = planes, col, rows, cols

    def to_pixels(self, out, *, convert=True):
        """Write the band into ``out`` (rows, cols, 3): XYZ (``OPPONENT_TO_XYZ`` applied), or the opponent
        channels themselves when not ``convert``."""
        f0, f1, f2 = self.planes
        _back_kernel()(f0, f1, f2, 0, self.col, OPPONENT_TO_XYZ.astype(out.dtype), out, convert)

    def blocks(self):
        """``(b0, b1)``: the band's rows in blocks of at most :data:`LAB_BLOCK_PIXELS` pixels (a row at least)."""
        step = max(1, LAB_BLOCK_PIXELS // max(self.cols, 1))
        return [(b, min(self.rows, b + step)) for b in range(0, self.rows, step)]

    def to_lab(self, white, out, ratios, start=0):
        """Write the L*a*b* under ``white`` (3,) of the band's rows ``start..start + h`` into ``out`` (h, cols,
        3), the numbers of :func:`.cielab._xyz_to_lab` of their XYZ; ``ratios``: a buffer of ``out``'s shape
        and dtype."""
        f0, f1, f2 = self.planes
        dt = out.dtype
        _ratio_planes_kernel()(f0, f1, f2, start, self.col, OPPONENT_TO_XYZ.astype(dt),
                               np.asarray(white, float).astype(dt), ratios)
        _lab_of_ratios(ratios.reshape(-1, 3), out.reshape(-1, 3), out.reshape(-1, 3))


#: Pixels per block of a band taken to L*a*b* (:meth:`_Band.blocks`): 768 KiB per float32 buffer.
LAB_BLOCK_PIXELS = 1 << 16


def _block_buffer(image):
    """A buffer (rows, W, 3) in ``image``'s dtype for one block of :meth:`_Band.blocks`."""
    W = image.shape[1]
    return np.empty((max(1, LAB_BLOCK_PIXELS // max(W, 1)), W, 3), image.dtype)


def _opponent_rows(rows, m, planes, r0, c0, px, convert):
    """Write ``m @ rows[i, x]`` (opponent channels of XYZ rows (h, W, 3); the values themselves when not
    ``convert``) into ``planes[:, r0 + i, c0 : c0 + W + 2 px]``, the columns mirrored by ``px`` on each side
    (edge sample included, as ``np.pad(..., mode="symmetric")``; ``px <= W / 2``).

    Compiled by numba (:func:`_opponent_kernel`): numpy took a strided
    product per channel and a padded copy of each plane (a third of the
    filter's time on a megapixel image); this is one pass. The image's own
    columns are written by a loop without a branch (it vectorizes), the
    mirrored margins then copied from them (a quarter less time than one
    loop finding each column's source).
    """
    h, W = rows.shape[0], rows.shape[1]
    for i in range(h):
        r = r0 + i
        if convert:
            for x in range(W):
                a, b, c = rows[i, x, 0], rows[i, x, 1], rows[i, x, 2]
                planes[0, r, c0 + px + x] = m[0, 0] * a + m[0, 1] * b + m[0, 2] * c
                planes[1, r, c0 + px + x] = m[1, 0] * a + m[1, 1] * b + m[1, 2] * c
                planes[2, r, c0 + px + x] = m[2, 0] * a + m[2, 1] * b + m[2, 2] * c
        else:
            for x in range(W):
                planes[0, r, c0 + px + x] = rows[i, x, 0]
                planes[1, r, c0 + px + x] = rows[i, x, 1]
                planes[2, r, c0 + px + x] = rows[i, x, 2]
        for k in range(px):
            for ch in range(3):
                planes[ch, r, c0 + px - 1 - k] = planes[ch, r, c0 + px + k]
                planes[ch, r, c0 + px + W + k] = planes[ch, r, c0 + px + W - 1 - k]


def _back_rows(f0, f1, f2, r0, c0, m, out, convert):
    """``out[i, x] = m @ (f0, f1, f2)[r0 + i, c0 + x]`` for ``out``'s (h, W) pixels (the values themselves
    when not ``convert``): filtered opponent channels, read where the transforms left them, back to pixels
    (XYZ). Compiled by numba (:func:`_back_kernel`), one pass for numpy's strided product."""
    for i in range(out.shape[0]):
        r = r0 + i
        for x in range(out.shape[1]):
            a, b, c = f0[r, c0 + x], f1[r, c0 + x], f2[r, c0 + x]
            if convert:
                out[i, x, 0] = m[0, 0] * a + m[0, 1] * b + m[0, 2] * c
                out[i, x, 1] = m[1, 0] * a + m[1, 1] * b + m[1, 2] * c
                out[i, x, 2] = m[2, 0] * a + m[2, 1] * b + m[2, 2] * c
            else:
                out[i, x, 0] = a
                out[i, x, 1] = b
                out[i, x, 2] = c


def _ratio_planes(f0, f1, f2, r0, c0, m, white, out):
    """``out[i, x, k] = (m @ (f0, f1, f2)[r0 + i, c0 + x])[k] / white[k]``: filtered opponent channels to XYZ
    and their ratios to the white, the first step of L*a*b*, in one pass with the numbers of
    :func:`_back_rows` followed by :func:`.cielab._ratio_rows`. Compiled by numba (:func:`_ratio_planes_kernel`)."""
    for i in range(out.shape[0]):
        r = r0 + i
        for x in range(out.shape[1]):
            a, b, c = f0[r, c0 + x], f1[r, c0 + x], f2[r, c0 + x]
            X = m[0, 0] * a + m[0, 1] * b + m[0, 2] * c
            Y = m[1, 0] * a + m[1, 1] * b + m[1, 2] * c
            Z = m[2, 0] * a + m[2, 1] * b + m[2, 2] * c
            out[i, x, 0] = X / white[0]
            out[i, x, 1] = Y / white[1]
            out[i, x, 2] = Z / white[2]


_opponent_kernel = compiled(_opponent_rows)
_back_kernel = compiled(_back_rows)
_ratio_planes_kernel = compiled(_ratio_planes)


def _filter_image(image, spd, *, opponent_out=False, **kw):
    """The whole filtered image (H, W, 3) of :func:`_filtered_bands`, written band by band: XYZ, or the
    opponent channels with ``opponent_out``."""
    out = np.empty(image.shape, image.dtype)

    def write(i0, i1, band):
        band.to_pixels(out[i0:i1], convert=not opponent_out)

    _filter_image_rows(image, spd, write, **kw)
    return out


def filter_opponent(opponent, samples_per_degree):
    """Spatially filter an opponent-channel image (H, W, 3) as S-CIELAB does (before Lab).

    Parameters
    ----------
    opponent : array_like (H, W, 3)
        Luminance, red-green, blue-yellow channels (``xyz @ XYZ_TO_OPPONENT.T``).
    samples_per_degree : float
        Image samples per degree of visual angle (> 0).

    Returns
    -------
    ndarray (H, W, 3)
    """
    spd = _check_spd(samples_per_degree)
    o = np.asarray(opponent)
    o = o if o.dtype in (np.float32, np.float64) else o.astype(np.float64)
    if o.ndim != 3 or o.shape[-1] != 3:
        raise ParameterError("opponent", f"must be an (H, W, 3) image, got shape {o.shape}")
    return _filter_image(o, spd, opponent_in=True, opponent_out=True)


def scielab_filter(xyz, samples_per_degree):
    """The S-CIELAB spatially filtered XYZ image (H, W, 3) (steps 1-3 and the way back)."""
    spd = _check_spd(samples_per_degree)
    xyz = np.asarray(xyz)
    xyz = xyz if xyz.dtype in (np.float32, np.float64) else xyz.astype(np.float64)
    if xyz.ndim != 3 or xyz.shape[-1] != 3:
        raise ParameterError("xyz", f"must be an (H, W, 3) XYZ image, got shape {xyz.shape}")
    return _scielab_filter(xyz, spd)


def _scielab_filter(xyz, spd):
    """XYZ (H, W, 3) -> opponent -> filtered -> XYZ, band by band (:func:`_filtered_bands`)."""
    return _filter_image(xyz, spd)


def filtered_lab(xyz, samples_per_degree, white, *, checked=False):
    """L*a*b* (H, W, 3) of the S-CIELAB filtered image: one side of :func:`scielab`.

    The incremental pipeline (:class:`camsim_core.cache.Pipeline`) keeps it
    for the ideal image, which a noise or processing change leaves as it is.

    Parameters
    ----------
    xyz : array_like (H, W, 3)
        The XYZ image, any unit (the white's).
    samples_per_degree : float
        Image samples per degree of visual angle (:func:`samples_per_degree`).
    white : array_like (3,)
        XYZ of the white the L*a*b* is relative to.
    checked : bool, optional
        ``True`` when the caller has checked ``xyz`` with
        :func:`~camsim_core.metrics.cielab.check_xyz` (a float array of
        finite values): that pass over the image is skipped. Its shape,
        ``samples_per_degree`` and the white are always checked.

    Returns
    -------
    ndarray (H, W, 3)
        L*, a*, b* of the filtered image: the same numbers as
        ``xyz_to_lab(scielab_filter(xyz, samples_per_degree), white)``, made
        band by band without holding the filtered XYZ image. float32 input
        stays float32.

    Raises
    ------
    ParameterError
        For a bad image, rate or white (naming it).

    References
    ----------
    X. Zhang and B. A. Wandell, "A spatial extension of CIELAB for digital
    color image reproduction", SID Journal 5(1), 1997.

    Examples
    --------
    >>> import numpy as np
    >>> white = np.array([95.047, 100.0, 108.883])
    >>> xyz = np.random.default_rng(0).uniform(10.0, 30.0, (32, 40, 3))
    >>> lab = filtered_lab(xyz, 30.0, white)
    >>> lab.shape
    (32, 40, 3)
    >>> from camsim_core.metrics import scielab_filter, xyz_to_lab
    >>> bool(np.allclose(lab, xyz_to_lab(scielab_filter(xyz, 30.0), white)))
    True
    """
    spd = _check_spd(samples_per_degree)
    w = check_white(white)
    a = np.asarray(xyz) if checked else check_xyz(xyz, "xyz")
    if a.ndim != 3 or a.shape[-1] != 3:
        raise ParameterError("xyz", f"must be an (H, W, 3) image, got shape {a.shape}")
    return _filtered_lab(a, spd, w)


def _filtered_lab(xyz, spd, white):
    """:func:`filtered_lab` of a checked XYZ image (H, W, 3) under a checked white: each band goes from its
    filtered channels to L*a*b* in the output, block by block (:meth:`_Band.to_lab`), with one block
    buffer per thread (a group of bands runs on one)."""
    out = np.empty(xyz.shape, xyz.dtype)
    buffers = {}

    def write(i0, i1, band):
        ratios = buffers.get(threading.get_ident())
        if ratios is None:
            ratios = buffers[threading.get_ident()] = _block_buffer(xyz)
        for b0, b1 in band.blocks():
            band.to_lab(white, out[i0 + b0 : i0 + b1], ratios[: b1 - b0], b0)

    _filter_image_rows(xyz, spd, write)
    return out


def scielab(xyz1, xyz2, samples_per_degree, white, *, method="CIE 1976", monitor=None):
    """S-CIELAB difference map between two XYZ images (chapter 4.3; Zhang & Wandell 1997).

    Parameters
    ----------
    xyz1, xyz2 : array_like (H, W, 3)
        CIE 1931 XYZ of the two displayed images, in the unit of ``white``.
    samples_per_degree : float, Viewing or str
        Image samples per degree of visual angle (> 0), or a viewing that
        fixes them without the camera (``"spd:10.26"``,
        ``"display:0.25mm@0.6m"``; see :mod:`.viewing`, whose
        ``Viewing.rate(image)`` gives the camera-based ones).
    white : array_like (3,)
        XYZ of the reference white (all positive).
    method : {"CIE 1976", "CIE 2000"}
        The colour difference applied after filtering.
    monitor : Monitor or name, optional
        Given, ``xyz1`` and ``xyz2`` are the rendered images (CameraImage,
        space "monitor") shown on it, taken to XYZ band by band (the numbers
        of :func:`camsim_core.to_xyz`): no full-size XYZ image is made.

    Returns
    -------
    ndarray (H, W)
        Delta E at each pixel; its mean is the chapter's "mean S-CIELAB error".
    """
    method = _method(method)
    spd = _check_spd(samples_per_degree)
    w = check_white(white)
    a, b, to_a, to_b = rendered_pair(xyz1, xyz2, monitor)
    if a.ndim != 3:
        raise ParameterError("xyz1", f"must be an (H, W, 3) image, got shape {a.shape}")
    # both images band by band: the filtered bands of each go to Lab and their difference at once, so
    # neither filtered image exists at full size
    out = None
    # per image (the two may differ in dtype), a block's L*a*b* and the buffer that makes it
    lab_a, ratios_a, lab_b, ratios_b = _block_buffer(a), _block_buffer(a), _block_buffer(b), _block_buffer(b)
    for (i0, _, fa), (_, _, fb) in zip(_filtered_bands(a, spd, to_xyz=to_a), _filtered_bands(b, spd, to_xyz=to_b)):
        for b0, b1 in fa.blocks():
            h = b1 - b0
            fa.to_lab(w, lab_a[:h], ratios_a[:h], b0)
            fb.to_lab(w, lab_b[:h], ratios_b[:h], b0)
            d = delta_e_lab(lab_a[:h], lab_b[:h], method)
            if out is None:
                out = np.empty(a.shape[:2], d.dtype)
            out[i0 + b0 : i0 + b1] = d
    return out
