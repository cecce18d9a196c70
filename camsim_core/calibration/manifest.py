"""A raw hyperspectral capture: the folder of monochromatic planes and its JSON manifest.

The folder holds one image per interference filter, the dark frames (camera
shutter closed) for each exposure time used, and ``manifest.json``::

    {
      "format": "tiff",                # "tiff", "png" or "raw-be16"; default: from the file names
      "height": 182, "width": 290,      # required for "raw-be16" (SimToolbox's plane files)
      "reference_wavelength": 550,      # plane the others are registered to (default 550 nm)
      "distance": 2.375,                # m, camera to scene (optional, default 1)
      "angular_resolution": [55.9, 55.9],  # px/deg of the hyperspectral camera (optional)
      "name": "my scene",               # optional
      "planes": [{"wavelength": 400, "file": "400.tif", "exposure": 2.0, "f_stop": 4}, ...],
      "darks":  [{"exposure": 2.0, "file": "dark_2s.tif"}, ...],
      "regions": "regions.json",        # optional: default for ``--mcc``
      "reference": "reference.csv"      # optional: default for ``--reference``
    }

Exposure times are in seconds. Plane and dark files are 16-bit TIFF or PNG
(one channel) or raw big-endian unsigned 16-bit integers, row by row
(``raw-be16``, the plane files of ``assets/simtoolbox``). Several dark
frames of one exposure time are averaged.

Checks (each a :class:`~camsim_core.errors.FileFormatError` naming the file
and the field): the manifest's fields; every listed file exists; the
wavelengths are evenly spaced with none missing, and every image file in the
folder is listed (a plane missing from the manifest); every exposure time
has a dark frame; all frames have the same size.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FileFormatError

__all__ = ["Plane", "Manifest", "read_manifest", "read_frame", "load_frames", "MANIFEST_NAME", "FORMATS"]

MANIFEST_NAME = "manifest.json"
FORMATS = ("tiff", "png", "raw-be16")
_SUFFIX_FORMAT = {".tif": "tiff", ".tiff": "tiff", ".png": "png"}


@dataclass(frozen=True)
class Plane:
    """One monochromatic image: wavelength (nm), exposure (s), f-stop, and its file."""

    wavelength: float
    exposure: float
    f_stop: float
    file: Path


@dataclass(frozen=True)
class Manifest:
    """A parsed, checked ``manifest.json`` (planes sorted by wavelength)."""

    folder: Path
    planes: tuple
    darks: dict  # exposure (s) -> tuple of dark-frame paths
    format: str
    height: int | None = None
    width: int | None = None
    reference_wavelength: float = 550.0
    distance: float = 1.0
    angular_resolution: tuple = (57.3, 57.3)
    name: str = ""
    regions: Path | None = None
    reference: Path | None = None
    extra: dict = field(default_factory=dict)

    @property
    def wavelengths(self):
        return np.array([p.wavelength for p in self.planes], float)


def _number(path, where, value, positive=True):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise FileFormatError(path, f"{where} must be a number, got {value!r}") from None
    if not np.isfinite(x) or (positive and x <= 0):
        raise FileFormatError(path, f"{where} must be a positive number, got {value!r}")
    return x


def _entry_file(path, folder, where, entry):
    name = entry.get("file")
    if not isinstance(name, str) or not name:
        raise FileFormatError(path, f"{where} needs a 'file' (a file name in {folder})")
    f = folder / name
    if not f.is_file():
        raise FileFormatError(f, f"listed by {where} in {path.name} but not found")
    return f


def _same_exposure(a, b):
    return abs(a - b) <= 1e-6 * max(abs(a), abs(b))


def _check_sampling(path, wls):
    if wls.size < 2:
        return
    d = np.diff(wls)
    if np.any(d <= 0):
        dup = wls[1:][d <= 0][0]
        raise FileFormatError(path, f"two planes have the wavelength {dup:g} nm")
    step = float(d.min())
    ratio = d / step
    if np.any(np.abs(ratio - np.round(ratio)) > 1e-3):
        raise FileFormatError(path, f"plane wavelengths must be evenly spaced, got steps {sorted(set(np.round(d, 3)))} nm")
    if np.any(np.round(ratio) > 1):
        full = wls[0] + step * np.arange(int(round((wls[-1] - wls[0]) / step)) + 1)
        missing = [w for w in full if np.min(np.abs(wls - w)) > 1e-3 * step]
        raise FileFormatError(path, "no plane for " + ", ".join(f"{w:g}" for w in missing) + f" nm: a plane is missing from the manifest (planes every {step:g} nm from {wls[0]:g} to {wls[-1]:g})")


def _unlisted_images(folder, listed, fmt):
    out = []
    for f in sorted(folder.iterdir()):
        if not f.is_file() or f.resolve() in listed or f.name.startswith("."):
            continue
        suffix = f.suffix.lower()
        if suffix in _SUFFIX_FORMAT or (fmt == "raw-be16" and suffix == "" and f.name.replace(".", "", 1).isdigit()):
            out.append(f)
    return out


def read_manifest(raw_dir):
    """Read and check ``RAW_DIR/manifest.json``; returns a :class:`Manifest`."""
    folder = Path(raw_dir)
    if not folder.is_dir():
        raise FileFormatError(folder, "raw capture folder not found")
    path = folder / MANIFEST_NAME
    try:
        spec = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise FileFormatError(path, f"not UTF-8 text (byte {exc.start}); save the manifest as UTF-8 JSON") from None
    except OSError:
        raise FileFormatError(path, f"no {MANIFEST_NAME} in the raw capture folder (it lists each plane's wavelength, exposure, f-stop and file, and the dark frames)") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(path, f"not valid JSON: {exc}") from None
    if not isinstance(spec, dict):
        raise FileFormatError(path, "must hold a JSON object")
    planes_in = spec.get("planes")
    if not isinstance(planes_in, list) or not planes_in:
        raise FileFormatError(path, "'planes' must be a non-empty list of {wavelength, exposure, f_stop, file}")
    planes = []
    for i, e in enumerate(planes_in):
        where = f"planes[{i}]"
        if not isinstance(e, dict):
            raise FileFormatError(path, f"{where} must be an object")
        for key in ("wavelength", "exposure", "f_stop"):
            if key not in e:
                raise FileFormatError(path, f"{where} lacks '{key}'")
        planes.append(
            Plane(
                _number(path, f"{where}.wavelength", e["wavelength"]),
                _number(path, f"{where}.exposure", e["exposure"]),
                _number(path, f"{where}.f_stop", e["f_stop"]),
                _entry_file(path, folder, where, e),
            )
        )
    planes.sort(key=lambda p: p.wavelength)
    wls = np.array([p.wavelength for p in planes])

    darks_in = spec.get("darks")
    if not isinstance(darks_in, list):
        raise FileFormatError(path, "'darks' must be a list of {exposure, file} (one dark frame per exposure time)")
    darks = {}
    for i, e in enumerate(darks_in):
        where = f"darks[{i}]"
        if not isinstance(e, dict) or "exposure" not in e:
            raise FileFormatError(path, f"{where} must be an object with 'exposure' and 'file'")
        t = _number(path, f"{where}.exposure", e["exposure"])
        f = _entry_file(path, folder, where, e)
        key = next((k for k in darks if _same_exposure(k, t)), t)
        darks[key] = darks.get(key, ()) + (f,)
    dark_check = []
    for p in planes:
        if not any(_same_exposure(k, p.exposure) for k in darks):
            have = ", ".join(f"{k:g}" for k in sorted(darks)) or "none"
            dark_check.append(f"the {p.wavelength:g} nm plane ({p.file.name}) was exposed {p.exposure:g} s but there is no dark frame for {p.exposure:g} s (dark frames for: {have} s)")

    fmt = spec.get("format")
    if fmt is None:
        kinds = {_SUFFIX_FORMAT.get(p.file.suffix.lower(), "raw-be16") for p in planes}
        if len(kinds) != 1:
            raise FileFormatError(path, f"planes mix file types ({', '.join(sorted(kinds))}); give 'format'")
        fmt = kinds.pop()
    if fmt not in FORMATS:
        raise FileFormatError(path, f"'format' must be one of {', '.join(FORMATS)}, got {fmt!r}")
    height = width = None
    if fmt == "raw-be16" or "height" in spec or "width" in spec:
        if "height" not in spec or "width" not in spec:
            raise FileFormatError(path, "'height' and 'width' (pixels) are required for raw-be16 planes")
        height = int(_number(path, "height", spec["height"]))
        width = int(_number(path, "width", spec["width"]))

    listed = {p.file.resolve() for p in planes} | {f.resolve() for fs in darks.values() for f in fs}
    for key in ("regions", "reference"):
        if isinstance(spec.get(key), str):
            listed.add((folder / spec[key]).resolve())
    stray = _unlisted_images(folder, listed, fmt)
    if stray:
        raise FileFormatError(stray[0], f"image file not listed in {MANIFEST_NAME}: a plane missing from the manifest? (list it under 'planes' or 'darks', or move it out of the folder)")
    _check_sampling(path, wls)
    if dark_check:
        raise FileFormatError(path, dark_check[0])

    ref_wl = _number(path, "reference_wavelength", spec.get("reference_wavelength", 550.0))
    if np.min(np.abs(wls - ref_wl)) > 1e-6:
        raise FileFormatError(path, f"no plane at the reference wavelength {ref_wl:g} nm (planes {wls[0]:g}-{wls[-1]:g} nm); the planes are registered to it")
    distance = _number(path, "distance", spec.get("distance", 1.0))
    ar = spec.get("angular_resolution", [57.3, 57.3])
    ar = [ar, ar] if not isinstance(ar, list) else ar
    if len(ar) != 2:
        raise FileFormatError(path, f"'angular_resolution' must be [x, y] pixels per degree, got {ar!r}")
    ar = tuple(_number(path, "angular_resolution", v) for v in ar)

    def optional_path(key):
        v = spec.get(key)
        if v is None:
            return None
        if not isinstance(v, str):
            raise FileFormatError(path, f"'{key}' must be a file name")
        return folder / v

    return Manifest(
        folder=folder,
        planes=tuple(planes),
        darks=darks,
        format=fmt,
        height=height,
        width=width,
        reference_wavelength=ref_wl,
        distance=distance,
        angular_resolution=ar,
        name=str(spec.get("name", folder.name)),
        regions=optional_path("regions"),
        reference=optional_path("reference"),
    )


def read_frame(path, fmt, height=None, width=None):
    """One frame as a float (H, W) array of raw counts."""
    path = Path(path)
    if fmt == "raw-be16":
        raw = path.read_bytes()
        if len(raw) != 2 * height * width:
            raise FileFormatError(path, f"is {len(raw)} bytes, expected {2 * height * width} ({height} x {width} 16-bit values): planes of different sizes?")
        return np.frombuffer(raw, dtype=">u2").reshape(height, width).astype(float)
    try:
        if fmt == "tiff":
            import tifffile

            a = tifffile.imread(path)
        else:
            from PIL import Image

            with Image.open(path) as im:
                a = np.array(im)
    except Exception as exc:  # unreadable or not the declared format
        raise FileFormatError(path, f"cannot read as {fmt}: {exc}") from None
    a = np.squeeze(a)
    if a.ndim != 2:
        raise FileFormatError(path, f"expected one monochrome plane, got an array of shape {a.shape}")
    if not np.issubdtype(a.dtype, np.number):
        raise FileFormatError(path, f"expected integer pixel values, got {a.dtype}")
    return a.astype(float)


def load_frames(manifest):
    """(planes (N, H, W), darks {exposure: (H, W) mean dark frame}) of a manifest, all of one size."""
    m = manifest
    shape = None if m.height is None else (m.height, m.width)
    first = None

    def get(f):
        nonlocal shape, first
        a = read_frame(f, m.format, *(shape or (None, None))) if m.format == "raw-be16" else read_frame(f, m.format)
        if shape is None:
            shape, first = a.shape, f
        elif a.shape != shape:
            ref = f"{first.name}" if first is not None else "the manifest's height x width"
            raise FileFormatError(f, f"frame is {a.shape[0]} x {a.shape[1]} pixels but {ref} is {shape[0]} x {shape[1]}: all planes and dark frames must have the same size")
        return a

    planes = np.stack([get(p.file) for p in m.planes])
    darks = {t: np.mean([get(f) for f in files], axis=0) for t, files in m.darks.items()}
    return planes, darks
