"""Slanted-edge MTF (ISO 12233 e-SFR), MTF50 and MTF at Nyquist, per channel and for luminance.

Written by hand: no maintained PyPI package implements the e-SFR method
with the corrections needed to meet analytic MTFs (the reference
implementation, Burns's ``sfrmat``, is MATLAB). The steps follow ISO
12233:2017 Annex D and ``sfrmat3``/``sfrmat4``:

1. Orient: the edge must be near vertical (transpose a near-horizontal one);
   flip the sign so that the image rises across the edge.
2. Find the edge: a first line through where each block of rows rises
   most; then per row, the centroid of the row's first difference under a
   Hamming window 65 px wide centred on the previous line (two passes);
   fit a straight line x = p0 + p1 y through the centroids. Only a band
   of ``half_width`` px (128) either side of the edge is used for the
   ESF: the region of interest of ISO 12233, so that a whole camera frame
   can be passed (whole rows' centroids were pulled tens of pixels off by
   the shading of cos^4 relative illumination). The band is wide for the
   1/x^2 tails of a diffraction-limited line spread; the centroids'
   window narrow, for the line's precision under noise.
3. Super-resolve the edge spread function (ESF): every pixel's
   perpendicular distance to the line, ``(x - p0 - p1 y) cos(theta)``, binned
   at 1/``oversampling`` pixel. Unlike sfrmat, each bin's mean is placed at
   its samples' mean distance and the ESF interpolated back onto the bin
   centres: at some slants the samples crowd one side of their bins, which
   otherwise costs up to 0.02 of MTF at Nyquist (measured on a 20 degree edge).
   An ESF still rising at the band's ends (a blur too wide for the band)
   is refused rather than measured too sharp.
4. Line spread function: first difference of the ESF, Hamming window
   centred on its centroid; MTF = |DFT|, normalized to 1 at zero frequency.
5. Correct for the two box filters the estimate applies: the binning
   (width 1/oversampling) and the two-point difference (same width), each a
   sinc(f / oversampling). A point-sampled Gaussian-blurred edge then gives
   exp(-2 pi^2 sigma^2 f^2) within 0.005 up to Nyquist (sigma 0.5-2 px,
   5-20 degrees, 128 x 128 pixels; tests/engine/test_sharpness.py).

Frequencies are in cycles per pixel *perpendicular to the edge*; Nyquist is 0.5.
"""

from __future__ import annotations

import numpy as np

from .._parallel import run_blocks
from ..errors import ParameterError

__all__ = ["slanted_edge_mtf", "mtf50", "mtf_at", "edge_angle", "edge_mtf", "EdgeMTF", "luminance_weights",
           "NYQUIST", "EDGE_HALF_WIDTH"]

#: Nyquist frequency of a pixel grid, cycles per pixel.
NYQUIST = 0.5
_MIN_ANGLE = 1.0  # degrees from the pixel grid below which the phases do not spread
#: Half-width (px) of the band around the edge that the e-SFR measures: the region of interest of ISO
#: 12233, 128 px across, wide enough for the edge spread of any camera whose MTF50 is above 0.01 cycles/px.
EDGE_HALF_WIDTH = 128
#: Half-width (px) of the window in which each row's edge centroid is taken (at most the band's): the
#: narrower the window, the less noise in the fitted line (a row's centroid error grows as the window's
#: width to the 3/2), and 32 px holds the line spread of any edge the band can measure, centred.
_CENTROID_HALF_WIDTH = 32


def _hamming(n_total, centre, positions):
    """Hamming window of full width ``n_total`` centred at ``centre``, at ``positions`` (0 outside)."""
    u = (positions - centre) / n_total
    return np.where(np.abs(u) <= 0.5, 0.54 + 0.46 * np.cos(2 * np.pi * u), 0.0)


def _check_image(image):
    a = np.asarray(image)
    if a.ndim != 2:
        raise ParameterError("image", f"needs a 2-D array holding one slanted edge, got shape {a.shape}")
    if min(a.shape) < 16:
        raise ParameterError("image", f"is {a.shape[0]} x {a.shape[1]}; the edge needs at least 16 x 16 pixels")
    if not np.issubdtype(a.dtype, np.number):
        raise ParameterError("image", f"must hold numbers, got {a.dtype}")
    a = a.astype(float)
    if not np.all(np.isfinite(a)):
        raise ParameterError("image", "holds NaN or infinite values")
    return a


def _oriented(a):
    """The image with its edge near vertical and rising left to right; and whether it was transposed.

    Near vertical when its left and right eighths differ more than its top and bottom eighths: a
    mean over whole strips, so that noise does not count (a sum of absolute differences, used
    before, took the noise of a tall narrow region for an edge across it).
    """
    def sides(b):
        k = max(1, b.shape[1] // 8)
        return b[:, -k:].mean() - b[:, :k].mean()

    transposed = abs(sides(a.T)) > abs(sides(a))
    if transposed:
        a = a.T
    if sides(a) < 0:
        a = -a
    return a, transposed


def _windowed_centroids(d, centre, n):
    """Per row, the centroid of ``d`` (at x + 0.5) under a Hamming window of full width ``n`` at ``centre``.

    The window's cosine is expanded (cos(a - b) = cos a cos b + sin a sin b)
    so that each pass is a few matrix-vector products rather than a
    per-pixel cosine.
    """
    rows, m = d.shape
    x = np.arange(m) + 0.5
    k = 2 * np.pi / n
    dm = np.where(np.abs(x[None, :] - centre[:, None]) <= n / 2, d, 0.0)
    basis = np.stack([np.ones(m), np.cos(k * x), np.sin(k * x)], axis=1)  # (m, 3)
    coef = np.stack([np.full(rows, 0.54), 0.46 * np.cos(k * centre), 0.46 * np.sin(k * centre)], axis=1)
    s = np.einsum("rj,rj->r", dm @ basis, coef)
    sx = np.einsum("rj,rj->r", dm @ (basis * x[:, None]), coef)
    return s, sx


def _coarse_line(d):
    """A first straight line x = q0 + q1 y through the edge, from where each block of rows rises most.

    Each block of rows (up to 64 blocks) is averaged and smoothed over 5 columns, and its largest
    difference located; a straight line is fitted through those places, twice leaving out the blocks
    more than 3 px (or 3 robust sigmas) off it (a block can peak on noise or a speck). This only
    centres the band that the centroids are taken in, so it needs to be within a few pixels, not better.
    """
    rows, m = d.shape
    block = max(1, rows // 64)
    nb = rows // block
    mean = d[: nb * block].reshape(nb, block, m).mean(axis=1)
    smooth = np.apply_along_axis(np.convolve, 1, mean, np.ones(5) / 5, mode="same") if m >= 5 else mean
    x = smooth.argmax(axis=1) + 0.5
    y = np.arange(nb) * block + (block - 1) / 2
    keep = np.ones(nb, bool)
    fit = np.polyfit(y, x, 1)
    for _ in range(2):
        r = np.abs(x - np.polyval(fit, y))
        spread = 1.4826 * np.median(r[keep])
        keep = r <= max(3.0, 3.0 * spread)
        if keep.sum() < 2:
            break
        fit = np.polyfit(y[keep], x[keep], 1)
    return fit


def _edge_line(a, half_width):
    """(p0, p1): edge at x = p0 + p1 y, from windowed centroids of each row's difference.

    The centroids are taken within ``half_width`` pixels of a first estimate of the line
    (:func:`_coarse_line`): ISO 12233 measures a region of interest around the edge, and a row's
    centroid taken over a whole camera frame is pulled tens of pixels off by shading
    (relative illumination) far from the edge.
    """
    rows, cols = a.shape
    d = np.diff(a, axis=1)
    k = max(2, cols // 8)
    rise = np.median(a[:, -k:].mean(axis=1) - a[:, :k].mean(axis=1))
    sample = d[:: max(1, rows // 128)]
    noise = 1.4826 * np.median(np.abs(sample - np.median(sample))) / np.sqrt(2)  # per-pixel sigma from differences
    # the rise is a median over rows of means over k columns a side: five times the noise of such a difference,
    # sigma sqrt(2 / k), and at least three times one pixel's noise (a ramp of 2 sigma across a noisy field passed
    # the first alone). Five times one pixel's noise refused a dim edge of 2.6 DN in 0.52 DN of noise as "no edge"
    if not rise > max(5 * noise * np.sqrt(2.0 / k), 3 * noise, 1e-9 * np.abs(a).max()):
        raise ParameterError("image", f"no edge found: the sides differ by {rise:.3g}, against noise of {noise:.3g}; "
                             "expected one straight slanted edge between two flat regions")
    y = np.arange(rows)
    centre = np.polyval(_coarse_line(d), y)
    n = min(d.shape[1] + 1, 2 * half_width + 1)
    fit = None
    for _ in range(2):  # the first window follows the coarse line; the second the first fit
        s, sx = _windowed_centroids(d, centre, n)
        peak = np.abs(s).max()
        good = s > 0.05 * peak if peak > 0 else np.zeros(rows, bool)
        if good.sum() < 4:
            raise ParameterError("image", "no edge found: expected one straight slanted edge between two flat regions")
        fit = np.polyfit(y[good], sx[good] / s[good], 1)
        centre = np.polyval(fit, y)
    return fit[1], fit[0]


def _check_flat_ends(esf, q, half_width):
    """Refuse an ESF that still rises near the band's ends: its LSF is cut off, and its MTF too high.

    Each end's outer eighth (at least 2 px) must change by less than 5 % of the step, or by less than
    four times the noise of that change (each side of the eighth a mean over 1 px of bins).
    """
    e = max(2 * q, esf.size // 8)
    step = esf[-e:].mean() - esf[:e].mean()
    first, last = esf[:e], esf[-e:]
    change = max(abs(first[-q:].mean() - first[:q].mean()), abs(last[-q:].mean() - last[:q].mean()))
    # the noise of a difference of two 1 px means, from the bins' scatter at the ends (a dim or coarsely
    # quantized edge is noisy there, not rising)
    scatter = np.concatenate([np.diff(first), np.diff(last)])
    sigma_bin = 1.4826 * np.median(np.abs(scatter - np.median(scatter))) / np.sqrt(2)
    noise = sigma_bin * np.sqrt(2.0 / q)
    ends = change / abs(step) if step else 0.0
    if ends > 0.05 and change > 4 * noise:
        raise ParameterError("half_width", f"the edge is still rising at the ends of the region measured ({ends:.0%} of "
                             f"the step within {e / q:g} px of them; {half_width} px either side of the edge): widen "
                             "the region, or the edge is too blurred for its image")


def edge_angle(image):
    """Angle of the edge from the nearest pixel axis, degrees (from the fitted line)."""
    a, _ = _oriented(_check_image(image))
    _, p1 = _edge_line(a, _CENTROID_HALF_WIDTH)
    return float(np.degrees(np.arctan(p1)))


def slanted_edge_mtf(image, *, oversampling=4, max_frequency=1.0, half_width=EDGE_HALF_WIDTH):
    """ISO 12233 e-SFR MTF of one slanted edge (see the module docstring for the method).

    Parameters
    ----------
    image : array_like (H, W)
        One straight edge between two flat regions, 1 to 45 degrees off the
        pixel grid (ISO 12233 suggests about 5), spanning the image.
    oversampling : int
        ESF bins per pixel (ISO: 4).
    max_frequency : float
        Highest frequency returned, cycles per pixel.
    half_width : int
        Half-width of the region of interest, pixels along a row either side of
        the edge (at least 8): only pixels this close to the edge are used, so
        that a whole camera frame can be passed as it is (its shading and
        content far from the edge do not bias the result).

    Returns
    -------
    frequency : ndarray
        Cycles per pixel, perpendicular to the edge, from 0.
    mtf : ndarray
        Modulation transfer, 1 at zero frequency.

    Raises
    ------
    ParameterError
        No edge, an edge within 1 degree of the pixel grid, too little flat
        region beside it, or a blur wider than the region measured.

    References
    ----------
    ISO 12233:2017, Photography - Electronic still picture imaging -
    Resolution and spatial frequency responses, Annex D.
    P. D. Burns, "Slanted-edge MTF for digital camera and scanner analysis",
    Proc. IS&T PICS Conference, 135-138 (2000).

    Examples
    --------
    A step area-sampled by 1 px pixels has the pixel aperture's MTF,
    sinc(f): 0.64 at Nyquist, MTF50 at 0.60 cycles/px.

    >>> from camsim_core.scene.charts import edge_coverage
    >>> step = 0.2 + 0.6 * (1.0 - edge_coverage((200, 300), 5.0))
    >>> f, m = slanted_edge_mtf(step)
    >>> round(mtf_at(f, m), 2), round(mtf50(f, m), 2)
    (0.64, 0.6)
    """
    a = _check_image(image)
    q = int(oversampling)
    if q < 1 or q != oversampling:
        raise ParameterError("oversampling", f"must be a whole number >= 1, got {oversampling!r}")
    if isinstance(half_width, (bool, np.bool_)) or not isinstance(half_width, (int, np.integer)) or half_width < 8:
        raise ParameterError("half_width", f"must be a whole number of pixels >= 8, got {half_width!r}")
    half_width = int(half_width)
    a, _ = _oriented(a)
    p0, p1 = _edge_line(a, min(half_width, _CENTROID_HALF_WIDTH))
    theta = np.arctan(p1)
    if abs(np.degrees(theta)) < _MIN_ANGLE:
        raise ParameterError("image", f"the edge is {np.degrees(theta):.2f} degrees off the pixel grid; "
                             f"the e-SFR needs a slant of at least {_MIN_ANGLE:g} degree (ISO 12233 suggests about 5)")
    rows, cols = a.shape
    cos = np.cos(theta)
    y = np.arange(rows)[:, None]
    dist = (np.arange(cols)[None, :] - (p0 + p1 * y)) * cos  # perpendicular distance, px
    # bins covered by every row within the band: between the largest row-start and the smallest row-end
    lo = max(dist[:, 0].max(), -half_width * cos) * q
    hi = min(dist[:, -1].min(), half_width * cos) * q
    start, stop = int(np.ceil(lo)), int(np.floor(hi))
    if stop - start < 8 * q:
        raise ParameterError("image", "the edge leaves too little flat region on its sides (need 4 px or more each side)")

    n = stop - start
    pos = dist.ravel() * q - start  # in bins from the first common one
    idx = np.clip(np.floor(pos), -1, n).astype(np.int64) + 1  # bins 0 and n + 1 collect what lies outside
    counts = np.bincount(idx, minlength=n + 2)[1:-1]
    sums = np.bincount(idx, weights=a.ravel(), minlength=n + 2)[1:-1]
    where = np.bincount(idx, weights=pos, minlength=n + 2)[1:-1]
    have = counts > 0
    if have.sum() < n // 2:
        raise ParameterError("image", "too few rows for the edge's slant to fill the super-resolved bins")
    # each bin's mean at its samples' mean position (their spread within a bin is uneven for
    # some slants), then back onto the regular grid of bin centres
    esf = np.interp(np.arange(n) + 0.5, where[have] / counts[have], sums[have] / counts[have])
    _check_flat_ends(esf, q, half_width)
    lsf = np.diff(esf)
    pos = np.arange(lsf.size)
    total = lsf.sum()
    c = (lsf * pos).sum() / total if total > 0 else lsf.size / 2
    lsf = lsf * _hamming(lsf.size, c, pos)
    spectrum = np.abs(np.fft.rfft(lsf))
    freq = np.fft.rfftfreq(lsf.size, d=1.0 / q)
    mtf = spectrum / spectrum[0]
    mtf = mtf / np.sinc(freq / q) ** 2  # binning box and two-point difference
    sel = freq <= max_frequency + 1e-12
    return freq[sel], mtf[sel]


def mtf_at(frequency, mtf, at=NYQUIST):
    """MTF at ``at`` cycles per pixel, by linear interpolation (default: Nyquist)."""
    f, m = _curve(frequency, mtf)
    if not f[0] <= at <= f[-1]:
        raise ParameterError("at", f"{at} cycles/px lies outside the curve's {f[0]:g}..{f[-1]:g}")
    return float(np.interp(at, f, m))


def _curve(frequency, mtf):
    f = np.asarray(frequency, float).ravel()
    m = np.asarray(mtf, float).ravel()
    if f.size != m.size or f.size < 2:
        raise ParameterError("mtf", f"frequency and mtf must be equal-length curves, got {f.size} and {m.size}")
    if np.any(np.diff(f) <= 0):
        raise ParameterError("frequency", "must be strictly increasing")
    return f, m


def mtf50(frequency, mtf):
    """The frequency (cycles per pixel) where the MTF first falls to 0.5, linearly interpolated.

    ``nan`` when the curve stays above 0.5 over its range.
    """
    f, m = _curve(frequency, mtf)
    below = np.nonzero(m < 0.5)[0]
    if below.size == 0:
        return float("nan")
    i = below[0]
    if i == 0:
        return float(f[0])
    return float(f[i - 1] + (m[i - 1] - 0.5) * (f[i] - f[i - 1]) / (m[i - 1] - m[i]))


class EdgeMTF(dict):
    """Per channel name: ``{"frequency", "mtf", "mtf50", "mtf_nyquist"}`` (a dict; ``"luminance"`` included)."""


def luminance_weights(image):
    """Weights (K,) that take a camera image's K channels to luminance.

    With sensitivities: the least-squares fit of the CIE 1931 y-bar by the
    sensitivities, scaled to sum to 1. Otherwise for three channels Rec. 709
    (0.2126, 0.7152, 0.0722), and an equal mean for any other count.
    """
    sens = getattr(image, "sensitivities", None)
    k = np.shape(getattr(image, "data", image))[2] if np.ndim(getattr(image, "data", image)) == 3 else 1
    if sens is not None and np.shape(sens)[0] == k and np.size(image.wavelengths):
        from ..datasets.sensors import cie1931_xyz

        ybar = cie1931_xyz().on(image.wavelengths)[1]
        w, *_ = np.linalg.lstsq(np.asarray(sens, float).T, ybar, rcond=None)
        if w.sum() > 0:
            return w / w.sum()
    if k == 3:
        return np.array([0.2126, 0.7152, 0.0722])
    return np.full(k, 1.0 / k)


def edge_mtf(image, *, oversampling=4, max_frequency=1.0, half_width=EDGE_HALF_WIDTH):
    """:func:`slanted_edge_mtf` of every channel of an image and of its luminance.

    ``image``: a 2-D array, an (H, W, K) array, or a non-mosaiced
    :class:`~camsim_core.image.CameraImage` (demosaic a raw first). Returns
    an :class:`EdgeMTF` keyed by channel name (the image's sensor names, or
    ``"0"``, ``"1"``...) and ``"luminance"``.
    """
    if getattr(image, "mosaiced", False):
        raise ParameterError("image", "is a raw mosaic; demosaic it first")
    data = np.asarray(getattr(image, "data", image), float)
    if data.ndim == 2:
        data = data[:, :, None]
    if data.ndim != 3:
        raise ParameterError("image", f"expected (H, W) or (H, W, K), got shape {data.shape}")
    names = tuple(getattr(image, "sensor_names", ()) or ())
    if len(names) != data.shape[2]:
        names = tuple(str(i) for i in range(data.shape[2]))
    planes = {n: data[:, :, i] for i, n in enumerate(names)}
    planes["luminance"] = data @ luminance_weights(image) if data.shape[2] > 1 else data[:, :, 0]
    # one plane a block on the machine's cores (each plane's MTF is its own): a frame-sized chart's four
    # planes took 0.28 s in turn
    items = list(planes.items())
    curves = [None] * len(items)

    def measure(start, stop):
        for i in range(start, stop):
            curves[i] = slanted_edge_mtf(items[i][1], oversampling=oversampling, max_frequency=max_frequency,
                                         half_width=half_width)

    run_blocks(measure, range(len(items) + 1), values=data.size)
    out = EdgeMTF()
    for (name, _), (f, m) in zip(items, curves):
        out[name] = {"frequency": f, "mtf": m, "mtf50": mtf50(f, m), "mtf_nyquist": mtf_at(f, m, NYQUIST)}
    return out
