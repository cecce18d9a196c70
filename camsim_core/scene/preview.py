"""An sRGB preview of a hyperspectral scene: what it looks like on an ordinary screen.

The radiance of each pixel becomes CIE 1931 XYZ (the sum over bands of the
colour-matching functions times the radiance per band), is scaled so that
the 99th percentile of its luminance Y is 1 (the brightest 1 % clip), and
goes to sRGB with the sRGB transfer function
(:func:`camsim_core.datasets.colour_science.xyz_to_srgb`, the numbers of
colour-science's ``XYZ_to_sRGB``; sRGB's white is D65, so no chromatic
adaptation).

A preview, not a rendering of the chapter's pipeline: the scene as a human
observer would roughly see it, for notebooks (``Scene._repr_html_``) and
viewers. The explorer's scene view does the same (``camsim_explorer.views``).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..screen import to_screen

__all__ = ["spectral_srgb", "scene_srgb", "PREVIEW_PERCENTILE"]

#: Percentile of the luminance Y shown as white: the brightest (100 - this) % of the pixels clip.
PREVIEW_PERCENTILE = 99.0


def spectral_srgb(data, wavelengths, *, percentile=PREVIEW_PERCENTILE):
    """sRGB (H, W, 3) in [0, 1] of spectral planes: CIE 1931 XYZ, the ``percentile`` of Y as white.

    Parameters
    ----------
    data : array_like (H, W, N)
        Radiance per band (any unit: the preview is relative), e.g. W/sr/m^2 per band.
    wavelengths : array_like (N,)
        nm. Bands outside the colour-matching functions' 360-830 nm add nothing.
    percentile : float
        The percentile (0-100] of the luminance Y that becomes sRGB white (Y = 1).

    Returns
    -------
    ndarray (H, W, 3)
        sRGB values in [0, 1], transfer function applied (float64). All zero
        for a scene without light in the visible range.

    References
    ----------
    IEC 61966-2-1:1999, sRGB. CIE 015:2004, Colorimetry (the 1931 2-degree
    observer, from colour-science).

    Examples
    --------
    A uniform scene with the spectrum of CIE D65 is sRGB white (D65 is sRGB's white point):

    >>> import numpy as np
    >>> from camsim_core.datasets.illuminants import illuminant
    >>> w = np.arange(400.0, 701.0, 10.0)
    >>> cube = np.broadcast_to(illuminant("D65").on(w), (2, 3, w.size))
    >>> np.round(spectral_srgb(cube, w)[0, 0], 2).tolist()
    [1.0, 1.0, 1.0]
    """
    from ..datasets.colour_science import xyz_to_srgb
    from ..datasets.sensors import cie1931_xyz

    a = np.asarray(data)
    w = np.asarray(wavelengths, float).ravel()
    if a.ndim != 3 or a.shape[2] != w.size:
        raise ParameterError("data", f"must be (H, W, N) planes for {w.size} wavelengths, got shape {a.shape}")
    p = float(percentile)
    if not (0 < p <= 100):
        raise ParameterError("percentile", f"must be in (0, 100], got {percentile!r}")
    bar = np.asarray(cie1931_xyz().on(w), float).T  # (N, 3)
    h, width, n = a.shape
    xyz = (a.reshape(-1, n).astype(float, copy=False) @ bar).reshape(h, width, 3)
    scale = np.percentile(xyz[..., 1], p) if xyz.size else 0.0
    if not np.isfinite(scale) or scale <= 0:
        scale = float(np.max(xyz[..., 1])) if xyz.size else 0.0
    if not np.isfinite(scale) or scale <= 0:
        return np.zeros((h, width, 3))
    rgb = xyz_to_srgb(xyz / scale)
    return np.clip(np.nan_to_num(rgb), 0.0, 1.0)


def scene_srgb(scene, *, max_side=None, percentile=PREVIEW_PERCENTILE):
    """sRGB preview (h, w, 3) in [0, 1] of a :class:`~camsim_core.scene.Scene`.

    Parameters
    ----------
    scene : Scene
        The hyperspectral scene.
    max_side : int, optional
        Longest side of the preview, pixels: the radiance is first averaged
        over square blocks of pixels (:func:`camsim_core.screen.to_screen`)
        until it fits. Default: the scene's own size.
    percentile : float
        See :func:`spectral_srgb`.

    Returns
    -------
    ndarray (h, w, 3)
        sRGB values in [0, 1].

    References
    ----------
    IEC 61966-2-1:1999, sRGB.

    Examples
    --------
    >>> import camsim_core as cs
    >>> rgb = scene_srgb(cs.load_scene("macbeth"), max_side=32)
    >>> max(rgb.shape[:2]) <= 32, rgb.shape[2], bool(rgb.min() >= 0 and rgb.max() <= 1)
    (True, 3, True)
    """
    data = scene.data
    if max_side is not None:
        side = int(max_side)
        if side < 1:
            raise ParameterError("max_side", f"must be a positive number of pixels, got {max_side!r}")
        data, _ = to_screen(data, (side, side))
    return spectral_srgb(data, scene.wavelengths, percentile=percentile)
