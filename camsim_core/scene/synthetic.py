"""Synthetic scenes: a Macbeth chart under any illuminant, and the thin-stripe scene of Figure 1.10."""

from __future__ import annotations

import numpy as np

from ..datasets.illuminants import illuminant as named_illuminant
from ..datasets.surfaces import macbeth
from ..errors import ParameterError
from ..spectra import Spectrum, resample, sampling_wavelengths
from .scene import Scene

__all__ = ["macbeth_scene", "stripe_scene", "DEFAULT_WAVELENGTHS", "scale_to_luminance"]

#: The hyperspectral sampling of the chapter: 400:10:700 nm.
DEFAULT_WAVELENGTHS = sampling_wavelengths(400, 10, 31)


def _illuminant(illum, wavelengths):
    if isinstance(illum, Spectrum):
        spd = illum
    else:
        spd = named_illuminant(str(illum))
    return spd, spd.on(wavelengths)


def scale_to_luminance(wavelengths, spd_values, luminance):
    """Factor that gives ``spd_values`` (per band) a luminance of ``luminance`` cd/m^2.

    Luminance is 683 lm/W times the sum over bands of y-bar times radiance per
    band (CIE 1931 y-bar from colour-science, interpolated).

    Examples
    --------
    >>> import numpy as np
    >>> from camsim_core.datasets.sensors import cie1931_xyz
    >>> w = DEFAULT_WAVELENGTHS
    >>> k = scale_to_luminance(w, np.ones(w.size), 100.0)
    >>> round(683 * float(cie1931_xyz().on(w)[1] @ (k * np.ones(w.size))), 6)
    100.0
    """
    from ..datasets.sensors import cie1931_xyz

    ybar = cie1931_xyz().on(wavelengths)[1]
    y = 683.0 * float(ybar @ np.asarray(spd_values, float))
    if y <= 0:
        raise ParameterError("illuminant", "has no power in the visible range")
    return luminance / y


def macbeth_scene(
    illuminant="D65",
    *,
    patch_size=16,
    border=4,
    wavelengths=DEFAULT_WAVELENGTHS,
    white_luminance=100.0,
    distance=1.0,
    angular_resolution=(57.3, 57.3),
):
    """A Macbeth ColorChecker (4 x 6 patches of ``patch_size`` px, ``border`` px of black gaps).

    The illuminant (a name of :data:`~camsim_core.datasets.illuminants.ILLUMINANT_NAMES`
    or a :class:`Spectrum`) is scaled so that a perfect white reflector would
    have ``white_luminance`` cd/m^2. Radiance = reflectance x illuminant, per
    band. Gaps have zero reflectance. The scene's ``comments`` name the patch
    order; :func:`patch_centers` gives where each patch lies.

    Examples
    --------
    Patches of 4 px with 1 px gaps: 4 x 6 patches, 31 bands (400-700 nm):

    >>> macbeth_scene(patch_size=4, border=1).shape
    (21, 31, 31)
    """
    if patch_size < 1 or border < 0:
        raise ParameterError("patch_size", "must be >= 1 (and border >= 0)")
    w = np.asarray(wavelengths, float)
    spd, e = _illuminant(illuminant, w)
    e = e * scale_to_luminance(w, e, white_luminance)
    mw, refl, names = macbeth()
    r = resample(mw, refl, w)
    # BabelColor data stop at 730 nm: hold the last value beyond it rather than dropping to 0
    beyond = w > mw[-1]
    r[:, beyond] = refl[:, -1:]
    step = patch_size + border
    h, wd = border + 4 * step, border + 6 * step
    data = np.zeros((h, wd, w.size))
    for i in range(24):
        row, col = divmod(i, 6)
        y0, x0 = border + row * step, border + col * step
        data[y0 : y0 + patch_size, x0 : x0 + patch_size, :] = r[i] * e
    return Scene(
        data,
        w,
        distance=distance,
        angular_resolution=angular_resolution,
        illuminant=Spectrum(w, e, spd.name),
        name="macbeth",
        comments="Macbeth ColorChecker (BabelColor average), patches row by row: " + ", ".join(names),
    )


def patch_centers(patch_size=16, border=4):
    """(row, col) pixel centres of the 24 patches of :func:`macbeth_scene`.

    Examples
    --------
    >>> patch_centers(16, 4)[:2]
    [(12, 12), (12, 32)]
    """
    step = patch_size + border
    return [(border + (i // 6) * step + patch_size // 2, border + (i % 6) * step + patch_size // 2) for i in range(24)]


def stripe_scene(
    height=64,
    width=64,
    *,
    period=2,
    phase=0,
    orientation="vertical",
    illuminant="D65",
    wavelengths=DEFAULT_WAVELENGTHS,
    white_luminance=100.0,
    distance=1.0,
    angular_resolution=(102.6, 102.6),
):
    """Thin green stripes on white, one pixel wide (chapter Figure 1.10).

    Every ``period``-th column (row, if horizontal) from ``phase`` is green:
    a reflectance of 0.9 from 500 to 570 nm and 0.02 elsewhere; the rest is a
    0.9 white. Give the scene the simulated camera's distance and angular
    resolution so that resampling leaves it pixel for pixel: with a GR/BG
    Bayer tile and ``phase=0`` the stripes cover every blue pixel and no red
    one, which is the figure's yellow-field case.

    Examples
    --------
    >>> scene = stripe_scene(8, 8, period=2)
    >>> scene.shape, scene.name
    ((8, 8, 31), 'stripes')
    """
    w = np.asarray(wavelengths, float)
    spd, e = _illuminant(illuminant, w)
    e = e * scale_to_luminance(w, e, white_luminance)
    green = np.where((w >= 500) & (w <= 570), 0.9, 0.02)
    white = np.full_like(w, 0.9)
    data = np.broadcast_to(white * e, (height, width, w.size)).copy()
    idx = np.arange(phase, width if orientation == "vertical" else height, period)
    if orientation == "vertical":
        data[:, idx, :] = green * e
    else:
        data[idx, :, :] = green * e
    return Scene(
        data,
        w,
        distance=distance,
        angular_resolution=angular_resolution,
        illuminant=Spectrum(w, e, spd.name),
        name="stripes",
        comments=f"green stripes every {period} px from {phase} ({orientation}) on white (Figure 1.10)",
    )
