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

import io
import os
import struct
import warnings
import zlib
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import CamsimError, FileFormatError, ParameterError
from ..io.files import check_regular, read_regular
from ..spectra import resample
from ._intake import MAX_SCENE_VALUES, SceneNotice
from .scene import Scene
from .synthetic import DEFAULT_WAVELENGTHS, _illuminant, scale_to_luminance

__all__ = ["scene_from_rgb", "read_photo", "mallett_basis", "opened_image", "PHOTO_SUFFIXES", "SAMPLE_PHOTOS",
           "PILLOW_ERRORS"]

PHOTO_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
#: Photos that ship with scikit-image, usable as ``load_scene("photo-NAME")``.
SAMPLE_PHOTOS = ("astronaut", "coffee", "chelsea", "rocket")
_NOTICE = "spectra from an sRGB photo by Mallett & Yuksel 2019 upsampling: plausible, not measured"


def mallett_basis(wavelengths):
    """(3, N) Mallett 2019 basis reflectances (r, g, b) on ``wavelengths`` (nm), from colour-science."""
    from ..datasets.colour_science import table

    w, b = table("mallett2019")  # colour-science's, shipped
    return resample(w, b.T, wavelengths)


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
    from ..datasets.colour_science import srgb_to_linear

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
    linear = srgb_to_linear(a)
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


#: What Pillow and its decoders raise on a malformed file (``PIL.UnidentifiedImageError`` is an OSError;
#: a PNG's chunk parser raises SyntaxError, its zlib stream zlib.error, a short header struct.error or EOFError).
PILLOW_ERRORS = (OSError, SyntaxError, ValueError, EOFError, struct.error, zlib.error)
#: Modes Pillow converts to 8-bit RGB with a photo's meaning (grey, palette, colour, with or without alpha).
_EIGHT_BIT_MODES = ("1", "L", "LA", "P", "PA", "RGB", "RGBA", "RGBX", "RGBa", "CMYK", "YCbCr")
#: 16-bit grey modes, read at full precision.
_SIXTEEN_BIT_MODES = ("I;16", "I;16L", "I;16B", "I;16N")
#: Modes Pillow gives 16-bit colour (or grey with alpha) files, decoding them to 8 bits: such files are decoded
#: by imagecodecs (PNG) or tifffile (TIFF) instead, which keep the 16 bits.
_SIXTEEN_BIT_COLOUR_MODES = ("RGB", "RGBA", "LA")
#: EXIF tag of the orientation (TIFF 6.0 tag 274): how the stored pixels are turned for display.
_ORIENTATION = 0x0112


def _without_path(exc, path, shown):
    """``exc``'s message with ``path`` (a server's temporary folder, say) replaced by ``shown``."""
    text = str(exc) or type(exc).__name__
    for p in sorted({os.fspath(path), os.fspath(Path(path).resolve())}, key=len, reverse=True):
        text = text.replace(p, str(shown))
    return text


@contextmanager
def opened_image(path, shown=None, kind="image"):
    """Pillow's image of the file ``path``, opened lazily (its header read, no pixel decoded yet).

    Check ``im.size`` and ``im.mode`` in the ``with`` body before decoding
    (``im.load()``, ``np.asarray(im)``). Pillow's errors on a malformed
    file (:data:`PILLOW_ERRORS`) and its decompression-bomb guard (the
    error, and the warning Pillow gives between ``Image.MAX_IMAGE_PIXELS``
    and twice that, made an error here) become a
    :class:`~camsim_core.errors.FileFormatError` naming ``shown`` (default:
    the file's name), never the folder the file was read from, and saying
    it is not a readable ``kind``. A
    :class:`~camsim_core.errors.CamsimError` raised in the body passes
    through unchanged.

    The warning is made an error with :func:`warnings.catch_warnings`,
    which changes the process's filters while the file is opened and
    decoded.
    """
    from PIL import Image, UnidentifiedImageError

    shown = Path(path).name if shown is None else shown
    check_regular(path, shown)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                yield im
        _pass_on(caught, path, shown)
    except CamsimError:
        raise
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise FileFormatError(shown, f"refused as a possible decompression bomb (Pillow's limit is "
                                     f"{Image.MAX_IMAGE_PIXELS:,} pixels): {_without_path(exc, path, shown)}") from None
    except UnidentifiedImageError:
        raise FileFormatError(shown, f"not a readable {kind} (not an image format Pillow knows)") from None
    except PILLOW_ERRORS as exc:
        raise FileFormatError(shown, f"not a readable {kind} ({type(exc).__name__}: "
                                     f"{_without_path(exc, path, shown)})") from None


def _pass_on(caught, path, shown):
    """Warnings recorded while a file was opened and read, passed on: what Pillow said of a damaged file
    ("Corrupt EXIF data", "Truncated File Read", a TIFF tag past the file's end) as a notice naming the file
    (never the folder it was read from), every other warning as it was."""
    for w in caught:
        if issubclass(w.category, SceneNotice) or "PIL" not in Path(w.filename or "").parts:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        else:
            warnings.warn(f"{shown}: looks damaged, read as far as Pillow could "
                          f"({_without_path(w.message, path, shown)})", SceneNotice, stacklevel=4)


def _sixteen_bit_colour(im):
    """Whether Pillow opened a 16-bit-per-channel colour PNG or TIFF (which it would decode to 8 bits)."""
    if im.format not in ("PNG", "TIFF") or im.mode not in _SIXTEEN_BIT_COLOUR_MODES or not im.tile:
        return False
    args = im.tile[0].args
    rawmode = args if isinstance(args, str) else (args[0] if isinstance(args, tuple) and args else "")
    return isinstance(rawmode, str) and ";16" in rawmode


def _decode_sixteen_bit(im, path, shown, h, w):
    """(H, W, C) uint16 values of a 16-bit colour PNG (imagecodecs, libpng) or TIFF (tifffile), first image only.

    The size was checked from the header; the file may hold at most 8 bytes a pixel
    (6 for 16-bit RGB) plus 1 MiB of other chunks.
    """
    import imagecodecs
    import tifffile

    channels = {"RGB": 3, "RGBA": 4, "LA": 2}[im.mode]
    data = read_regular(path, max_bytes=w * h * 8 + 2**20, shown=shown)
    try:
        if im.format == "PNG":
            a = imagecodecs.png_decode(data)
        else:
            with tifffile.TiffFile(io.BytesIO(data)) as tf:
                page = tf.pages[0]
                if tuple(page.shape) != (h, w, channels):
                    raise FileFormatError(shown, f"its first TIFF image is {tuple(page.shape)}, expected {h} x {w} x {channels}")
                a = page.asarray()
    except CamsimError:
        raise
    except (RuntimeError, ValueError, TypeError, OSError, EOFError, struct.error, zlib.error, KeyError,
            IndexError) as exc:  # imagecodecs' errors are RuntimeErrors, tifffile's ValueErrors
        raise FileFormatError(shown, f"not a readable 16-bit image ({type(exc).__name__}: "
                                     f"{_without_path(exc, path, shown)})") from None
    a = np.asarray(a)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.shape != (h, w, channels) or a.dtype != np.uint16:
        raise FileFormatError(shown, f"decoded to an array of shape {a.shape} and type {a.dtype}, "
                                     f"expected {h} x {w} x {channels} 16-bit values")
    return a


def _orientation(im):
    """The EXIF orientation (1-8) of an opened image, 1 when it has none."""
    value = im.getexif().get(_ORIENTATION, 1)
    return value if isinstance(value, int) and 1 <= value <= 8 else 1


def _upright_planes(a, im):
    """``a`` (H, W, C) turned upright as ``im``'s EXIF orientation says, by Pillow's ``ImageOps.exif_transpose``.

    Pillow holds no 16-bit colour image, so each plane is turned as a 16-bit grey image carrying the photo's EXIF.
    """
    from PIL import Image, ImageOps

    exif = im.getexif().tobytes()
    planes = []
    for k in range(a.shape[2]):
        plane = Image.fromarray(np.ascontiguousarray(a[:, :, k]))
        plane.info["exif"] = exif
        planes.append(np.asarray(ImageOps.exif_transpose(plane)))
    return np.stack(planes, axis=2)


def read_photo(path, *, max_values=None, shown=None, **options):
    """A photo file (PNG, JPEG, TIFF, BMP; 8 or 16 bits) or ``photo-NAME`` of :data:`SAMPLE_PHOTOS` as a scene.

    The pixel count and mode are read from the header and checked before
    decoding (pixels x bands at most ``max_values``, and
    :data:`MAX_SCENE_VALUES`); a malformed file, a decompression bomb or an
    image mode that is not a photo's (floating point, 32-bit integers
    beyond 16 bits) is a :class:`~camsim_core.errors.FileFormatError`
    naming ``shown`` (default: the file's name). ``options`` go to
    :func:`scene_from_rgb`.

    The photo is turned upright as its EXIF orientation says (a phone's
    portrait JPEG is stored sideways with orientation 6 or 8), by Pillow's
    ``ImageOps.exif_transpose``. 16-bit grey keeps its 65536 levels through
    Pillow; 16-bit colour PNGs are decoded by imagecodecs (libpng) and
    16-bit colour TIFFs by tifffile, because Pillow reduces 16-bit colour
    to 8 bits.

    Parameters
    ----------
    path : path-like or str
        The photo file, or ``"photo-NAME"``.
    max_values : int, optional
        A tighter bound on pixels x bands (an upload's limit).
    shown : str, optional
        The name messages give the file.
    **options
        Passed to :func:`scene_from_rgb` (``illuminant``, ``luminance``,
        ``distance``, ``angular_resolution``, ``wavelengths``).

    Returns
    -------
    Scene
        Radiance in W/sr/m^2 per band, the photo's rows and columns as it is displayed.

    Examples
    --------
    >>> read_photo("photo-coffee").shape
    (400, 600, 31)
    """
    key = str(path)
    if key.lower().startswith("photo-") and key[6:].lower() in SAMPLE_PHOTOS:
        rgb = _sample_photo(key[6:].lower()) / 255.0
        return scene_from_rgb(rgb, name=key.lower(), **options)
    from PIL import ImageOps

    path = Path(path)
    shown = path.name if shown is None else shown
    n = len(np.atleast_1d(options.get("wavelengths", DEFAULT_WAVELENGTHS)))
    limit = MAX_SCENE_VALUES if max_values is None else min(int(max_values), MAX_SCENE_VALUES)
    with opened_image(path, shown) as im:
        w, h = im.size
        if w < 1 or h < 1:
            raise FileFormatError(shown, f"declares {w} x {h} pixels; expected at least one")
        if w * h * n > limit:
            raise FileFormatError(shown, f"{w} x {h} pixels x {n} bands is more than the {limit} values allowed; "
                                         "downsize the photo")
        if _sixteen_bit_colour(im):
            a = _decode_sixteen_bit(im, path, shown, h, w)
            im.load()  # an eXIf chunk after the pixels is read with them
            if _orientation(im) != 1:
                a = _upright_planes(a, im)
            full = 65535.0
        elif im.mode in _SIXTEEN_BIT_MODES or im.mode == "I":
            im.load()
            a = np.asarray(ImageOps.exif_transpose(im) if _orientation(im) != 1 else im)
            full = 65535.0
        elif im.mode in _EIGHT_BIT_MODES:
            im.load()  # a transparency chunk after the pixels is read with them
            upright = ImageOps.exif_transpose(im) if _orientation(im) != 1 else im
            # RGBA first when a palette marks a transparent colour (Pillow's advice)
            a = np.asarray(upright.convert("RGBA" if "transparency" in im.info else "RGB"))
            full = 255.0
        else:
            raise FileFormatError(shown, f"image mode {im.mode!r} is not a photo's; expected 8 or 16 bits per channel "
                                         "(grey, palette or RGB)")
    if sorted(a.shape[:2]) != sorted((h, w)) or a.dtype.kind not in "biu":
        raise FileFormatError(shown, f"decoded to an array of shape {a.shape} and type {a.dtype}, "
                                     f"expected {h} x {w} whole numbers")
    if a.size and (a.min() < 0 or a.max() > full):
        raise FileFormatError(shown, f"holds values {a.min()}..{a.max()}, outside 0..{full:g} of "
                                     f"{'16' if full > 255 else '8'}-bit data")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.shape[2] < 3:  # grey, or grey with alpha
        a = np.repeat(a[:, :, :1], 3, axis=2)
    rgb = a[:, :, :3].astype(float) / full
    return scene_from_rgb(rgb, name=path.stem, **options)
