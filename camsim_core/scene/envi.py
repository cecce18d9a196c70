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

from pathlib import Path

import numpy as np

from ..errors import FileFormatError
from ..io.files import MAX_TEXT_BYTES, check_regular
from ._intake import check_scene_size, finish_scene, per_nm_to_per_band, photons_to_radiance

__all__ = ["read_envi", "write_envi"]

# ENVI "data type" codes -> numpy dtypes (ENVI header format documentation)
_DTYPES = {1: "u1", 2: "i2", 3: "i4", 4: "f4", 5: "f8", 12: "u2", 13: "u4", 14: "i8", 15: "u8"}
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


def _header(path):
    from spectral.io import envi

    try:
        return envi.read_envi_header(str(path))
    except envi.FileNotAnEnviHeader as exc:
        raise FileFormatError(path, f"not an ENVI header ({exc}); expected a text file starting with 'ENVI'") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(path, f"cannot read as an ENVI header: {exc}") from None
    except Exception as exc:  # spectral raises plain Exceptions on malformed headers
        raise FileFormatError(path, f"malformed ENVI header: {exc}") from None


def _int_field(path, h, key):
    if key not in h:
        raise FileFormatError(path, f"required header field {key!r} is missing")
    try:
        return int(h[key])
    except (TypeError, ValueError):
        raise FileFormatError(path, f"header field {key!r} must be a whole number, got {h[key]!r}") from None


def _floats(path, h, key):
    try:
        return np.asarray([float(v) for v in np.atleast_1d(h[key])], float)
    except (TypeError, ValueError):
        raise FileFormatError(path, f"header field {key!r} must hold numbers, got {h[key]!r}") from None


def _geometry(path, h):
    distance = float(_floats(path, h, "distance")[0]) if "distance" in h else None
    ar = None
    if "angular resolution" in h:
        v = _floats(path, h, "angular resolution")
        ar = (float(v[0]), float(v[-1]))
    elif "fov" in h:
        fov = float(_floats(path, h, "fov")[0])
        if not fov > 0:
            raise FileFormatError(path, f"header field 'fov' must be a positive number of degrees, got {fov}")
        ar = (_int_field(path, h, "samples") / fov,) * 2
    return distance, ar


def read_envi(path, *, negative="error", max_values=None):
    """Read an ENVI image as a :class:`~camsim_core.scene.Scene` (see the module docstring).

    ``max_values`` tightens the size bound (lines x samples x bands).
    """
    from spectral.io import envi

    path = Path(path)
    st = check_regular(path)
    if st.st_size > MAX_TEXT_BYTES:
        raise FileFormatError(path, f"is {st.st_size} bytes: too large for an ENVI header")
    h = _header(path)
    lines, samples, bands = (_int_field(path, h, k) for k in ("lines", "samples", "bands"))
    check_scene_size(path, (lines, samples, bands), max_values=max_values)
    code = _int_field(path, h, "data type")
    if code not in _DTYPES:
        raise FileFormatError(path, f"ENVI data type {code} is not supported (expected one of {sorted(_DTYPES)})")
    if "wavelength" not in h:
        raise FileFormatError(path, "required header field 'wavelength' (one centre wavelength per band) is missing")
    wls = _floats(path, h, "wavelength")
    if wls.size != bands:
        raise FileFormatError(path, f"'wavelength' lists {wls.size} values for {bands} bands")
    notices = []
    wunit = str(h.get("wavelength units", "")).strip().lower()
    if not wunit and wls.max() < 100:
        wunit = "micrometers"
        notices.append("no 'wavelength units' and wavelengths below 100: taken as micrometers")
    if wunit in ("micrometers", "micrometer", "um", "microns"):
        wls = wls * 1000.0
    elif wunit not in ("", "nanometers", "nanometer", "nm", "unknown"):
        raise FileFormatError(path, f"'wavelength units' {h['wavelength units']!r} not understood (nanometers or micrometers)")
    try:
        img = envi.open(str(path))
    except Exception as exc:  # missing data file, unknown interleave, ...
        raise FileFormatError(path, f"cannot open the ENVI data file: {exc}") from None
    data_path = Path(img.filename)
    check_regular(data_path)
    need = int(h.get("header offset", 0) or 0) + lines * samples * bands * np.dtype(_DTYPES[code]).itemsize
    have = data_path.stat().st_size
    if have < need:
        raise FileFormatError(data_path, f"data file is {have} bytes, the header promises {need}: truncated or wrong header")
    cube = np.array(img.open_memmap(interleave="bip"), dtype=float)  # load() would give float32
    units = str(h.get("data units", "")).strip()
    kind, factor = _UNITS.get(units.lower(), (None, 1.0))
    if kind == "per nm":
        cube = per_nm_to_per_band(cube * factor, wls)
    elif kind == "photons":
        cube = photons_to_radiance(cube, wls)
    elif kind is None:
        notices.append(
            f"data units {units!r} not understood: values taken as W/sr/m^2 per band" if units
            else "no 'data units' in the header: values taken as W/sr/m^2 per band"
        )
    distance, ar = _geometry(path, h)
    return finish_scene(path, cube, wls, distance=distance, angular_resolution=ar, name=path.stem,
                        comments=str(h.get("description", "")).strip(), notices=notices, negative=negative)


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
