"""Demosaicing (chapter section 4.1): estimate every sensor class at every pixel.

``demosaic(image, method)`` takes a mosaiced :class:`~camsim_core.image.CameraImage`
(one plane plus its tile, or a tiered tile) and returns a new image with
``(H, W, K)`` sensor planes, ``mosaiced=False``, the tile kept, and
``"demosaic:METHOD"`` appended to its history.

Methods: ``bilinear`` (any tile), ``freeman`` (any tile), ``bayesian``
(any tile; camsim's extension of Brainard's method: an achromatic detail
term, local means, a 7 x 7 window, the image's noise sigma),
``bayesian-original`` (any tile; as close to Brainard's method as the
chapter allows: 5 x 5, no detail term, one global mean, a noise fraction;
see :mod:`.bayesian`), ``malvar2004`` and ``menon2007`` (Bayer tiles only,
through colour-demosaicing).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..image import subtract_black_level
from ._masks import check_mosaiced

__all__ = ["demosaic", "METHODS", "reach", "clipped_samples", "saturation_level"]


def _bilinear(image, **options):
    from .bilinear import demosaic_bilinear

    return demosaic_bilinear(image, **options)


def _freeman(image, **options):
    from .freeman import demosaic_freeman

    return demosaic_freeman(image, **options)


def _bayesian(image, **options):
    from .bayesian import demosaic_bayesian

    return demosaic_bayesian(image, **options)


def _bayesian_original(image, **options):
    from .bayesian import demosaic_bayesian

    return demosaic_bayesian(image, mode="original", **options)


def _malvar(image, **options):
    from .bayer import demosaic_malvar2004

    return demosaic_malvar2004(image, **options)


def _menon(image, **options):
    from .bayer import demosaic_menon2007

    return demosaic_menon2007(image, **options)


METHODS = {
    "bilinear": _bilinear,
    "freeman": _freeman,
    "bayesian": _bayesian,
    "bayesian-original": _bayesian_original,
    "malvar2004": _malvar,
    "menon2007": _menon,
}


def _check_size(image):
    """A mosaic must repeat its tile at least twice each way: each sensor then has a neighbour of its own
    class to interpolate from (a far camera or large pixels can leave a scene only a few pixels)."""
    h, w = np.shape(image.data)[:2]
    th, tw = np.shape(image.tile)
    if h < 2 * th or w < 2 * tw:
        raise ParameterError("image", f"is {h} x {w} pixels, fewer than two mosaic tiles ({2 * th} x {2 * tw}) a side: "
                                      "too small to demosaic (bring the camera closer, or use smaller pixels)")


def reach(method, tile, **options):
    """(rows, columns): how far from a raw sample the estimates of ``method`` may change with it.

    Bilinear interpolates each class from its own samples with the tent of
    the tile's period (``n - 1`` rows, ``m - 1`` columns); Freeman adds its
    median of differences (``size // 2``); Malvar's filters are 5 x 5; the
    Bayesian estimate reads the samples of its window (``window // 2``; its
    prior, estimated over the whole image, is not counted); Menon's
    directional filters, decision and refining step reach 8 pixels at most
    (measured: a single changed sample of a random Bayer mosaic moves
    estimates up to 8 pixels away, never further).
    """
    n, m = np.shape(tile)[:2]
    key = str(method).lower()
    if key == "bilinear":
        return n - 1, m - 1
    if key == "freeman":
        r = int(options.get("size", 5)) // 2
        return n - 1 + r, m - 1 + r
    if key in ("bayesian", "bayesian-original"):
        window = options.get("window")
        if window is None:
            window = 5 if key == "bayesian-original" or options.get("mode") == "original" else 2 * max(n, m) + 3
        return int(window) // 2, int(window) // 2
    if key == "malvar2004":
        return 2, 2
    return 8, 8


def saturation_level(image):
    """The value (or one per sensor class) at which ``image``'s raw clipped, in the units of its data.

    The ADC's: ``full_scale`` while the image still carries its pedestal, ``full_scale - black_level`` once
    processing subtracted it (``extra["saturation"]``). A simulated electron-level sensor's charge saturates at
    its full well (``extra["sensor_saturation"]``, above the black level), which may come first, and is the only
    clip of an unquantized one. ``None`` for an image that nothing clipped (unquantized, no full well).
    """
    adc = None
    if image.full_scale is not None:
        adc = image.full_scale
        if not np.any(np.asarray(image.black_level, float)) and "saturation" in image.extra:
            adc = image.extra["saturation"]
    well = image.extra.get("sensor_saturation")
    if well is None:
        return adc
    well = float(well) + np.asarray(image.black_level, float)  # 0 once the pedestal is subtracted
    level = well if adc is None else np.minimum(np.asarray(adc, float), well)
    return float(level) if np.ndim(level) == 0 else tuple(float(v) for v in np.ravel(level))


def clipped_samples(image):
    """(H, W) boolean: the pixels at which the raw reached its full scale (any tier); ``None`` when none did.

    A clipped value is a lower bound of what the pixel received, not a
    measurement: rendering shows such pixels as the display's white
    (:func:`camsim_core.render`) instead of as the darker colour their
    clipped values would give once the exposure is divided out.
    """
    level = saturation_level(image)
    if level is None:
        return None
    data = np.asarray(image.data)
    level = np.asarray(level, float)
    if level.ndim and image.mosaiced and image.tile is not None:
        from ..simulation.mosaic import tile_index_map

        level = level[tile_index_map(image.tile, data.shape[:2])]
    elif level.ndim and data.ndim == 3 and data.shape[2] != level.size:
        return None
    # quantized values: a half step below the full scale is the full scale (the full well's level already has its
    # margin for read noise). The maximum first: an image that did not clip (the usual case) costs one reduction
    half = 0.5 if image.quantized else 0.0
    if data.size == 0 or not np.nanmax(data - level if level.ndim else data) >= (-half if level.ndim else float(level) - half):
        return None
    hit = data >= level - half
    if hit.ndim == 3:
        hit = hit.any(axis=2)
    return hit if hit.any() else None


def _clipped_after(image, key, options):
    """The pixels whose estimate may hold a clipped raw sample: :func:`clipped_samples` widened by the method's
    :func:`reach` (``None`` when nothing clipped). Read-only."""
    hit = clipped_samples(image)
    if hit is None:
        return None
    from scipy.ndimage import maximum_filter

    ry, rx = reach(key, image.tile, **options)
    out = maximum_filter(hit.view(np.uint8), size=(2 * ry + 1, 2 * rx + 1), mode="constant").view(bool)
    out.flags.writeable = False
    return out


def demosaic(image, method="bilinear", **options):
    """Demosaic a camera image.

    Parameters
    ----------
    image : CameraImage
        Mosaiced (``image.mosaiced`` and a ``tile``), in digital units. Its
        ``black_level`` (pedestal) is subtracted first; the values stay
        signed (floating point): the noise around black is kept, not
        clipped at 0, so that a dark frame stays unbiased. The result has
        ``black_level`` 0 and ``extra["saturation"]``, the level at which
        the raw clipped after the subtraction (:func:`saturation_level`).
    method : str
        One of :data:`METHODS`.
    **options
        Passed to the method (e.g. ``size`` for Freeman's median filter,
        ``window`` for the Bayesian neighbourhood).

    Returns
    -------
    CameraImage
        ``space="sensor"``, data (H, W, K), ``mosaiced=False``, tile kept.
        ``extra["clipped"]``: (H, W) boolean, the pixels whose estimates
        may hold a raw sample at full scale (the clipped samples widened
        by the method's :func:`reach`), or ``None`` when none clipped; it
        holds for these data only (``extra["clipped_of"]`` is the data
        array it describes).

    Examples
    --------
    A uniform raw demosaics to uniform planes:

    >>> import numpy as np
    >>> from camsim_core.io.raw import raw_from_array
    >>> full = demosaic(raw_from_array(np.full((4, 4), 100, np.uint8), "GRBG"))
    >>> full.data.shape, float(full.data.min()), float(full.data.max())
    ((4, 4, 3), 100.0, 100.0)
    """
    key = str(method).lower()
    if key not in METHODS:
        raise ParameterError("method", f"unknown demosaicing method {method!r}; valid: {', '.join(METHODS)}")
    check_mosaiced(image, key)
    _check_size(image)
    clipped = _clipped_after(image, key, options)
    image = subtract_black_level(image)
    out = METHODS[key](image, **options)
    extra = dict(image.extra)
    extra["demosaic"] = key
    # the mask describes these data: an image whose data are replaced (image.replace(data=...)) carries none
    extra["clipped"], extra["clipped_of"] = clipped, out
    return image.then(f"demosaic:{key}", data=out, mosaiced=False, space="sensor", extra=extra)
