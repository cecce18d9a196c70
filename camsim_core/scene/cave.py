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
import math
import os
import re
from pathlib import Path

import numpy as np

from ..errors import FileFormatError
from ..io.files import read_regular
from ._intake import check_scene_size, finish_scene
from .envi import _short, wavelength_list
from .photo import opened_image

__all__ = ["read_band_folder", "write_band_folder", "CAVE_WAVELENGTHS"]

#: CAVE's sampling: 400:10:700 nm, bands numbered 01..31.
CAVE_WAVELENGTHS = 400.0 + 10.0 * np.arange(31)
_JSON_NAMES = ("scene.json", "wavelengths.json")
_CAVE_NUMBER = re.compile(r"_(\d{2})\.png$", re.IGNORECASE)
#: Folders entered looking for the bands (a CAVE download nests them two deep).
_MAX_DEPTH = 4
#: 16-bit grey modes of Pillow (CAVE's bands), read at full precision; "I" (32-bit) must hold 16-bit values.
_SIXTEEN_BIT_MODES = ("I;16", "I;16L", "I;16B", "I;16N", "I")
#: 8-bit modes a band may have; a colour one gives its first (red) channel.
_EIGHT_BIT_MODES = ("1", "L", "LA", "P", "PA", "RGB", "RGBA", "RGBX")


def _natural(path):
    """Sort key that puts band2.png before band10.png."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def _folder(path, shown, depth=0):
    """(folder, its PNGs in natural order): ``path``, or its only sub-folder when it holds no PNG (a few levels down)."""
    try:
        entries = list(path.iterdir())
    except OSError as exc:
        raise FileFormatError(shown, f"cannot list the folder: {exc.strerror or type(exc).__name__}") from None
    pngs = sorted((p for p in entries if p.suffix.lower() == ".png"), key=_natural)
    if pngs:
        return path, pngs
    subs = [p for p in entries if p.is_dir() and not p.is_symlink()]
    if len(subs) == 1 and depth < _MAX_DEPTH:
        return _folder(subs[0], shown, depth + 1)
    raise FileFormatError(shown, "folder holds no band PNGs (expected one PNG per band, CAVE's layout)")


def _named(shown, root, member):
    """How errors name ``member`` of the folder ``root``: ``shown`` then its path inside the folder."""
    return f"{shown}: {Path(os.path.relpath(member, root)).as_posix()}"


def _number(where, key, value):
    """A JSON field that must be one finite positive number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FileFormatError(where, f"{key!r} must be a number, got {_short(value)}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not (math.isfinite(x) and x > 0):
        raise FileFormatError(where, f"{key!r} must be a finite positive number, got {_short(value)}")
    return x


def _numbers(where, key, values, sizes):
    """A JSON list of ``sizes`` numbers (or one number), each checked by :func:`_number`."""
    v = values if isinstance(values, list) else [values]
    if len(v) not in sizes:
        raise FileFormatError(where, f"{key!r} must hold {' or '.join(map(str, sizes))} number(s), got {_short(values)}")
    return [_number(where, key, x) for x in v]


def _file_names(where, folder, names):
    """The band files ``names`` of the JSON: plain names of regular files in ``folder``."""
    if not isinstance(names, list) or not names:
        raise FileFormatError(where, f"'files' must be a list of band file names, got {_short(names)}")
    out = []
    for name in names:
        if (not isinstance(name, str) or not name.strip() or len(name) > 255 or name in (".", "..")
                or any(c in name for c in "/\\\0")):
            raise FileFormatError(where, f"'files' must list plain file names in the folder, got {_short(name)}")
        if not os.path.isfile(folder / name):
            raise FileFormatError(where, f"listed band file {_short(name)} is not in the folder")
        out.append(folder / name)
    return out


def _layout(folder, pngs, root, shown):
    """(files, wavelengths, options) from the JSON file or CAVE's numbering, every field checked."""
    candidates = [folder / n for n in _JSON_NAMES if (folder / n).is_file()]
    others = sorted(p for p in folder.glob("*.json") if p.name not in _JSON_NAMES)
    if not candidates and len(others) == 1:
        candidates = others  # one JSON file of any name
    if candidates:
        jp = candidates[0]
        where = _named(shown, root, jp)
        try:
            meta = json.loads(read_regular(jp, max_bytes=1 << 20, shown=where))
        except (ValueError, RecursionError) as exc:  # UnicodeDecodeError is a ValueError; nesting too deep
            raise FileFormatError(where, f"not valid JSON ({type(exc).__name__}: {str(exc)[:200]})") from None
        if isinstance(meta, list):
            meta = {"wavelengths": meta}
        if isinstance(meta, dict) and "wavelengths" not in meta:
            for alias in ("bands", "wavelength", "wave"):
                if alias in meta:
                    meta["wavelengths"] = meta[alias]
                    break
        if not isinstance(meta, dict) or "wavelengths" not in meta:
            raise FileFormatError(where, "expected an object with 'wavelengths' (one per band, nm)")
        raw = meta["wavelengths"]
        if not isinstance(raw, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in raw):
            raise FileFormatError(where, f"'wavelengths' must be a list of numbers (nm), got {_short(raw)}")
        wls = wavelength_list(where, "'wavelengths'", [_finite_or_inf(v) for v in raw])
        files = _file_names(where, folder, meta["files"]) if "files" in meta else pngs  # natural order
        if len(files) != wls.size:
            raise FileFormatError(where, f"{wls.size} wavelengths for {len(files)} band PNGs")
        options = {}
        if "distance" in meta:
            options["distance"] = _number(where, "distance", meta["distance"])
        if "angular_resolution" in meta:
            v = _numbers(where, "angular_resolution", meta["angular_resolution"], (1, 2))
            options["angular_resolution"] = (v[0], v[-1])
        if "scale" in meta:
            options["scale"] = _number(where, "scale", meta["scale"])
        return files, wls, options
    numbered = [(int(m.group(1)), p) for p in pngs if (m := _CAVE_NUMBER.search(p.name))]
    if not numbered:
        raise FileFormatError(shown, "no scene.json with wavelengths, and the PNGs are not named like CAVE's "
                                     "NAME_01.png ... NAME_31.png")
    numbered.sort()
    idx = np.array([n for n, _ in numbered])
    if idx.min() < 1 or idx.max() > 31 or len(set(idx)) != idx.size:
        raise FileFormatError(shown, f"CAVE band numbers must be distinct and within 01..31, got {sorted(set(idx.tolist()))}")
    return [p for _, p in numbered], CAVE_WAVELENGTHS[idx - 1], {}


def _finite_or_inf(v):
    """``float(v)``, an integer too large for a float becoming inf (refused by :func:`wavelength_list`)."""
    try:
        return float(v)
    except OverflowError:
        return math.inf


def _band(path, size, where):
    """One band as floats in [0, 1] (divided by its full scale), its size and mode checked before decoding."""
    with opened_image(path, where, "PNG") as im:
        if im.size != size:
            raise FileFormatError(where, f"band is {im.size[0]} x {im.size[1]}, the others are {size[0]} x {size[1]}")
        if im.mode in _SIXTEEN_BIT_MODES:
            a, full = np.asarray(im), 65535.0
        elif im.mode in ("L", "1"):
            a, full = np.asarray(im.convert("L")), 255.0
        elif im.mode in _EIGHT_BIT_MODES:  # a colour PNG for a band: keep its first channel
            im.load()  # a transparency chunk after the pixels is read with them
            a, full = np.asarray(im.convert("RGBA" if "transparency" in im.info else "RGB"))[:, :, 0], 255.0
        else:
            raise FileFormatError(where, f"image mode {im.mode!r} is not a band's; expected 8- or 16-bit grey")
    if a.shape != (size[1], size[0]) or a.dtype.kind not in "biu":
        raise FileFormatError(where, f"decoded to shape {a.shape} ({a.dtype}), expected {size[1]} x {size[0]} whole numbers")
    if a.size and (a.min() < 0 or a.max() > full):
        raise FileFormatError(where, f"holds values {a.min()}..{a.max()}, outside 0..{full:g}")
    return a.astype(float) / full


def read_band_folder(path, *, illuminant=None, luminance=100.0, negative="error", max_values=None, shown=None):
    """Read a folder of band PNGs as a :class:`~camsim_core.scene.Scene` (see the module docstring).

    ``illuminant`` (a name or Spectrum): treat the bands as reflectance and
    light them with it, scaled so that a white reflector has ``luminance`` cd/m^2.
    ``max_values`` tightens the size bound (pixels x bands).

    Every field of the JSON file is checked (wavelengths finite, positive,
    strictly increasing and within
    :data:`~camsim_core.scene.scene.WAVELENGTH_RANGE`; band files plain
    names in the folder; distance, angular resolution and scale finite and
    positive), and every band's size and mode from its header before any is
    decoded into the cube. Errors name ``shown`` (default: the folder's
    name) and the member at fault, never the folder's path.
    """
    path = Path(path)
    shown = path.name if shown is None else str(shown)
    if not path.is_dir():
        raise FileFormatError(shown, "not a folder (a band-PNG scene is a folder of one PNG per band)")
    folder, pngs = _folder(path, shown)
    files, wls, meta = _layout(folder, pngs, path, shown)
    with opened_image(files[0], _named(shown, path, files[0]), "PNG") as im:
        size = im.size
    check_scene_size(shown, (size[1], size[0], len(files)), max_values=max_values)
    for f in files[1:]:  # every band's header before the cube is allocated
        with opened_image(f, _named(shown, path, f), "PNG") as im:
            if im.size != size:
                raise FileFormatError(_named(shown, path, f), f"band is {im.size[0]} x {im.size[1]}, "
                                                              f"the others are {size[0]} x {size[1]}")
    cube = np.empty((size[1], size[0], len(files)))
    for k, f in enumerate(files):
        cube[:, :, k] = _band(f, size, _named(shown, path, f))
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
            cube *= meta["scale"]
            unit_note = None
        else:
            unit_note = "no 'scale' in scene.json: PNG values / full scale taken as W/sr/m^2 per band"
    if unit_note:
        notices.append(unit_note)
    name = folder.name[:-3] if folder.name.endswith("_ms") else folder.name
    return finish_scene(shown, cube, wls, distance=meta.get("distance"), angular_resolution=meta.get("angular_resolution"),
                        illuminant=illum, name=name, comments=f"{len(files)} band PNGs", notices=notices,
                        negative=negative)


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
