"""Any sRGB photograph as a hyperspectral scene, by spectral upsampling (a plausible, not a measured, spectrum).

Each pixel's linear sRGB values weight Mallett & Yuksel's three basis
reflectances (colour-science's ``MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019``):
reflectance = r b_r + g b_g + b b_b, bounded in [0, 1] for colours inside
the sRGB gamut, and equal to the pixel's sRGB colour when lit by D65 and
seen by the CIE 1931 observer. Radiance = reflectance x illuminant, the
illuminant scaled so that a white pixel (1, 1, 1) has ``luminance`` cd/m^2.

Reference: I. Mallett and C. Yuksel, "Spectral Primary Decomposition for
Rendering with sRGB Reflectance", EGSR 2019.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FileFormatError, ParameterError
from ..spectra import resample
from ._intake import MAX_SCENE_VALUES
from .scene import Scene
from .synthetic import DEFAULT_WAVELENGTHS, _illuminant, scale_to_luminance

__all__ = ["scene_from_rgb", "read_photo", "mallett_basis", "PHOTO_SUFFIXES", "SAMPLE_PHOTOS"]

PHOTO_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
#: Photos that ship with scikit-image, usable as ``load_scene("photo-NAME")``.
SAMPLE_PHOTOS = ("astronaut", "coffee", "chelsea", "rocket")
_NOTICE = "spectra from an sRGB photo by Mallett & Yuksel 2019 upsampling: plausible, not measured"


def mallett_basis(wavelengths):
    """(3, N) Mallett 2019 basis reflectances (r, g, b) on ``wavelengths`` (nm), from colour-science."""
    import colour

    b = colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019
    return resample(b.wavelengths, b.values.T, wavelengths)


def scene_from_rgb(rgb, *, illuminant="D65", luminance=100.0, distance=1.0, angular_resolution=(57.3, 57.3),
                   wavelengths=DEFAULT_WAVELENGTHS, name="photo"):
    """A plausible hyperspectral :class:`Scene` from an sRGB image (values in [0, 1]).

    The spectra are *plausible, not measured*: any metamer of the pixel's
    colour would be as right, and the one chosen is the Mallett 2019 linear
    combination (see the module docstring).

    Parameters
    ----------
    rgb : array_like (H, W, 3)
        Non-linear (gamma-encoded) sRGB values in [0, 1].
    illuminant : str or Spectrum
        Lights the reflectances (``"D65"`` reproduces the photo's colours).
    luminance : float
        cd/m^2 of a white pixel.
    distance : float
        m.
    angular_resolution : (x, y)
        Pixels per degree.
    wavelengths : array_like
        nm, default 400:10:700.
    """
    import colour

    a = np.asarray(rgb)
    if a.ndim != 3 or a.shape[2] != 3 or a.size == 0:
        raise ParameterError("rgb", f"an sRGB image must be (H, W, 3), got shape {a.shape}")
    if not np.issubdtype(a.dtype, np.number):
        raise ParameterError("rgb", f"must hold numbers, got {a.dtype}")
    a = a.astype(float)
    if not np.all(np.isfinite(a)) or a.min() < 0 or a.max() > 1:
        raise ParameterError("rgb", f"values must lie in [0, 1] (got {np.nanmin(a):g}..{np.nanmax(a):g}); divide 8-bit data by 255")
    if not (np.isfinite(luminance) and luminance > 0):
        raise ParameterError("luminance", f"must be a positive number of cd/m^2, got {luminance!r}")
    w = np.asarray(wavelengths, float)
    if a.shape[0] * a.shape[1] * w.size > MAX_SCENE_VALUES:
        raise ParameterError("rgb", f"{a.shape[0]} x {a.shape[1]} pixels x {w.size} bands is more than {MAX_SCENE_VALUES} values")
    linear = colour.cctf_decoding(a, function="sRGB")
    spd, e = _illuminant(illuminant, w)
    e = e * scale_to_luminance(w, e, luminance)
    weights = mallett_basis(w) * e[None, :]  # (3, N): radiance of each primary reflectance
    h, wd, _ = a.shape
    cube = np.clip((linear.reshape(-1, 3) @ weights).reshape(h, wd, w.size), 0.0, None)
    from ..spectra import Spectrum

    return Scene(cube, w, distance, angular_resolution, "W/sr/m^2 per band", Spectrum(w, e, spd.name), name,
                 f"sRGB photo under {spd.name or 'the illuminant'} at {luminance:g} cd/m^2 (Mallett 2019 upsampling)",
                 (_NOTICE,))


def _sample_photo(name):
    from skimage import data

    return getattr(data, name)()


def read_photo(path, *, max_values=None, **options):
    """A photo file (PNG, JPEG, TIFF, BMP; 8 or 16 bits) or ``photo-NAME`` of :data:`SAMPLE_PHOTOS` as a scene.

    The pixel count is read from the header and checked before decoding
    (pixels x bands at most ``max_values``, and :data:`MAX_SCENE_VALUES`);
    ``options`` go to :func:`scene_from_rgb`.
    """
    key = str(path)
    if key.lower().startswith("photo-") and key[6:].lower() in SAMPLE_PHOTOS:
        rgb = _sample_photo(key[6:].lower()) / 255.0
        return scene_from_rgb(rgb, name=key.lower(), **options)
    from PIL import Image, UnidentifiedImageError

    from ..io.files import check_regular

    path = Path(path)
    n = len(np.atleast_1d(options.get("wavelengths", DEFAULT_WAVELENGTHS)))
    limit = MAX_SCENE_VALUES if max_values is None else min(int(max_values), MAX_SCENE_VALUES)
    check_regular(path)
    try:
        with Image.open(path) as im:
            w, h = im.size
            if w * h * n > limit:
                raise FileFormatError(path, f"{w} x {h} pixels x {n} bands is more than the {limit} values allowed; "
                                            "downsize the photo")
            sixteen = im.mode.startswith("I")
            a = np.asarray(im if sixteen else im.convert("RGB"))
    except (UnidentifiedImageError, OSError) as exc:
        raise FileFormatError(path, f"not a readable image ({exc})") from None
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    rgb = a.astype(float) / (65535.0 if sixteen else 255.0)
    return scene_from_rgb(np.clip(rgb[:, :, :3], 0, 1), name=path.stem, **options)
