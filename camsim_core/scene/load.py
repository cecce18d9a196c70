"""Loading scenes: shipped names, the original simulator's ``.Simg``, and ``.npz``."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..datasets import SIMTOOLBOX
from ..datasets.illuminants import illuminant as named_illuminant
from ..errors import FileFormatError, ParameterError
from ..io.simtoolbox import group_numbers, read_tagged
from ..spectra import Spectrum, sampling_wavelengths
from .scene import Scene, check_radiance
from .synthetic import macbeth_scene, stripe_scene

__all__ = ["load_scene", "read_simg", "read_npz_scene", "save_npz_scene", "SCENE_NAMES"]

_SHIPPED = {
    "cacaphony290": ("Cacaphony290/Cacaphony290.Simg", "cacaphony"),
    "bfgb128": ("BFGB_128/BFGB_128.Simg", "bfgb"),
}
SCENE_NAMES = tuple(_SHIPPED) + ("macbeth", "stripes")
_CACHE = {}


def load_scene(name_or_path, *, negative="error"):
    """A :class:`Scene` from a shipped name (``SCENE_NAMES``) or a ``.Simg`` / ``.npz`` path.

    Shipped scenes are read once per process and shared (they are read-only).
    ``negative="clip"`` clips negative radiances with a warning instead of
    refusing them.
    """
    if isinstance(name_or_path, Scene):
        return name_or_path
    key = str(name_or_path)
    low = key.lower()
    if low in _SHIPPED:
        if low not in _CACHE:
            rel, illum = _SHIPPED[low]
            scene = read_simg(SIMTOOLBOX / rel, name=low)
            if scene.illuminant is None:
                scene = Scene(scene.data, scene.wavelengths, scene.distance, scene.angular_resolution, scene.unit,
                              named_illuminant(illum), scene.name, scene.comments)
            _CACHE[low] = scene
        return _CACHE[low]
    if low == "macbeth":
        return macbeth_scene()
    if low == "stripes":
        return stripe_scene()
    path = Path(key)
    if not path.exists():
        raise FileFormatError(path, f"no such file, and not a shipped scene name ({', '.join(SCENE_NAMES)})")
    suffix = path.suffix.lower()
    if suffix == ".simg":
        return read_simg(path, negative=negative)
    if suffix == ".npz":
        return read_npz_scene(path, negative=negative)
    raise FileFormatError(path, "unknown scene format: expected a .Simg header with its planes, or an .npz")


def _camera_angular_resolution(simg_path, tagged):
    cam_name = tagged.text("CameraFile")
    if not cam_name:
        raise FileFormatError(simg_path, "required tag #SimCameraFile is missing (the hyperspectral camera, for its angular resolution)")
    for folder in (Path(simg_path).parent, SIMTOOLBOX / "cameras"):
        cam_path = folder / cam_name
        if cam_path.exists():
            cam = read_tagged(cam_path)
            x = group_numbers(cam, "AngularResolution", "X")[0]
            y = group_numbers(cam, "AngularResolution", "Y")[0]
            return (x, y)
    raise FileFormatError(simg_path, f"camera file {cam_name!r} named by #SimCameraFile not found beside the header or in the shipped cameras")


def read_simg(path, *, name=None, negative="error"):
    """Read a hyperspectral ``.Simg`` header and its planes (16-bit big-endian, one file per wavelength).

    Each plane times its ``#Sim#ImageFactors`` entry is calibrated radiance.
    """
    path = Path(path)
    t = read_tagged(path)
    h = int(t.number("Height", required=True))
    w = int(t.number("Width", required=True))
    start = group_numbers(t, "WavelengthSampling", "Start")[0]
    step = group_numbers(t, "WavelengthSampling", "Step")[0]
    count = int(group_numbers(t, "WavelengthSampling", "NumberSamples")[0])
    factors = np.asarray(t.require("ImageFactors", "one calibration factor per plane"), float).ravel()
    if factors.size != count:
        raise FileFormatError(path, f"#Sim#ImageFactors has {factors.size} factors for {count} planes")
    distance = t.number("InputCameraDistance", required=True)
    wls = sampling_wavelengths(start, step, count)
    root = t.text("ImageRoot")
    cube = np.empty((h, w, count))
    for k, wl in enumerate(wls):
        plane = path.parent / f"{root}{int(round(wl))}"
        try:
            raw = plane.read_bytes()
        except OSError:
            raise FileFormatError(plane, f"plane for {wl:g} nm is missing (expected beside {path.name})") from None
        if len(raw) != 2 * h * w:
            raise FileFormatError(plane, f"plane is {len(raw)} bytes, expected {2 * h * w} ({h} x {w} 16-bit values): truncated or wrong size")
        cube[:, :, k] = np.frombuffer(raw, dtype=">u2").reshape(h, w) * factors[k]
    illum = None
    act = t.get_tag("ActualIlluminant")
    if isinstance(act, dict):
        spd = group_numbers(t, "ActualIlluminant", "Spd", required=False)
        s = group_numbers(t, "ActualIlluminant", "S", required=False)
        if spd is not None and s is not None and s.size >= 3 and spd.size == int(s[2]):
            illum = Spectrum(sampling_wavelengths(*s[:3]), spd, "measured")
    label = name or path.stem
    cube = check_radiance(cube, str(path), negative)
    return Scene(cube, wls, distance, _camera_angular_resolution(path, t), "W/sr/m^2 per band", illum, label, t.text("Comments"))


def read_npz_scene(path, *, negative="error"):
    """Read an ``.npz`` scene: ``data`` (H, W, N), ``wavelengths`` (N,), optional
    ``distance``, ``angular_resolution`` (2,) and ``illuminant`` (N,). Never unpickles."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except ValueError as exc:
        raise FileFormatError(path, f"not a plain-array .npz ({exc})") from None
    except (OSError, EOFError) as exc:
        raise FileFormatError(path, f"cannot read as .npz: {exc}") from None
    except Exception as exc:  # zipfile.BadZipFile and friends
        raise FileFormatError(path, f"cannot read as .npz: {exc}") from None
    for key in ("data", "wavelengths"):
        if key not in arrays:
            raise FileFormatError(path, f"required key {key!r} is missing (keys: {', '.join(sorted(arrays)) or 'none'})")
    data = arrays["data"]
    if data.ndim != 3:
        raise FileFormatError(path, f"'data' must be (H, W, N), got shape {data.shape}")
    wls = np.asarray(arrays["wavelengths"], float).ravel()
    if wls.size != data.shape[2]:
        raise FileFormatError(path, f"'wavelengths' has {wls.size} entries for {data.shape[2]} planes")
    if not np.issubdtype(data.dtype, np.number):
        raise FileFormatError(path, f"'data' must be numeric, got {data.dtype}")
    distance = float(arrays["distance"]) if "distance" in arrays else 1.0
    ar = tuple(np.asarray(arrays.get("angular_resolution", [57.3, 57.3]), float).ravel()[:2])
    if len(ar) != 2:
        raise FileFormatError(path, "'angular_resolution' must hold two numbers (x, y) in pixels per degree")
    illum = None
    if "illuminant" in arrays:
        iv = np.asarray(arrays["illuminant"], float).ravel()
        if iv.size != wls.size:
            raise FileFormatError(path, f"'illuminant' has {iv.size} values for {wls.size} wavelengths")
        illum = Spectrum(wls, iv, "from file")
    cube = check_radiance(data.astype(float), str(path), negative)
    try:
        return Scene(cube, wls, distance, ar, "W/sr/m^2 per band", illum, path.stem, "")
    except ParameterError as exc:
        raise FileFormatError(path, str(exc)) from None


def save_npz_scene(scene, path):
    """Write a scene as ``.npz`` (atomically: no partial file on failure)."""
    from ..io.output import atomic_write

    arrays = dict(
        data=scene.data,
        wavelengths=scene.wavelengths,
        distance=np.float64(scene.distance),
        angular_resolution=np.asarray(scene.angular_resolution, float),
    )
    if scene.illuminant is not None:
        arrays["illuminant"] = scene.illuminant.per_band(scene.wavelengths)

    def write(f):
        np.savez_compressed(f, **arrays)

    atomic_write(path, write)
    return Path(path)
