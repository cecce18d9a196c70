"""A folder of one PNG per band (the CAVE multispectral database's layout).

Wavelengths come from a small JSON file in the folder (``scene.json``,
``wavelengths.json``, or the folder's only ``.json``; ``bands`` or ``wave``
also name the wavelengths)::

    {"wavelengths": [400, 410, ...], "files": ["a.png", ...],      # files optional
     "distance": 1.5, "angular_resolution": [60, 60], "scale": 0.01}  # all optional

or, without one, from CAVE's naming: ``NAME_01.png`` ... ``NAME_31.png`` are
400, 410, ... 700 nm. A CAVE download unpacks to ``NAME_ms/NAME_ms/*.png``:
a folder holding no PNG but one sub-folder is entered.

Values are divided by the PNG's full scale (65535 for 16-bit, 255 for 8-bit)
and multiplied by ``scale`` (default 1) to give W/sr/m^2 per band; without a
``scale`` the unit is unknown and a notice says so. CAVE's images are
reflectance-like: pass ``illuminant`` to :func:`read_band_folder` to light
them with an illuminant (white at ``luminance`` cd/m^2) instead.

Each PNG's size is read from its header (Pillow opens lazily) and the total
checked against :data:`~camsim_core.scene._intake.MAX_SCENE_VALUES` before
any band is decoded.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from ..errors import FileFormatError
from ..io.files import check_regular, read_regular
from ._intake import check_scene_size, finish_scene

__all__ = ["read_band_folder", "write_band_folder", "CAVE_WAVELENGTHS"]

#: CAVE's sampling: 400:10:700 nm, bands numbered 01..31.
CAVE_WAVELENGTHS = 400.0 + 10.0 * np.arange(31)
_JSON_NAMES = ("scene.json", "wavelengths.json")
_CAVE_NUMBER = re.compile(r"_(\d{2})\.png$", re.IGNORECASE)


def _natural(path):
    """Sort key that puts band2.png before band10.png."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def _folder(path):
    pngs = sorted((p for p in path.iterdir() if p.suffix.lower() == ".png"), key=_natural)
    if pngs:
        return path, pngs
    subs = [p for p in path.iterdir() if p.is_dir()]
    if len(subs) == 1:
        return _folder(subs[0])
    raise FileFormatError(path, "folder holds no band PNGs (expected one PNG per band, CAVE's layout)")


def _layout(folder, pngs):
    """(files, wavelengths, options) from the JSON file or CAVE's numbering."""
    candidates = [folder / n for n in _JSON_NAMES if (folder / n).is_file()]
    others = sorted(p for p in folder.glob("*.json") if p.name not in _JSON_NAMES)
    if not candidates and len(others) == 1:
        candidates = others  # one JSON file of any name
    for jp in candidates:
        if True:
            try:
                meta = json.loads(read_regular(jp, max_bytes=1 << 20))
            except (ValueError, UnicodeDecodeError) as exc:
                raise FileFormatError(jp, f"not valid JSON ({exc})") from None
            if isinstance(meta, list):
                meta = {"wavelengths": meta}
            if isinstance(meta, dict) and "wavelengths" not in meta:
                for alias in ("bands", "wavelength", "wave"):
                    if alias in meta:
                        meta["wavelengths"] = meta[alias]
                        break
            if not isinstance(meta, dict) or "wavelengths" not in meta:
                raise FileFormatError(jp, "expected an object with 'wavelengths' (one per band, nm)")
            try:
                wls = np.asarray(meta["wavelengths"], float).ravel()
            except (TypeError, ValueError):
                raise FileFormatError(jp, "'wavelengths' must be a list of numbers (nm)") from None
            if "files" in meta:
                files = [folder / str(f) for f in meta["files"]]
                for f in files:
                    if f.parent != folder or not f.is_file():
                        raise FileFormatError(jp, f"listed band file {f.name!r} is not in the folder")
            else:
                files = pngs  # in natural order: band2.png before band10.png
            if len(files) != wls.size:
                raise FileFormatError(jp, f"{wls.size} wavelengths for {len(files)} band PNGs")
            return files, wls, meta
    numbered = [(int(m.group(1)), p) for p in pngs if (m := _CAVE_NUMBER.search(p.name))]
    if not numbered:
        raise FileFormatError(folder, "no scene.json with wavelengths, and the PNGs are not named like CAVE's NAME_01.png ... NAME_31.png")
    numbered.sort()
    idx = np.array([n for n, _ in numbered])
    if idx.min() < 1 or idx.max() > 31 or len(set(idx)) != idx.size:
        raise FileFormatError(folder, f"CAVE band numbers must be distinct and within 01..31, got {sorted(set(idx.tolist()))}")
    return [p for _, p in numbered], CAVE_WAVELENGTHS[idx - 1], {}


def _band(path, size):
    from PIL import Image, UnidentifiedImageError

    check_regular(path)
    try:
        with Image.open(path) as im:
            if im.size != size:
                raise FileFormatError(path, f"band is {im.size[0]} x {im.size[1]}, the others are {size[0]} x {size[1]}")
            sixteen = im.mode.startswith("I")
            a = np.asarray(im)
    except (UnidentifiedImageError, OSError) as exc:
        raise FileFormatError(path, f"not a readable PNG ({exc})") from None
    if a.ndim == 3:  # a colour PNG for a band: keep its first channel
        a = a[:, :, 0]
    full = 65535.0 if sixteen or a.dtype == np.uint16 else 255.0
    return a.astype(float) / full


def read_band_folder(path, *, illuminant=None, luminance=100.0, negative="error", max_values=None):
    """Read a folder of band PNGs as a :class:`~camsim_core.scene.Scene` (see the module docstring).

    ``illuminant`` (a name or Spectrum): treat the bands as reflectance and
    light them with it, scaled so that a white reflector has ``luminance`` cd/m^2.
    ``max_values`` tightens the size bound (pixels x bands).
    """
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.is_dir():
        raise FileFormatError(path, "not a folder (a band-PNG scene is a folder of one PNG per band)")
    folder, pngs = _folder(path)
    files, wls, meta = _layout(folder, pngs)
    check_regular(files[0])
    try:
        with Image.open(files[0]) as im:
            size = im.size
    except (UnidentifiedImageError, OSError) as exc:
        raise FileFormatError(files[0], f"not a readable PNG ({exc})") from None
    check_scene_size(folder, (size[1], size[0], len(files)), max_values=max_values)
    cube = np.empty((size[1], size[0], len(files)))
    for k, f in enumerate(files):
        cube[:, :, k] = _band(f, size)
    notices = []
    if illuminant is not None:
        from .synthetic import _illuminant, scale_to_luminance

        spd, e = _illuminant(illuminant, wls)
        e = e * scale_to_luminance(wls, e, luminance)
        cube *= e
        illum = spd
        unit_note = f"bands taken as reflectance under {spd.name or 'the illuminant'} (white {luminance:g} cd/m^2)"
    else:
        illum = None
        if "scale" in meta:
            cube *= float(meta["scale"])
            unit_note = None
        else:
            unit_note = "no 'scale' in scene.json: PNG values / full scale taken as W/sr/m^2 per band"
    if unit_note:
        notices.append(unit_note)
    distance = float(meta["distance"]) if "distance" in meta else None
    ar = None
    if "angular_resolution" in meta:
        v = np.broadcast_to(np.asarray(meta["angular_resolution"], float).ravel(), (2,))
        ar = (float(v[0]), float(v[1]))
    name = folder.name[:-3] if folder.name.endswith("_ms") else folder.name
    return finish_scene(folder, cube, wls, distance=distance, angular_resolution=ar, illuminant=illum, name=name,
                        comments=f"{len(files)} band PNGs", notices=notices, negative=negative)


def write_band_folder(scene, folder, *, bits=16):
    """Write a scene as one PNG per band plus ``scene.json`` (wavelengths, geometry, ``scale``).

    Values are scaled so the brightest is full scale; reading back gives the
    scene to within the PNG's quantization (1 / 65535 of the maximum for 16 bits).
    """
    from PIL import Image

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    full = 2**bits - 1
    peak = float(scene.data.max()) or 1.0
    names = []
    for k, w in enumerate(scene.wavelengths):
        name = f"{scene.name or 'scene'}_{k + 1:02d}.png"
        q = np.round(scene.data[:, :, k] / peak * full).astype(np.uint16 if bits > 8 else np.uint8)
        Image.fromarray(q).save(folder / name)
        names.append(name)
    meta = dict(wavelengths=[float(w) for w in scene.wavelengths], files=names, distance=scene.distance,
                angular_resolution=list(scene.angular_resolution), scale=peak)
    (folder / "scene.json").write_text(json.dumps(meta, indent=1))
    return folder
