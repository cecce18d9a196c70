"""Loading scenes: shipped names, the original simulator's ``.Simg``, and ``.npz``."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..datasets import SIMTOOLBOX
from ..datasets.illuminants import illuminant as named_illuminant
from ..errors import FileFormatError, ParameterError
from ..io.files import check_regular, member_path, read_regular
from ..io.guard import reader_errors
from ..io.simtoolbox import checked_wavelengths, group_number, group_numbers, read_tagged, wavelength_sampling
from ..spectra import Spectrum, sampling_wavelengths
from .scene import Scene, check_radiance
from .charts import CHART_NAMES, chart
from .photo import PHOTO_SUFFIXES, SAMPLE_PHOTOS
from .synthetic import macbeth_scene, stripe_scene

__all__ = ["load_scene", "read_simg", "read_npz_scene", "save_npz_scene", "SCENE_NAMES"]

_SHIPPED = {
    "cacaphony290": ("Cacaphony290/Cacaphony290.Simg", "cacaphony"),
    "bfgb128": ("BFGB_128/BFGB_128.Simg", "bfgb"),
}
# (the Macbeth chart is a chart too, "macbeth:patch_size=32": named once, in its place after the shipped scenes)
SCENE_NAMES = tuple(dict.fromkeys(tuple(_SHIPPED) + ("macbeth", "stripes") + CHART_NAMES
                                  + tuple(f"photo-{p}" for p in SAMPLE_PHOTOS)))
_CACHE = {}


def load_scene(name_or_path, *, negative="error"):
    """A :class:`Scene` from a shipped name or chart (``SCENE_NAMES``), or a path.

    Paths by extension: ``.Simg``, ``.npz``, ENVI ``.hdr``
    (:mod:`~camsim_core.scene.envi`), MATLAB ``.mat`` v5 or v7.3
    (:mod:`~camsim_core.scene.matlab`: ICVL, ARAD, Harvard, ISETCam), a photo
    ``.png`` / ``.jpg`` (:mod:`~camsim_core.scene.photo`, a plausible
    spectrum), or a folder of band PNGs (:mod:`~camsim_core.scene.cave`).
    Charts (``slanted-edge``, ``zone-plate``, ``uniform``, ``munsell``, ``macbeth``) come
    at their default settings (:mod:`~camsim_core.scene.charts`), or with
    options after a colon: ``"slanted-edge:angle=10,contrast=2,illuminant=A"``. What a
    reader had to assume is in ``scene.notices`` (and warned).

    Shipped scenes are read once per process and shared (they are read-only).
    ``negative="clip"`` clips negative radiances with a warning instead of
    refusing them.

    Examples
    --------
    >>> scene = load_scene("macbeth")
    >>> scene.shape, scene.name, scene.wavelengths[0], scene.wavelengths[-1]
    ((84, 124, 31), 'macbeth', 400.0, 700.0)
    """
    if isinstance(name_or_path, Scene):
        return name_or_path
    key = str(name_or_path)
    with reader_errors(key):  # the last line of defence: no reader leaks a traceback
        return _load_scene(key, negative)


def _load_scene(key, negative):
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
    if low in CHART_NAMES or (low.startswith("photo-") and low[6:] in SAMPLE_PHOTOS):
        if low not in _CACHE:  # default charts and sample photos are made once and shared (read-only)
            from .photo import read_photo

            _CACHE[low] = chart(low) if low in CHART_NAMES else read_photo(low)
        return _CACHE[low]
    if ":" in low and low.split(":", 1)[0] in CHART_NAMES:
        return chart(key)  # a chart with options, "slanted-edge:angle=10,contrast=2"
    path = Path(key)
    if not os.path.lexists(path):
        raise FileFormatError(path, f"no such file, and not a shipped scene or chart name ({', '.join(SCENE_NAMES)})")
    if path.is_dir():
        from .cave import read_band_folder

        return read_band_folder(path, negative=negative, shown=key)
    suffix = path.suffix.lower()
    if suffix == ".simg":
        return read_simg(path, negative=negative, shown=path)
    if suffix == ".npz":
        return read_npz_scene(path, negative=negative, shown=path)
    if suffix == ".hdr":
        from .envi import read_envi

        return read_envi(path, negative=negative, shown=key)
    if suffix == ".mat":
        from .matlab import read_mat

        return read_mat(path, negative=negative, shown=key)
    if suffix in PHOTO_SUFFIXES:
        from .photo import read_photo

        return read_photo(path, shown=key)
    raise FileFormatError(
        path, "unknown scene format: expected a .Simg header with its planes, an .npz, an ENVI .hdr, a MATLAB .mat, "
        f"a photo ({', '.join(PHOTO_SUFFIXES)}) or a folder of band PNGs")


#: Shipped hyperspectral cameras a ``#SimCameraFile`` may name when the file is not beside the header.
SHIPPED_CAMERA_FILES = tuple(sorted(p.name for p in (SIMTOOLBOX / "cameras").glob("*.Scam")))


def _shown(path, shown):
    return Path(path).name if shown is None else shown


def _camera_angular_resolution(simg_path, tagged, shown):
    """Pixels per degree (x, y) of the hyperspectral camera ``#SimCameraFile`` names.

    The file is looked for beside the header (never outside its folder) and
    then among the shipped cameras by name; nothing else of the file
    system is ever opened.
    """
    cam_name = tagged.text("CameraFile").strip()
    if not cam_name:
        raise FileFormatError(shown, "required tag #SimCameraFile is missing (the hyperspectral camera, for its angular resolution)")
    cam_path = member_path(Path(simg_path).parent, cam_name, shown=shown, field="#SimCameraFile")
    cam_shown = f"{shown}: camera file {cam_name}"
    if os.path.lexists(cam_path):
        cam = read_tagged(cam_path, shown=cam_shown)
    elif cam_name in SHIPPED_CAMERA_FILES:
        cam = read_tagged(SIMTOOLBOX / "cameras" / cam_name, shown=cam_name)
    else:
        raise FileFormatError(shown, f"camera file {cam_name!r} named by #SimCameraFile is neither beside the header "
                                     f"nor a shipped camera ({', '.join(SHIPPED_CAMERA_FILES)})")
    x = group_number(cam, "AngularResolution", "X", positive=True)
    y = group_number(cam, "AngularResolution", "Y", positive=True)
    return (x, y)


def simg_shape(path, *, shown=None):
    """(height, width, planes) a ``.Simg`` header declares, checked, without reading any plane."""
    shown = _shown(path, shown)
    t = read_tagged(path, shown=shown)
    return _simg_shape(t)


def _simg_shape(t):
    h = t.number("Height", required=True, integer=True, positive=True)
    w = t.number("Width", required=True, integer=True, positive=True)
    n = wavelength_sampling(t).size
    return h, w, n


def read_simg(path, *, name=None, negative="error", shown=None, max_values=None):
    """Read a hyperspectral ``.Simg`` header and its planes (16-bit big-endian, one file per wavelength).

    Each plane times its ``#Sim#ImageFactors`` entry is calibrated radiance.
    Plane files (``#SimImageRoot`` followed by the wavelength in nm) and the
    camera file must lie beside the header: absolute names and ``..`` are
    refused before anything is opened. ``shown`` is the name errors give
    the header (default: its file name); ``max_values`` refuses a scene of
    more than that many values (pixels x planes) before allocating it.
    """
    path = Path(path)
    shown = _shown(path, shown)
    t = read_tagged(path, shown=shown)
    h, w, count = _simg_shape(t)
    if max_values is not None and h * w * count > max_values:
        raise FileFormatError(shown, f"declares {h} x {w} pixels x {count} planes = {h * w * count} values, "
                                     f"more than the {max_values} allowed")
    wls = wavelength_sampling(t)
    factors = np.asarray(t.require("ImageFactors", "one calibration factor per plane"), float).ravel()
    if factors.size != count:
        raise FileFormatError(shown, f"#Sim#ImageFactors has {factors.size} factors for {count} planes")
    if np.any(factors < 0):
        raise FileFormatError(shown, "#Sim#ImageFactors holds negative factors; expected non-negative calibration factors")
    distance = t.number("InputCameraDistance", required=True, positive=True)
    root = t.text("ImageRoot").strip()
    angular = _camera_angular_resolution(path, t, shown)
    planes = []
    for wl in wls:  # every plane checked (beside the header, regular, the right size) before allocating
        plane_name = f"{root}{int(round(wl))}"
        plane = member_path(path.parent, plane_name, shown=shown, field="#SimImageRoot")
        if not os.path.lexists(plane):
            raise FileFormatError(shown, f"plane file {plane_name!r} for {wl:g} nm is missing (expected beside the header)")
        size = check_regular(plane, f"{shown}: plane {plane_name}").st_size
        if size != 2 * h * w:
            raise FileFormatError(f"{shown}: plane {plane_name}", f"is {size} bytes, expected {2 * h * w} "
                                                                  f"({h} x {w} 16-bit values): truncated or wrong size")
        planes.append((plane, plane_name))
    # 16-bit samples times a factor per plane: float32 holds each to its rounding (6e-8 relative), so the cube
    # is float32 (half the memory of float64, and every stage after it runs in float32)
    cube = np.empty((h, w, count), np.float32)
    for k, (plane, plane_name) in enumerate(planes):
        raw = read_regular(plane, max_bytes=2 * h * w, shown=f"{shown}: plane {plane_name}")
        if len(raw) != 2 * h * w:
            raise FileFormatError(f"{shown}: plane {plane_name}", f"is {len(raw)} bytes, expected {2 * h * w}")
        with np.errstate(over="ignore"):  # an overflow becomes inf, refused by check_radiance below
            cube[:, :, k] = np.frombuffer(raw, dtype=">u2").reshape(h, w) * factors[k]
    illum = None
    act = t.get_tag("ActualIlluminant")
    if isinstance(act, dict):
        spd = group_numbers(t, "ActualIlluminant", "Spd", required=False)
        s = group_numbers(t, "ActualIlluminant", "S", required=False)
        if spd is not None and s is not None and s.size >= 3 and spd.size == int(s[2]):
            if s[0] <= 0 or s[1] <= 0 or s[2] != int(s[2]):
                raise FileFormatError(shown, f"#SimActualIlluminant ##SimS is {s[:3].tolist()}; expected [start step count], all positive")
            if np.any(spd < 0):
                raise FileFormatError(shown, "#SimActualIlluminant ##SimSpd holds negative values; expected a non-negative spectrum")
            illum = Spectrum(checked_wavelengths(shown, "#SimActualIlluminant ##SimS", s[0], s[1], int(s[2])), spd, "measured")
    label = name or path.stem
    cube = check_radiance(cube, shown, negative)
    cube.flags.writeable = False  # our own array: the Scene keeps it without a copy
    try:
        return Scene(cube, wls, distance, angular, "W/sr/m^2 per band", illum, label, t.text("Comments"))
    except ParameterError as exc:
        raise FileFormatError(shown, str(exc)) from None


#: Most members an ``.npz`` scene may hold (it needs five at most).
NPZ_MAX_MEMBERS = 64


def npz_headers(path, *, shown=None, max_members=NPZ_MAX_MEMBERS):
    """``{key: (shape, dtype)}`` of every array of an ``.npz``, from the array headers alone.

    Reads the zip's central directory and the first bytes of each ``.npy``
    member (:mod:`numpy.lib.format`), never the data, so that a file
    declaring a huge array is refused before anything is allocated.
    """
    import zipfile

    from numpy.lib import format as npy

    shown = _shown(path, shown)
    check_regular(path, shown)
    try:
        with zipfile.ZipFile(path) as z:
            infos = z.infolist()
            if len(infos) > max_members:
                raise FileFormatError(shown, f"holds {len(infos)} members, more than the {max_members} an .npz scene may have")
            out = {}
            for info in infos:
                key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                with z.open(info) as f:
                    version = npy.read_magic(f)
                    if version == (1, 0):
                        shape, fortran, dtype = npy.read_array_header_1_0(f)
                    elif version == (2, 0):
                        shape, fortran, dtype = npy.read_array_header_2_0(f)
                    else:
                        raise ValueError(f"unsupported .npy version {version}")
                out[key] = (tuple(int(d) for d in shape), np.dtype(dtype))
            return out
    except FileFormatError:
        raise
    except Exception as exc:  # zipfile.BadZipFile, a bad .npy header, EOFError ...
        raise FileFormatError(shown, f"cannot read as .npz: {exc}") from None


def _npz_number_array(key, dtype, shown):
    if dtype.hasobject or dtype.kind not in "biuf":
        raise FileFormatError(shown, f"{key!r} must hold real numbers, found dtype {dtype}")


def read_npz_scene(path, *, name=None, negative="error", shown=None, max_values=None):
    """Read an ``.npz`` scene: ``data`` (H, W, N), ``wavelengths`` (N,), optional
    ``distance`` (one number, m), ``angular_resolution`` (2,) and ``illuminant`` (N,).

    Every array's shape and type are checked from its header before any
    data are read (``max_values`` bounds H x W x N); never unpickles.
    ``shown`` is the name errors give the file (default: its file name).
    """
    path = Path(path)
    shown = _shown(path, shown)
    heads = npz_headers(path, shown=shown)
    for key in ("data", "wavelengths"):
        if key not in heads:
            raise FileFormatError(shown, f"required key {key!r} is missing (keys: {', '.join(sorted(heads)) or 'none'})")
    expected = {"data": 3, "wavelengths": 1, "distance": 0, "angular_resolution": 1, "illuminant": 1}
    for key, (shape, dtype) in heads.items():
        if key not in expected:
            continue
        _npz_number_array(key, dtype, shown)
        if key == "distance" and int(np.prod(shape)) != 1:
            raise FileFormatError(shown, f"'distance' must be one number (m), got shape {shape}")
        elif key != "distance" and len(shape) != expected[key]:
            raise FileFormatError(shown, f"{key!r} must have {expected[key]} dimension(s), got shape {shape}")
    h, w, n = heads["data"][0]
    if min(h, w, n) < 1:
        raise FileFormatError(shown, f"'data' is {h} x {w} x {n}; expected at least one pixel and one plane")
    if max_values is not None and h * w * n > max_values:
        raise FileFormatError(shown, f"'data' declares {h} x {w} pixels x {n} planes = {h * w * n} values, "
                                     f"more than the {max_values} allowed")
    if heads["wavelengths"][0] != (n,):
        raise FileFormatError(shown, f"'wavelengths' has shape {heads['wavelengths'][0]} for {n} planes")
    if "angular_resolution" in heads and heads["angular_resolution"][0] != (2,):
        raise FileFormatError(shown, "'angular_resolution' must hold two numbers (x, y) in pixels per degree")
    if "illuminant" in heads and heads["illuminant"][0] != (n,):
        raise FileFormatError(shown, f"'illuminant' has shape {heads['illuminant'][0]} for {n} wavelengths")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in expected if k in heads}
    except Exception as exc:  # a truncated member, a bad CRC ...
        raise FileFormatError(shown, f"cannot read as .npz: {exc}") from None
    wls = arrays["wavelengths"].astype(float)
    if not np.all(np.isfinite(wls)) or np.any(wls <= 0) or np.any(np.diff(wls) <= 0):
        raise FileFormatError(shown, "'wavelengths' must be finite, positive and strictly increasing (nm)")
    distance = float(arrays["distance"].ravel()[0]) if "distance" in arrays else 1.0
    ar = tuple(arrays["angular_resolution"].astype(float)) if "angular_resolution" in arrays else (57.3, 57.3)
    illum = None
    if "illuminant" in arrays:
        iv = arrays["illuminant"].astype(float)
        if not np.all(np.isfinite(iv)) or np.any(iv < 0):
            raise FileFormatError(shown, "'illuminant' must be finite and non-negative (a power spectrum)")
        illum = Spectrum(wls, iv, "from file")
    cube = check_radiance(arrays["data"], shown, negative)  # float32 stays float32
    cube.flags.writeable = False  # our own array: the Scene keeps it without a copy
    try:
        return Scene(cube, wls, distance, ar, "W/sr/m^2 per band", illum, name or path.stem, "")
    except ParameterError as exc:
        raise FileFormatError(shown, str(exc)) from None


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
