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

__all__ = ["demosaic", "METHODS", "saturation_level"]


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


def saturation_level(image):
    """The value (or one per sensor class) at which ``image``'s raw clipped, in the units of its data.

    ``full_scale`` while the image still carries its pedestal, ``full_scale -
    black_level`` once processing subtracted it (``extra["saturation"]``);
    ``None`` for an unquantized image, which has no ADC to clip it.
    """
    if image.full_scale is None or not image.quantized:
        return None
    if not np.any(np.asarray(image.black_level, float)) and "saturation" in image.extra:
        return image.extra["saturation"]
    return image.full_scale


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
    """
    key = str(method).lower()
    if key not in METHODS:
        raise ParameterError("method", f"unknown demosaicing method {method!r}; valid: {', '.join(METHODS)}")
    check_mosaiced(image, key)
    _check_size(image)
    image = subtract_black_level(image)
    out = METHODS[key](image, **options)
    extra = dict(image.extra)
    extra["demosaic"] = key
    return image.then(f"demosaic:{key}", data=out, mosaiced=False, space="sensor", extra=extra)
