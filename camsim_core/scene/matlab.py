"""MATLAB ``.mat`` hyperspectral scenes: v5 (scipy.io) and v7.3 (HDF5, h5py).

Variables recognised, in this order:

* ISETCam scene file: a struct ``scene`` with ``data.photons`` (H x W x N,
  photons/s/sr/m^2/nm; ISET's older 16-bit compressed form with
  ``data.dmin``, ``data.dmax`` and ``data.bitDepth`` too), ``spectrum.wave``
  (nm), ``wAngular`` (horizontal field of view, degrees), ``distance`` (m)
  and ``illuminant`` (see below);
* ISETCam multispectral basis file (``sceneToFile(fname, scene, bType)``,
  ``ieSaveMultiSpectralImage``): ``mcCOEF`` (H x W x n basis coefficients),
  ``basis`` (``basis`` N x n, ``wave``), optional ``imgMean`` (N),
  ``illuminant``, ``fov`` (degrees), ``dist`` (m) and ``name``;
  photons = mcCOEF x basis' + imgMean, negative sums set to 0 (as ISETCam's
  ``vcReadImage`` does);
* ISETCam uncompressed multispectral file (``sceneToFile(fname, scene, [])``):
  ``photons`` (H x W x N; ``vcReadImage`` also takes a numeric ``data``),
  ``wave`` (or ``wavelength``), ``illuminant``, ``fov``, ``dist``, ``name``;
* ICVL: ``rad`` with ``bands``; ARAD: ``cube`` with ``bands``; Harvard:
  ``ref``. Without a ``bands``/``wavelengths`` variable, a 31-band cube gets
  its dataset's sampling (ICVL and ARAD 400:10:700 nm, Harvard 420:10:720 nm)
  with a notice.

ISETCam illuminants, in the layouts ISETCam's own readers accept
(``illuminantGet``, ``illuminantModernize``, ``vcReadImage``); the scene's
illuminant is the radiance of a perfect white reflector, which sets the
display scale of a rendering:

* ``data.photons`` (photons/s/sr/m^2/nm) on ``spectrum.wave`` (or, inside a
  scene struct, on the scene's wavelengths), as ``illuminantCreate`` and
  ``sceneToFile`` write it. Integer photons are ISETCam's compressed form
  and are decompressed as ``illuminantGet(il, 'photons')`` does:
  ``ieUncompressData(codes, data.min, data.max, bits)`` with 32 bits for
  uint32 and 16 for uint16 codes, i.e.
  ``(max - min) / (2^bits - 1) x codes + min`` (``max / (2^bits - 1) x
  codes + min`` when min = max). A spatial-spectral illuminant (one
  spectrum per pixel) is not kept: a notice says so;
* ``data`` in energy units (W/sr/m^2/nm) on ``wavelength`` (the older
  layout ``illuminantModernize`` converts) or on ``wave`` (the layout
  ``ieSaveMultiSpectralImage`` documents).

A file without an illuminant, or ISETCam geometry, says so in a notice;
ISETCam files without ``wAngular``/``fov`` or ``distance``/``dist`` get
ISETCam's own defaults (``sceneInitSpatial``, ``sceneInitGeometry``,
``ieSaveMultiSpectralImage``): a 10 degree field of view at 1.2 m.

ISETCam photons are converted to W/sr/m^2 per band (E = h c / lambda per
photon, times the band width); energy per nm to per band by the band width.
ICVL, ARAD and Harvard cubes carry no absolute unit: their values are taken
as W/sr/m^2 per band with a notice (auto exposure makes the scale
immaterial to a simulation). Those datasets have no geometry either:
defaults with a notice.

Sizes come from the file before anything is allocated: for v7.3 from the
HDF5 dataset shapes; for v5 from a pass over the file's data elements that
counts their uncompressed length (decompressing in bounded chunks and
discarding the output), so that a small compressed file cannot expand into
an unbounded allocation. Nothing is unpickled (MATLAB objects are refused by
scipy's reader).

MATLAB stores arrays column-major; HDF5 (v7.3) files therefore hold an
H x W x N cube as (N, W, H). A v7.3 cube whose *last* axis is the band axis
(written from Python) is taken as it is.

The ISETCam layouts are read by hand from ISETCam's MATLAB sources (ISET/isetcam
on GitHub: ``ieUncompressData``, ``illuminantGet``, ``illuminantModernize``,
``sceneToFile``, ``vcReadImage``, ``sceneFromFile``); no Python package reads them.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from ..errors import CamsimError, FileFormatError
from ..io.files import check_regular, open_regular
from ..io.hdf5 import check_dataset, open_hdf5
from ..io.matv5 import check_v5
from ..spectra import Spectrum, sampling_wavelengths
from ._intake import MAX_SCENE_VALUES, check_scene_size, finish_scene, per_nm_to_per_band, photons_to_radiance

__all__ = ["read_mat", "ISETCAM_FOV", "ISETCAM_DISTANCE"]

#: ISETCam's field of view (degrees) for a scene whose file gives none (``sceneInitSpatial``).
ISETCAM_FOV = 10.0
#: ISETCam's scene distance (m) for a file that gives none (``sceneInitGeometry``).
ISETCAM_DISTANCE = 1.2

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Largest uncompressed payload of a v5 file: the largest scene as float64, plus 64 MiB for the rest.
MAX_V5_BYTES = MAX_SCENE_VALUES * 8 + 64 * 2**20
_HARVARD_WAVELENGTHS = sampling_wavelengths(420, 10, 31)
_ICVL_ARAD_WAVELENGTHS = sampling_wavelengths(400, 10, 31)
_CUBES = (("rad", "ICVL"), ("cube", "ARAD"), ("ref", "Harvard"))
_WAVELENGTH_NAMES = ("bands", "wavelengths", "wavelength", "wave", "wl")


def _is_hdf5(source):
    head = bytes(source[: 2048 + 8]) if isinstance(source, (bytes, bytearray, memoryview)) else None
    if head is None:
        with open_regular(source) as f:
            head = f.read(2048 + 8)
    return any(head[o : o + 8] == _HDF5_SIGNATURE for o in (0, 512, 1024, 2048))


def _v5_budget(max_values):
    """Most bytes a v5 file's variables may expand to: the scene bound as float64 plus 16 MiB for the rest."""
    return MAX_V5_BYTES if max_values is None else min(MAX_V5_BYTES, int(max_values) * 8 + 16 * 2**20)


class _V5:
    """Variables of a v5 file, vetted whole (:func:`~camsim_core.io.matv5.check_v5`) before scipy reads any.

    scipy.io.loadmat reads from memory (an upload's bytes) or from a memory
    map of the checked regular file; structs come as attribute objects.
    """

    transposed = False

    def __init__(self, source, shown, max_values):
        import mmap

        from scipy.io import whosmat

        self.shown = shown
        self.max_values = max_values
        self._file = None
        if isinstance(source, (bytes, bytearray, memoryview)):
            self.buf = memoryview(bytes(source))
        else:
            self._file = open_regular(source, shown)
            size = os.fstat(self._file.fileno()).st_size
            if size < 128:
                self.close()
                raise FileFormatError(shown, "not a MATLAB .mat file (shorter than its 128-byte header)")
            self.buf = mmap.mmap(self._file.fileno(), 0, access=mmap.ACCESS_READ)
        largest = check_v5(self.buf, shown=shown, max_bytes=_v5_budget(max_values))
        check_scene_size(shown, (largest,), "the largest array", max_values)
        try:
            self.shapes = {name: shape for name, shape, _ in whosmat(io.BytesIO(self.buf) if self._file is None else
                                                                     _MapReader(self.buf))}
        except Exception as exc:  # scipy raises several types on a bad file
            raise FileFormatError(shown, f"not a readable MATLAB v5 file ({type(exc).__name__})") from None
        self._loaded = {}

    def names(self):
        return set(self.shapes)

    def get(self, name):
        from scipy.io import loadmat

        if name not in self._loaded:
            stream = io.BytesIO(self.buf) if self._file is None else _MapReader(self.buf)
            try:
                m = loadmat(stream, variable_names=[name], squeeze_me=True, struct_as_record=False)
            except Exception as exc:
                raise FileFormatError(self.shown, f"cannot read variable {name!r} ({type(exc).__name__})") from None
            self._loaded[name] = m[name]
        return self._loaded[name]

    def field(self, obj, name):
        return getattr(obj, name) if name in getattr(obj, "_fieldnames", ()) else None

    def is_struct(self, obj):
        return hasattr(obj, "_fieldnames")

    def text(self, obj):
        """A character variable or field as text, or None."""
        return obj if isinstance(obj, str) else None

    def array(self, obj, what):
        if obj is None:
            return None
        a = np.asarray(obj)
        if a.dtype.kind not in "biuf":
            raise FileFormatError(self.shown, f"{what} holds {_kind(obj)}, expected numbers")
        return a

    def close(self):
        if self._file is not None:
            if isinstance(getattr(self, "buf", None), __import__("mmap").mmap):
                self.buf.close()
            self._file.close()
            self._file = None


class _MapReader(io.RawIOBase):
    """A read-only, seekable binary stream over a memory map (scipy.io reads it as a file)."""

    def __init__(self, buf):
        self._buf, self._pos = buf, 0

    def readable(self):
        return True

    def seekable(self):
        return True

    def readinto(self, b):
        n = min(len(b), max(0, len(self._buf) - self._pos))
        b[:n] = self._buf[self._pos : self._pos + n]
        self._pos += n
        return n

    def seek(self, offset, whence=0):
        self._pos = {0: 0, 1: self._pos, 2: len(self._buf)}[whence] + offset
        return self._pos

    def tell(self):
        return self._pos


def _kind(obj):
    """What a non-numeric variable or field is, in MATLAB's words."""
    if hasattr(obj, "_fieldnames"):
        return "a struct"
    if isinstance(obj, str):
        return "text"
    if hasattr(obj, "dtype"):  # an array or an HDF5 dataset: named without reading it
        return f"{obj.dtype} values"
    return f"{np.asarray(obj).dtype} values"


class _H5:
    """Variables of a v7.3 (HDF5) file, vetted whole by :func:`~camsim_core.io.hdf5.open_hdf5`.

    Opened from memory or a descriptor (never by a name that relative paths
    in the file could resolve against); shapes checked before any dataset
    is read, and each dataset's storage checked again right before reading.
    """

    transposed = True

    def __init__(self, source, shown, max_values):
        self.shown = shown
        self.max_values = max_values
        self._ctx = open_hdf5(source, shown=shown)
        self.f = self._ctx.__enter__()

    def names(self):
        return {k for k in self.f.keys() if not k.startswith("#")}

    def get(self, name):
        return self.f[name] if name in self.f else None

    def field(self, obj, name):
        import h5py

        if isinstance(obj, h5py.Group) and name in obj:
            return obj[name]
        return None

    def is_struct(self, obj):
        import h5py

        return isinstance(obj, h5py.Group)

    def text(self, obj):
        """A MATLAB character array (uint16 codes, ``MATLAB_class`` "char") as text, or None."""
        import h5py

        if not isinstance(obj, h5py.Dataset) or obj.dtype.kind != "u" or obj.size > 4096:
            return None
        if obj.attrs.get("MATLAB_class") not in (b"char", "char"):
            return None
        check_dataset(obj, self.shown)
        return "".join(chr(c) for c in np.asarray(obj[()]).T.ravel().tolist() if 0 < c < 0xD800)

    def array(self, obj, what):
        import h5py

        if obj is None:
            return None
        if not isinstance(obj, h5py.Dataset):
            raise FileFormatError(self.shown, f"{what} is a group (a struct), expected an array")
        if obj.dtype.kind not in "biuf":
            raise FileFormatError(self.shown, f"{what} holds {obj.dtype}, expected numbers")
        check_scene_size(self.shown, obj.shape or (1,), what, self.max_values)
        check_dataset(obj, self.shown)
        return obj[()]

    def close(self):
        if self._ctx is not None:
            self._ctx.__exit__(None, None, None)
            self._ctx = None


def _vector(src, obj, what):
    """A finite float vector, or None when the variable or field is absent."""
    a = src.array(obj, what)
    if a is None:
        return None
    v = np.asarray(a, float).ravel()
    if not np.all(np.isfinite(v)):
        raise FileFormatError(src.shown, f"{what} holds NaN or infinite values")
    return v


def _scalar(src, obj, what, *, positive=False):
    """One finite number (the first of the array), or None when absent or empty."""
    v = _vector(src, obj, what)
    if v is None or v.size == 0:
        return None
    if positive and not v[0] > 0:
        raise FileFormatError(src.shown, f"{what} must be a positive number, got {v[0]:g}")
    return float(v[0])


def _cube(src, obj, n_bands, what):
    """An (H, W, N) numeric cube from a variable, undoing MATLAB's column-major order in v7.3 files."""
    if obj is None:
        raise FileFormatError(src.shown, f"{what} is missing")
    if src.transposed:
        shape = tuple(obj.shape) if hasattr(obj, "shape") else ()
        check_scene_size(src.shown, shape or (0,), what, src.max_values)
        a = src.array(obj, what)
        if a.ndim == 3 and not (n_bands and a.shape[2] == n_bands and a.shape[0] != n_bands):
            a = a.T  # MATLAB's (H, W, N) is stored (N, W, H)
        elif a.ndim == 2:
            a = a.T
    else:
        a = src.array(obj, what)
        check_scene_size(src.shown, a.shape or (0,), what, src.max_values)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise FileFormatError(src.shown, f"{what} must be an (H, W, N) array, got shape {a.shape}")
    return a


def _wavelengths(src, n, default=None):
    for name in _WAVELENGTH_NAMES:
        if name in src.names():
            w = _vector(src, src.get(name), f"variable {name!r}")
            if w.size != n:
                raise FileFormatError(src.shown, f"variable {name!r} has {w.size} wavelengths for {n} bands")
            return w
    if default is not None and default.size == n:
        return default
    raise FileFormatError(src.shown, f"no wavelength variable ({', '.join(_WAVELENGTH_NAMES)}) for the {n} bands")


def _uncompress(src, codes, lo, hi, bits, what):
    """ISETCam's ``ieUncompressData``: ``s / (2^bits - 1) x codes + min``, s = max - min (max when they are equal)."""
    if lo is None or hi is None:
        raise FileFormatError(src.shown, f"integer {what} (ISETCam's compressed form) without its minimum and maximum")
    if not lo <= hi:
        raise FileFormatError(src.shown, f"{what}: minimum {lo:g} above maximum {hi:g}")
    span = hi if lo == hi else hi - lo
    return span / (2.0**bits - 1) * codes.astype(float) + lo


def _check_wavelengths(src, w, what):
    if w.size == 0 or not (np.all(w > 0) and np.all(np.diff(w) > 0)):
        raise FileFormatError(src.shown, f"{what} must be positive wavelengths (nm) in increasing order")
    return w


def _isetcam_illuminant(src, il, what, scene_wave=None):
    """The :class:`Spectrum` (W/sr/m^2 per band) of an ISETCam illuminant struct, and notices.

    The layouts are those of the module docstring. Returns ``(None, [notice])``
    for a spatial-spectral illuminant; anything else that is not an
    illuminant is a :class:`FileFormatError` naming the field.
    """
    if not src.is_struct(il):
        raise FileFormatError(src.shown, f"{what} holds {_kind(il)}, expected an ISETCam illuminant struct")
    data = src.field(il, "data")
    wave = None
    for field, name in ((src.field(src.field(il, "spectrum"), "wave"), "spectrum.wave"),
                        (src.field(il, "wavelength"), "wavelength"), (src.field(il, "wave"), "wave")):
        if field is not None:
            wave = _check_wavelengths(src, _vector(src, field, f"{what}.{name}"), f"{what}.{name}")
            break
    if src.is_struct(data):
        raw = src.array(src.field(data, "photons"), f"{what}.data.photons")
        if raw is None:
            raise FileFormatError(src.shown, f"{what}.data has no photons")
        raw = np.asarray(raw)
        if raw.dtype.kind == "u" and raw.dtype.itemsize in (2, 4):  # illuminantGet's uint16 and uint32 codes
            bits = 8 * raw.dtype.itemsize
            lo = _scalar(src, src.field(data, "min"), f"{what}.data.min")
            hi = _scalar(src, src.field(data, "max"), f"{what}.data.max")
            values = _uncompress(src, raw, lo, hi, bits, f"{what}.data.photons")
        else:
            values = raw.astype(float)
        unit, field = "photons", f"{what}.data.photons"
    elif data is not None:
        values = np.asarray(src.array(data, f"{what}.data"), float)
        unit, field = "energy", f"{what}.data"
    else:
        raise FileFormatError(src.shown, f"{what} has no data (ISETCam keeps data.photons, or energy in data)")
    if wave is None:  # illuminantGet(il, 'wave', scene): a scene's illuminant may use the scene's wavelengths
        wave = scene_wave
    if wave is None:
        raise FileFormatError(src.shown, f"{what} has no wavelengths (spectrum.wave, wavelength or wave)")
    if values.size != wave.size:
        if values.ndim == 3 and values.size % wave.size == 0:
            return None, [f"{field} holds a spatial-spectral illuminant ({values.size // wave.size} spectra); "
                          "it is not kept, so renderings scale by the image"]
        raise FileFormatError(src.shown, f"{field} has {values.size} values for {wave.size} wavelengths")
    values = values.ravel()
    if not np.all(np.isfinite(values)):
        raise FileFormatError(src.shown, f"{field} holds NaN or infinite values")
    if values.min() < 0 or not values.max() > 0:
        raise FileFormatError(src.shown, f"{field} must be non-negative and not all zero "
                                         f"(values {values.min():g}..{values.max():g})")
    per_band = photons_to_radiance(values, wave) if unit == "photons" else per_nm_to_per_band(values, wave)
    return _spectrum(src, wave, per_band, _text_or(src, src.field(il, "name"), "ISETCam illuminant"), what), []


def _text_or(src, obj, default):
    text = src.text(obj) if obj is not None else None
    return text[:256] if text else default


def _file_illuminant(src, label):
    """The illuminant variable of an ISETCam multispectral file, and notices."""
    if "illuminant" not in src.names():
        return None, [f"no illuminant in the ISETCam {label}: renderings scale by the image"]
    return _isetcam_illuminant(src, src.get("illuminant"), "illuminant")


def _isetcam_geometry(src, fov, distance, width, fov_name, distance_name):
    """(angular resolution, distance, notices): the file's, or ISETCam's defaults with a notice."""
    notices = []
    if fov is None:
        fov = ISETCAM_FOV
        notices.append(f"no {fov_name} in the file: ISETCam's default field of view, {ISETCAM_FOV:g} degrees, assumed")
    if distance is None:
        distance = ISETCAM_DISTANCE
        notices.append(f"no {distance_name} in the file: ISETCam's default distance, {ISETCAM_DISTANCE:g} m, assumed")
    return (width / fov,) * 2, distance, notices


def _variable_scalar(src, name, positive=True):
    return _scalar(src, src.get(name), name, positive=positive) if name in src.names() else None


def _isetcam_scene(src, label):
    s = src.get("scene")
    if not src.is_struct(s):
        raise FileFormatError(src.shown, f"variable 'scene' holds {_kind(s)}, expected an ISETCam scene struct")
    data = src.field(s, "data")
    wave = _vector(src, src.field(src.field(s, "spectrum"), "wave"), "scene.spectrum.wave")
    if wave is None:
        raise FileFormatError(src.shown, "ISETCam scene has no spectrum.wave")
    photons = _cube(src, src.field(data, "photons"), wave.size, "scene.data.photons")
    if np.issubdtype(photons.dtype, np.integer):  # ISET's compressed storage
        dmin = _scalar(src, src.field(data, "dmin"), "scene.data.dmin")
        dmax = _scalar(src, src.field(data, "dmax"), "scene.data.dmax")
        depth = _scalar(src, src.field(data, "bitDepth"), "scene.data.bitDepth") or 16
        if dmin is None or dmax is None:
            raise FileFormatError(src.shown, "integer scene.data.photons without data.dmin / data.dmax")
        if not (dmax >= dmin and depth == int(depth) and 1 <= depth <= 32):
            raise FileFormatError(src.shown, f"scene.data: dmin {dmin:g}, dmax {dmax:g}, bitDepth {depth:g}; expected "
                                             "dmin <= dmax and a bit depth of 1 to 32")
        photons = _uncompress(src, photons, dmin, dmax, depth, "scene.data.photons")
    if photons.shape[2] != wave.size:
        raise FileFormatError(src.shown, f"scene.data.photons has {photons.shape[2]} bands for {wave.size} wavelengths")
    ar, distance, notices = _isetcam_geometry(
        src, _scalar(src, src.field(s, "wAngular"), "scene.wAngular", positive=True),
        _scalar(src, src.field(s, "distance"), "scene.distance", positive=True), photons.shape[1],
        "scene.wAngular", "scene.distance")
    il = src.field(s, "illuminant")
    if il is None:
        illum, more = None, ["no illuminant in the ISETCam scene: renderings scale by the image"]
    else:
        illum, more = _isetcam_illuminant(src, il, "scene.illuminant", _check_wavelengths(src, wave, "scene.spectrum.wave"))
    return dict(data=photons_to_radiance(photons, wave), wavelengths=wave, distance=distance, angular_resolution=ar,
                illuminant=illum, name=_text_or(src, src.field(s, "name"), label), notices=notices + more,
                comments="ISETCam scene (photons converted to W/sr/m^2 per band)")


def _spectrum(src, wavelengths, values, name, what):
    """A :class:`Spectrum`, its own checks reported against the file's field."""
    try:
        return Spectrum(wavelengths, values, name)
    except CamsimError as exc:
        raise FileFormatError(src.shown, f"{what}: {exc}") from None


def _isetcam_file_fields(src, photons, wave, label, kind):
    """The scene fields shared by ISETCam's two multispectral files (photons and basis)."""
    ar, distance, notices = _isetcam_geometry(src, _variable_scalar(src, "fov"), _variable_scalar(src, "dist"),
                                              photons.shape[1], "'fov'", "'dist'")
    illum, more = _file_illuminant(src, kind)
    name = _text_or(src, src.get("name"), label) if "name" in src.names() else label
    return dict(data=photons_to_radiance(photons, wave), wavelengths=wave, distance=distance, angular_resolution=ar,
                illuminant=illum, name=name, notices=notices + more,
                comments=f"ISETCam {kind} (photons converted to W/sr/m^2 per band)")


def _isetcam_multispectral(src, label):
    basis = src.get("basis")
    wave = _vector(src, src.field(basis, "wave"), "basis.wave")
    b = src.array(src.field(basis, "basis"), "basis.basis")
    if wave is None or b is None:
        raise FileFormatError(src.shown, "ISETCam multispectral file: 'basis' needs fields 'basis' and 'wave'")
    b = np.atleast_2d(np.asarray(b, float))
    if b.ndim != 2 or not np.all(np.isfinite(b)):
        raise FileFormatError(src.shown, f"basis.basis must be a finite (wavelengths x functions) matrix, got shape {b.shape}")
    if src.transposed:
        b = b.T
    if b.shape[0] != wave.size and b.shape[1] == wave.size:
        b = b.T
    if b.shape[0] != wave.size:
        raise FileFormatError(src.shown, f"basis.basis is {b.shape[0]} x {b.shape[1]} for {wave.size} wavelengths")
    coef = _cube(src, src.get("mcCOEF"), b.shape[1], "mcCOEF")
    if coef.shape[2] != b.shape[1]:
        raise FileFormatError(src.shown, f"mcCOEF has {coef.shape[2]} coefficients per pixel, basis has {b.shape[1]} functions")
    h, w, _ = coef.shape
    check_scene_size(src.shown, (h, w, wave.size), max_values=src.max_values)
    photons = (coef.reshape(-1, coef.shape[2]).astype(float) @ b.T).reshape(h, w, wave.size)
    if "imgMean" in src.names():
        mean = _vector(src, src.get("imgMean"), "imgMean")
        if mean is not None and mean.size == wave.size:
            photons += mean
    return _isetcam_file_fields(src, np.clip(photons, 0.0, None), wave, label,
                                "multispectral file (basis x coefficients)")


def _isetcam_photons_file(src, label):
    var = "photons" if "photons" in src.names() else "data"
    wave_var = "wave" if "wave" in src.names() else "wavelength"
    wave = _vector(src, src.get(wave_var), f"variable {wave_var!r}")
    if wave is None or wave.size == 0:
        raise FileFormatError(src.shown, f"variable {wave_var!r} holds no wavelengths")
    photons = _cube(src, src.get(var), wave.size, f"variable {var!r}")
    if photons.shape[2] != wave.size:
        raise FileFormatError(src.shown, f"variable {var!r} has {photons.shape[2]} bands for {wave.size} wavelengths")
    return _isetcam_file_fields(src, photons, wave, label, "multispectral file (photons)")


def _is_photons_file(src, names):
    """ISETCam's uncompressed file: ``photons`` (or a numeric ``data``) with ``wave`` (or ``wavelength``)."""
    if not ({"wave", "wavelength"} & names):
        return False
    if "photons" in names:
        return True
    return "data" in names and not src.is_struct(src.get("data"))


def _dataset_cube(src, var, dataset, label):
    n = None
    for name in _WAVELENGTH_NAMES:
        if name in src.names():
            n = _vector(src, src.get(name), f"variable {name!r}").size
            break
    default = _HARVARD_WAVELENGTHS if var == "ref" else _ICVL_ARAD_WAVELENGTHS
    cube = _cube(src, src.get(var), n or 31, var)
    wls = _wavelengths(src, cube.shape[2], default)
    notices = [f"{dataset} cube {var!r} has no absolute unit: values taken as W/sr/m^2 per band"]
    if n is None:
        notices.append(f"no wavelength variable: {dataset}'s {default[0]:g}-{default[-1]:g} nm in 10 nm steps assumed")
    return dict(data=cube, wavelengths=wls, distance=None, angular_resolution=None, illuminant=None,
                name=label, comments=f"{dataset} hyperspectral cube", notices=notices)


def read_mat(path, *, negative="error", max_values=None, content=None, shown=None):
    """Read a MATLAB ``.mat`` hyperspectral scene (see the module docstring for the variables).

    Parameters
    ----------
    path : path-like
        The file; with ``content``, only its name (for the label and messages).
    negative : {"error", "clip"}
        What to do with negative radiances.
    max_values : int, optional
        Tighter bound on every array's values (an upload's limit).
    content : bytes, optional
        The file's bytes (an upload): read from memory, no file is opened.
    shown : str, optional
        The name messages give the file (default: ``path`` as given).

    Returns
    -------
    Scene

    Raises
    ------
    FileFormatError
        Naming ``shown``, for any file that is not such a scene, or that
        reaches outside itself (HDF5 external storage, links, virtual
        datasets, plugin filters: :mod:`camsim_core.io.hdf5`).

    Examples
    --------
    >>> import io, numpy as np, scipy.io
    >>> buf = io.BytesIO()
    >>> scipy.io.savemat(buf, {"rad": np.ones((2, 3, 31)), "bands": np.arange(400, 701, 10)})
    >>> read_mat("cube.mat", content=buf.getvalue()).shape
    (2, 3, 31)
    """
    path = Path(path)
    shown = str(path) if shown is None else str(shown)
    source = path if content is None else content
    if content is None:
        check_regular(path, shown)
    src = _H5(source, shown, max_values) if _is_hdf5(source) else _V5(source, shown, max_values)
    try:
        names = src.names()
        label = path.stem
        if "scene" in names:
            fields = _isetcam_scene(src, label)
        elif "mcCOEF" in names and "basis" in names:
            fields = _isetcam_multispectral(src, label)
        elif _is_photons_file(src, names):
            fields = _isetcam_photons_file(src, label)
        else:
            found = [(v, d) for v, d in _CUBES if v in names]
            if not found:
                raise FileFormatError(
                    shown, f"no hyperspectral variable found (variables: {', '.join(sorted(names)) or 'none'}); expected "
                    "'rad' (ICVL), 'cube' (ARAD), 'ref' (Harvard), an ISETCam 'scene' struct, 'mcCOEF' with 'basis', or 'photons' with 'wave'")
            fields = _dataset_cube(src, *found[0], label)
        notices = fields.pop("notices", [])
        return finish_scene(shown, fields.pop("data"), fields.pop("wavelengths"), notices=notices, negative=negative,
                            **fields)
    finally:
        src.close()
