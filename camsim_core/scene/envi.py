"""ENVI hyperspectral images (``.hdr`` header plus a raw data file), as Specim and HySpex cameras write them.

Read through the ``spectral`` package (Spectral Python), which knows the
header syntax, the interleaves (BSQ, BIL, BIP) and the byte orders. The
header's ``lines`` x ``samples`` x ``bands`` and data type are checked
against :data:`~camsim_core.scene._intake.MAX_SCENE_VALUES` and against the
data file's length before any pixel is read.

Fields used:

* ``wavelength`` (required) with ``wavelength units`` (nanometers, the
  default, or micrometers; without units, values below 100 are taken as
  micrometers, with a notice);
* ``data units`` (optional): ``W/(m^2 sr nm)``, ``uW/(cm^2 sr nm)`` or
  ``photons/(s sr m^2 nm)`` are converted to W/sr/m^2 per band; without it
  the values are taken as W/sr/m^2 per band, with a notice;
* ``distance`` (m) and ``angular resolution`` (x, y px/deg) or ``fov`` (horizontal
  field of view, degrees): camsim's own optional keys (ENVI has no geometry
  fields); missing ones get the documented defaults with a notice.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from ..errors import FileFormatError
from ..io.files import MAX_TEXT_BYTES, check_regular
from ._intake import check_scene_size, finish_scene, per_nm_to_per_band, photons_to_radiance
from .scene import WAVELENGTH_RANGE

__all__ = ["read_envi", "write_envi", "wavelength_list"]

# ENVI "data type" codes -> numpy dtypes (ENVI header format documentation)
_DTYPES = {1: "u1", 2: "i2", 3: "i4", 4: "f4", 5: "f8", 12: "u2", 13: "u4", 14: "i8", 15: "u8"}
_INTERLEAVES = ("bsq", "bil", "bip")
_UNITS = {
    "w/(m^2 sr nm)": ("per nm", 1.0),
    "w/(m2 sr nm)": ("per nm", 1.0),
    "w/m^2/sr/nm": ("per nm", 1.0),
    "uw/(cm^2 sr nm)": ("per nm", 1e-2),
    "uw/(cm2 sr nm)": ("per nm", 1e-2),
    "uw/cm^2/sr/nm": ("per nm", 1e-2),
    "photons/(s sr m^2 nm)": ("photons", 1.0),
    "w/sr/m^2 per band": ("per band", 1.0),
}


def _short(value, limit=60):
    """``repr(value)`` cut to ``limit`` characters (a field may hold megabytes)."""
    try:
        text = repr(value)
    except ValueError:  # an integer of more digits than Python prints
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def wavelength_list(shown, field, values):
    """``values`` as a float array of wavelengths (nm), refused unless a valid sampling.

    A 1-D list of at least one finite number, every one within
    :data:`~camsim_core.scene.scene.WAVELENGTH_RANGE` (nm), strictly
    increasing. Raises :class:`~camsim_core.errors.FileFormatError` naming
    ``shown`` and ``field`` otherwise.
    """
    try:
        w = np.asarray(values, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise FileFormatError(shown, f"{field} must be a list of numbers (nm), got {_short(values)}") from None
    if w.ndim != 1 or w.size == 0:
        raise FileFormatError(shown, f"{field} must be a list of at least one wavelength (nm), got shape {w.shape}")
    if not np.all(np.isfinite(w)):
        raise FileFormatError(shown, f"{field} holds {np.count_nonzero(~np.isfinite(w))} NaN or infinite values; "
                                     "expected finite wavelengths (nm)")
    low, high = WAVELENGTH_RANGE
    if w.min() < low or w.max() > high:
        raise FileFormatError(shown, f"{field} spans {w.min():g}..{w.max():g} nm; expected wavelengths from "
                                     f"{low:g} to {high:g} nm")
    if np.any(np.diff(w) <= 0):
        i = int(np.argmax(np.diff(w) <= 0))
        raise FileFormatError(shown, f"{field} must be strictly increasing, but {w[i + 1]:g} nm follows {w[i]:g} nm")
    return w


def _scrub(exc, path, shown):
    """``exc``'s message with the header's folder replaced by ``shown`` (no server path in a message)."""
    text = str(exc) or type(exc).__name__
    folder = os.fspath(Path(path).parent)
    for p in sorted({os.fspath(path), os.fspath(Path(path).resolve()), folder}, key=len, reverse=True):
        if p not in ("", "."):
            text = text.replace(p, str(shown))
    return text


#: spectral's warning that it lower-cased a header key: ENVI's keys are case-insensitive, nothing to tell the user.
_LOWERCASE_WARNING = "Parameters with non-lowercase names"


def _header(path, shown):
    from spectral.io import envi

    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=_LOWERCASE_WARNING, category=UserWarning)
            return envi.read_envi_header(str(path))
    except envi.FileNotAnEnviHeader as exc:
        raise FileFormatError(shown, f"not an ENVI header ({_scrub(exc, path, shown)}); "
                                     "expected a text file starting with 'ENVI'") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(shown, f"cannot read as an ENVI header: {_scrub(exc, path, shown)}") from None
    except Exception as exc:  # spectral raises plain Exceptions on malformed headers
        raise FileFormatError(shown, f"malformed ENVI header: {_scrub(exc, path, shown)}") from None


def _int_field(shown, h, key, default=None):
    if key not in h:
        if default is not None:
            return default
        raise FileFormatError(shown, f"required header field {key!r} is missing")
    try:
        return int(h[key])
    except (TypeError, ValueError):
        raise FileFormatError(shown, f"header field {key!r} must be a whole number, got {_short(h[key])}") from None


def _floats(shown, h, key):
    try:
        return np.asarray([float(v) for v in np.atleast_1d(h[key])], float)
    except (TypeError, ValueError):
        raise FileFormatError(shown, f"header field {key!r} must hold numbers, got {_short(h[key])}") from None


def _positive(shown, h, key, sizes=(1,), below=np.inf):
    """The numbers of field ``key``: as many as one of ``sizes``, each finite, positive and below ``below``."""
    v = _floats(shown, h, key)
    if v.size not in sizes:
        raise FileFormatError(shown, f"header field {key!r} must hold {' or '.join(map(str, sizes))} number(s), "
                                     f"got {_short(h[key])}")
    if not np.all(np.isfinite(v) & (v > 0) & (v < below)):
        bound = "" if below == np.inf else f" below {below:g}"
        raise FileFormatError(shown, f"header field {key!r} must hold finite positive numbers{bound}, got {_short(h[key])}")
    return v


def _geometry(shown, h, samples):
    distance = float(_positive(shown, h, "distance")[0]) if "distance" in h else None
    ar = None
    if "angular resolution" in h:
        v = _positive(shown, h, "angular resolution", sizes=(1, 2))
        ar = (float(v[0]), float(v[-1]))
    elif "fov" in h:
        fov = float(_positive(shown, h, "fov", below=360.0)[0])
        ar = (samples / fov,) * 2
    return distance, ar


def read_envi(path, *, negative="error", max_values=None, shown=None):
    """Read an ENVI image as a :class:`~camsim_core.scene.Scene` (see the module docstring).

    Every header field used is checked (whole sizes, a known data type,
    interleave and byte order, an offset within the data file, finite
    wavelengths in a plausible range and strictly increasing, positive
    geometry) before the data file is mapped; ``max_values`` tightens the
    size bound (lines x samples x bands). Errors name ``shown`` (default:
    the header's file name), never the folder it was read from.
    """
    from spectral.io import envi

    path = Path(path)
    shown = path.name if shown is None else str(shown)
    st = check_regular(path, shown)
    if st.st_size > MAX_TEXT_BYTES:
        raise FileFormatError(shown, f"is {st.st_size} bytes: too large for an ENVI header")
    h = _header(path, shown)
    lines, samples, bands = (_int_field(shown, h, k) for k in ("lines", "samples", "bands"))
    check_scene_size(shown, (lines, samples, bands), max_values=max_values)
    code = _int_field(shown, h, "data type")
    if code not in _DTYPES:
        raise FileFormatError(shown, f"ENVI data type {code} is not supported (expected one of {sorted(_DTYPES)})")
    interleave = str(h.get("interleave", "")).strip().lower()
    if interleave not in _INTERLEAVES:
        raise FileFormatError(shown, f"header field 'interleave' must be one of {', '.join(_INTERLEAVES)}, "
                                     f"got {_short(h.get('interleave'))}")
    order = _int_field(shown, h, "byte order")
    if order not in (0, 1):
        raise FileFormatError(shown, f"header field 'byte order' must be 0 (little-endian) or 1 (big-endian), got {order}")
    offset = _int_field(shown, h, "header offset", default=0)
    if offset < 0:
        raise FileFormatError(shown, f"header field 'header offset' must be >= 0 bytes, got {offset}")
    if "wavelength" not in h:
        raise FileFormatError(shown, "required header field 'wavelength' (one centre wavelength per band) is missing")
    wls = _floats(shown, h, "wavelength")
    if wls.size != bands:
        raise FileFormatError(shown, f"'wavelength' lists {wls.size} values for {bands} bands")
    if not np.all(np.isfinite(wls)):
        raise FileFormatError(shown, "'wavelength' holds NaN or infinite values; expected finite wavelengths")
    notices = []
    wunit = str(h.get("wavelength units", "")).strip().lower()
    if not wunit and wls.max() < 100:
        wunit = "micrometers"
        notices.append("no 'wavelength units' and wavelengths below 100: taken as micrometers")
    if wunit in ("micrometers", "micrometer", "um", "microns"):
        wls = wls * 1000.0
    elif wunit not in ("", "nanometers", "nanometer", "nm", "unknown"):
        raise FileFormatError(shown, f"'wavelength units' {_short(h['wavelength units'])} not understood "
                                     "(nanometers or micrometers)")
    wls = wavelength_list(shown, "'wavelength'", wls)
    distance, ar = _geometry(shown, h, samples)
    try:
        with warnings.catch_warnings():  # envi.open reads the header again
            warnings.filterwarnings("ignore", message=_LOWERCASE_WARNING, category=UserWarning)
            img = envi.open(str(path))
    except Exception as exc:  # spectral raises plain Exceptions: a missing data file, a bad scale factor, ...
        raise FileFormatError(shown, f"cannot open the ENVI data file: {_scrub(exc, path, shown)}") from None
    data_path = Path(img.filename)
    data_shown = f"{shown}: data file {data_path.name}"
    check_regular(data_path, data_shown)
    need = offset + lines * samples * bands * np.dtype(_DTYPES[code]).itemsize
    have = data_path.stat().st_size
    if have < need:
        raise FileFormatError(data_shown, f"is {have} bytes, the header promises {need}: truncated or wrong header")
    try:
        with np.errstate(invalid="ignore"):  # a signalling NaN cast to float64: refused with the others below
            cube = np.array(img.open_memmap(interleave="bip"), dtype=float)  # load() would give float32
    except (OSError, ValueError) as exc:  # spectral gives a ValueError when numpy cannot map the file
        raise FileFormatError(data_shown, f"cannot be mapped as {lines} x {samples} x {bands} values "
                                          f"({_scrub(exc, path, shown)})") from None
    if cube.shape != (lines, samples, bands):
        raise FileFormatError(data_shown, f"mapped to shape {cube.shape}, the header says {(lines, samples, bands)}")
    units = str(h.get("data units", "")).strip()
    kind, factor = _UNITS.get(units.lower(), (None, 1.0))
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow becomes inf, refused by finish_scene
        if kind == "per nm":
            cube = per_nm_to_per_band(cube * factor, wls)
        elif kind == "photons":
            cube = photons_to_radiance(cube, wls)
    if kind is None:
        notices.append(
            f"data units {_short(units)} not understood: values taken as W/sr/m^2 per band" if units
            else "no 'data units' in the header: values taken as W/sr/m^2 per band"
        )
    return finish_scene(shown, cube, wls, distance=distance, angular_resolution=ar, name=path.stem,
                        comments=str(h.get("description", "")).strip()[:10_000], notices=notices, negative=negative)


def write_envi(scene, path):
    """Write a scene as an ENVI ``.hdr`` + ``.img`` (float64, BSQ) that :func:`read_envi` reads back exactly.

    ``data units`` is W/sr/m^2 per band; distance and angular resolution go
    in camsim's own header keys.
    """
    from spectral.io import envi

    meta = {
        "wavelength": [f"{w:g}" for w in scene.wavelengths],
        "wavelength units": "nanometers",
        "data units": "W/sr/m^2 per band",
        "distance": f"{scene.distance:.17g}",
        "angular resolution": [f"{v:.17g}" for v in scene.angular_resolution],
        "description": scene.comments or scene.name,
    }
    envi.save_image(str(path), np.asarray(scene.data, float), dtype=np.float64, interleave="bsq", ext=".img",
                    force=True, metadata=meta)
    return Path(path)
