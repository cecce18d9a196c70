"""Raw files out and in: a simulated raw as a CFA DNG (tifffile), and real raws through rawpy (LibRaw).

:func:`write_dng` writes one uncompressed CFA image with the DNG 1.4 tags a
raw converter needs (Adobe, *Digital Negative Specification* 1.4.0.0):

* ``CFARepeatPatternDim`` / ``CFAPattern`` from the camera's mosaic tile,
  ``CFAPlaneColor`` R, G, B (sensors ranked by their mean wavelength,
  longest = red) and ``CFALayout`` 1 (rectangular);
* ``BlackLevel`` (the image's ``black_level``: the camera's pedestal, which
  the data hold) and ``WhiteLevel`` 2^bits - 1;
* ``ColorMatrix1`` (XYZ -> camera) fitted by least squares from the camera's
  sensitivities over the 24 Macbeth reflectances under D65
  (``CalibrationIlluminant1`` = D65), normalized as the specification asks
  (D65's white, Y = 1, gives a largest camera channel of 1), and
  ``AsShotNeutral`` the camera's response to that white;
* ``ImageDescription``: camsim's JSON metadata of the image (sensitivities,
  tile, exposure...), so that :func:`load_raw` of a camsim DNG gets them back;
* an EXIF IFD (``ExifTag`` 34665 in IFD 0, as cameras write it; EXIF 2.3)
  with the tags raw tools show: ``ExposureTime`` (s) and ``FNumber`` as
  rationals, ``ISOSpeedRatings`` = 100 x the analog gain (ISO 100 at unit
  gain, the base sensitivity a camera quotes) and ``ExifVersion`` 0230.
  tifffile writes no EXIF IFD (it refuses an ``ExifTag`` among the extra
  tags), so the IFD is appended to tifffile's file by hand (TIFF 6.0
  section 2 layout), and a placeholder tag that tifffile writes in IFD 0 at
  the place ``ExifTag`` sorts to is renamed ``ExifTag`` and pointed at it.
  dcraw and LibRaw read ISO only from the EXIF IFD; exiftool validates
  the file without a warning.

Written with tifffile (there is no maintained Python DNG writer on PyPI);
validated by LibRaw itself (``tests/engine/test_dng.py``): rawpy opens the file,
reports the pattern and levels, and demosaics it.
"""

from __future__ import annotations

import io
import json
from fractions import Fraction
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, ParameterError
from .output import atomic_write

__all__ = ["write_dng", "load_raw", "color_matrix", "plane_order", "MAX_RAW_BYTES"]

#: Largest raw file :func:`load_raw` opens (LibRaw then applies its own allocation limits).
MAX_RAW_BYTES = 1 << 30
_LETTERS = {"R": 0, "G": 1, "B": 2, "C": 3, "M": 4, "Y": 5, "W": 6}
#: An unassigned tag written in ExifTag's place (the tag before 34665, so IFD 0 stays sorted when it is renamed).
_EXIF_PLACEHOLDER = 34664


def plane_order(sensitivities, wavelengths):
    """For 3 sensors: the DNG colour (0 R, 1 G, 2 B) of each, ranked by its mean wavelength (longest = R)."""
    s = np.abs(np.asarray(sensitivities, float))
    centroid = s @ np.asarray(wavelengths, float) / s.sum(axis=1)
    rank = np.argsort(np.argsort(-centroid, kind="stable"), kind="stable")
    return rank  # sensor i -> colour rank[i]


def color_matrix(sensitivities, wavelengths):
    """(3, 3) XYZ -> camera matrix (rows in R, G, B plane order), DNG-normalized; and the D65 white's camera values.

    Least squares over the Macbeth chart's 24 reflectances under CIE D65.
    """
    from ..datasets.illuminants import illuminant
    from ..datasets.sensors import cie1931_xyz
    from ..datasets.surfaces import macbeth
    from ..spectra import resample

    w = np.asarray(wavelengths, float)
    t = np.asarray(sensitivities, float)
    mw, refl, _ = macbeth()
    r = resample(mw, refl, w)
    r[:, w > mw[-1]] = refl[:, -1:]
    e = illuminant("D65").per_band(w)
    radiance = r * e
    cmf = cie1931_xyz().on(w)
    xyz = radiance @ cmf.T
    cam = radiance @ t.T
    m, *_ = np.linalg.lstsq(xyz, cam, rcond=None)  # cam ~ xyz @ m
    m = m.T[np.argsort(plane_order(t, w))]  # rows in R, G, B order
    white_xyz = cmf @ e
    white_xyz = white_xyz / white_xyz[1]
    white_cam = m @ white_xyz
    scale = white_cam.max()
    if not scale > 0:
        raise ParameterError("sensitivities", "give no response to D65: cannot build a DNG colour matrix")
    return m / scale, white_cam / scale


def _srational(values, denominator=10000):
    out = []
    for v in np.ravel(values):
        fr = Fraction(float(v)).limit_denominator(denominator)
        out += [fr.numerator, fr.denominator]
    return out


def _rational(value, what):
    """A positive number as an unsigned TIFF RATIONAL (numerator, denominator), the closest with 32-bit terms."""
    v = float(value)
    if not (np.isfinite(v) and 0 < v < 2**32 - 1):
        raise ParameterError(what, f"must be a positive number below 2^32 to be written to a DNG, got {value!r}")
    fr = Fraction(v).limit_denominator(min(2**32 - 1, int((2**32 - 1) / v)))
    if not 0 < fr.numerator <= 2**32 - 1:
        raise ParameterError(what, f"{v:g} cannot be written as a rational of 32-bit terms")
    return fr.numerator, fr.denominator


def _check_raw(image):
    if not getattr(image, "mosaiced", False) or image.tile is None:
        raise ParameterError("out", "a DNG holds a raw mosaic; write the image before demosaicing (no --demosaic/--render)")
    if image.tile.ndim != 2 or np.asarray(image.data).ndim != 2:
        raise ParameterError("out", "a DNG holds one mosaic plane; tiered (field-sequential) tiles cannot be written")
    if image.n_sensors != 3:
        raise ParameterError("out", f"a DNG CFA here holds 3 colours (R, G, B); the camera has {image.n_sensors} sensors")
    if image.tile.shape[0] > 8 or image.tile.shape[1] > 8:
        raise ParameterError("out", f"the tile is {image.tile.shape}; DNG readers expect a CFA repeat of at most 8 x 8")
    if not image.quantized or image.bits is None or image.bits > 16:
        raise ParameterError("out", "a DNG holds integers of up to 16 bits; simulate with --bits 1..16 (not --unquantized)")


def write_dng(image, path, *, model="camsim", analog_gain=1.0):
    """Write a simulated raw :class:`~camsim_core.image.CameraImage` as a CFA DNG (see the module docstring).

    Parameters
    ----------
    image : CameraImage
        A quantized (at most 16 bits), mosaiced image of a 3-colour tile.
    path : path-like
        The ``.dng`` file, written atomically.
    model : str
        The camera's name (``Model``, ``UniqueCameraModel``).
    analog_gain : float
        The camera's analog gain (``Camera.analog_gain``: 1 unless an
        electron-level sensor sets another), which the image does not
        carry; written as ``ISOSpeedRatings`` = 100 x ``analog_gain``
        (at most 65535).

    Returns
    -------
    Path

    Raises
    ------
    ParameterError
        For an image a DNG cannot hold (demosaiced, unquantized, over 16
        bits, more than 3 colours), or an exposure, f-number or gain that is
        not a positive number.

    Examples
    --------
    >>> import tempfile, camsim_core as cs
    >>> raw = cs.simulate(cs.load_scene("bfgb128"), cs.load_camera("kodak-dcs200-ir"), exposure=0.5)
    >>> with tempfile.TemporaryDirectory() as d:
    ...     write_dng(raw, f"{d}/x.dng").name
    'x.dng'
    """
    import tifffile

    path = Path(path)
    _check_raw(image)
    exposure = _rational(image.exposure, "exposure")
    f_number = _rational(image.f_stop, "f_stop")
    g = float(analog_gain)
    if not (np.isfinite(g) and g > 0):
        raise ParameterError("analog_gain", f"must be a positive number, got {analog_gain!r}")
    iso = int(min(65535, max(1, round(100.0 * g))))
    colours = plane_order(image.sensitivities, image.wavelengths)
    pattern = colours[np.asarray(image.tile)]
    matrix, neutral = color_matrix(image.sensitivities, image.wavelengths)
    white = 2**image.bits - 1
    black = float(image.black_level)
    data = np.clip(np.round(np.asarray(image.data, float)), 0, white).astype(np.uint16)
    meta = image.metadata()
    rows, cols = pattern.shape
    tags = [
        (33421, "H", 2, (rows, cols), True),  # CFARepeatPatternDim
        (33422, "B", rows * cols, tuple(int(v) for v in pattern.ravel()), True),  # CFAPattern
        (50706, "B", 4, (1, 4, 0, 0), True),  # DNGVersion
        (50707, "B", 4, (1, 1, 0, 0), True),  # DNGBackwardVersion
        (50708, "s", 0, f"camsim {model}", True),  # UniqueCameraModel
        (50710, "B", 3, (0, 1, 2), True),  # CFAPlaneColor
        (50711, "H", 1, (1,), True),  # CFALayout: rectangular
        (50713, "H", 2, (1, 1), True),  # BlackLevelRepeatDim
        (50714, "I", 1, (int(round(black)),), True),  # BlackLevel
        (50717, "I", 1, (white,), True),  # WhiteLevel
        (50721, "q", 9, tuple(_srational(matrix)), True),  # ColorMatrix1 (SRATIONAL)
        (50778, "H", 1, (21,), True),  # CalibrationIlluminant1: D65
        (50728, "Q", 3, tuple(_srational(neutral)), True),  # AsShotNeutral (RATIONAL)
        (271, "s", 0, "camsim", True),  # Make
        (272, "s", 0, model, True),  # Model
        (274, "H", 1, (1,), True),  # Orientation
        (_EXIF_PLACEHOLDER, "I", 1, (0,), True),  # becomes ExifTag (34665) in _with_exif_ifd
    ]
    codes = {"B": 1, "s": 2, "H": 3, "I": 4, "Q": 5, "q": 10}  # TIFF types; Q RATIONAL, q SRATIONAL
    tags = [(c, codes[d], n, v, w) for c, d, n, v, w in tags]

    def write(f):
        buf = io.BytesIO()
        tifffile.imwrite(buf, data, photometric=32803, subfiletype=0, software="camsim", byteorder="<", bigtiff=False,
                         description=json.dumps(meta), extratags=tags, metadata=None)
        f.write(_with_exif_ifd(buf.getvalue(), exposure, f_number, iso))

    atomic_write(path, write)
    return path


def _with_exif_ifd(tiff, exposure, f_number, iso):
    """A little-endian classic TIFF's bytes with an EXIF IFD appended, IFD 0's placeholder made ``ExifTag`` (34665).

    The IFD (TIFF 6.0, section 2): a 2-byte entry count, 12-byte entries in
    ascending tag order (tag, type, count, value or offset), a 4-byte zero
    (no next IFD), then the two RATIONAL values the entries point to.
    """
    import struct

    import tifffile

    with tifffile.TiffFile(io.BytesIO(tiff)) as tf:
        tag = tf.pages[0].tags[_EXIF_PLACEHOLDER]
        entry, pointer = tag.offset, tag.valueoffset
    start = len(tiff) + len(tiff) % 2  # IFDs begin on a word boundary
    entries = 4
    values = start + 2 + 12 * entries + 4
    ifd = struct.pack("<H", entries)
    ifd += struct.pack("<HHII", 33434, 5, 1, values)  # ExposureTime, RATIONAL
    ifd += struct.pack("<HHII", 33437, 5, 1, values + 8)  # FNumber, RATIONAL
    ifd += struct.pack("<HHIHH", 34855, 3, 1, iso, 0)  # ISOSpeedRatings, SHORT
    ifd += struct.pack("<HHI4s", 36864, 7, 4, b"0230")  # ExifVersion, UNDEFINED
    ifd += struct.pack("<I", 0) + struct.pack("<IIII", *exposure, *f_number)
    out = bytearray(tiff) + b"\0" * (start - len(tiff)) + ifd
    struct.pack_into("<H", out, entry, 34665)  # ExifTag, type LONG, count 1 as written
    struct.pack_into("<I", out, pointer, start)
    return bytes(out)


def _camsim_metadata(path):
    """camsim's JSON metadata from a DNG's ImageDescription, or None."""
    import tifffile

    try:
        with tifffile.TiffFile(path) as tf:
            desc = tf.pages[0].description
    except Exception:  # not a TIFF-based raw: no camsim metadata
        return None
    try:
        meta = json.loads(desc)
    except (TypeError, ValueError):
        return None
    return meta if isinstance(meta, dict) and "sensitivities" in meta and "tile" in meta else None


def load_raw(path):
    """Read a DNG or camera raw file (any LibRaw reads, through rawpy) as a mosaiced camera image.

    The CFA pattern becomes the tile (R, G, B = sensors 0, 1, 2; LibRaw's
    second green is green), the black level becomes the image's
    ``black_level`` (the data keep the pedestal; demosaic and render
    subtract it) and ``bits`` follows the white level. A DNG written by camsim brings back
    its sensitivities, exposure, f-stop, gain, distance and angular
    resolution from its metadata; another camera's raw has no sensitivities
    (demosaicing works, rendering needs them: see
    :func:`~camsim_core.io.raw.raw_from_array`).
    """
    import rawpy

    from .raw import raw_from_array

    from .files import check_regular

    path = Path(path)
    size = check_regular(path).st_size
    if size > MAX_RAW_BYTES:
        raise FileFormatError(path, f"{size} bytes is more than the {MAX_RAW_BYTES} a raw file may have")
    try:
        with rawpy.imread(str(path)) as raw:
            if raw.raw_pattern is None or raw.raw_type != rawpy.RawType.Flat:
                raise FileFormatError(path, "not a colour-filter-array raw (LibRaw found no CFA pattern)")
            desc = raw.color_desc.decode("ascii", "replace")
            pattern = np.asarray(raw.raw_pattern)
            mosaic = np.array(raw.raw_image_visible, dtype=np.float64)
            black = np.asarray(raw.black_level_per_channel, float)
            white = float(raw.white_level)
    except FileFormatError:
        raise
    except Exception as exc:  # rawpy.LibRawError and its subclasses, OSError
        raise FileFormatError(path, f"not a raw file LibRaw can read ({type(exc).__name__}: {exc})") from None
    letters = [desc[i] if i < len(desc) else "?" for i in range(4)]
    codes = sorted({_LETTERS.get(c, 7) for c in letters[: int(pattern.max()) + 1]})
    tile = np.vectorize(lambda i: codes.index(_LETTERS.get(letters[i], 7)))(pattern)
    # the pedestal stays in the data (processing subtracts it); per-colour levels that differ
    # are evened out to the smallest, which the image then carries
    used = black[np.unique(pattern)]
    data = mosaic
    if np.ptp(used) > 0:
        reps = (mosaic.shape[0] // pattern.shape[0] + 1, mosaic.shape[1] // pattern.shape[1] + 1)
        excess = (black - used.min())[np.tile(pattern, reps)[: mosaic.shape[0], : mosaic.shape[1]]]
        data = np.clip(mosaic - excess, 0.0, None)
    bits = int(np.ceil(np.log2(white + 1))) if white > 0 else None
    meta = _camsim_metadata(path)
    fields = dict(name=path.stem)
    sens = wls = None
    names = None
    if meta is not None:
        wls = np.asarray(meta["wavelengths"], float)
        sens = np.asarray(meta["sensitivities"], float)
        names = tuple(meta.get("sensor_names") or ()) or None
        tile = np.asarray(meta["tile"], int)
        for key, field in (("exposure_s", "exposure"), ("f_stop", "f_stop"), ("distance_m", "distance"),
                           ("gain", "gain"), ("noise_sigma", "noise_sigma")):
            if meta.get(key) is not None:
                fields[field] = float(meta[key])
        if meta.get("angular_resolution_px_per_deg"):
            fields["angular_resolution"] = tuple(meta["angular_resolution_px_per_deg"])
        bits = meta.get("bits") or bits
    out = raw_from_array(data.astype(np.uint16) if bits and bits <= 16 else data, tile, sensitivities=sens,
                         wavelengths=wls, sensor_names=names, bits=bits, black_level=float(used.min()), **fields)
    extra = dict(out.extra, white_level=white, source=str(path))
    return out.replace(extra=extra)
