"""MATLAB ``.mat`` hyperspectral scenes: v5 (scipy.io) and v7.3 (HDF5, h5py).

Variables recognised, in this order:

* ISETCam scene file: a struct ``scene`` with ``data.photons`` (H x W x N,
  photons/s/sr/m^2/nm; ISET's 16-bit compressed form with ``data.dmin``,
  ``data.dmax`` and ``data.bitDepth`` too), ``spectrum.wave`` (nm),
  ``wAngular`` (horizontal field of view, degrees), ``distance`` (m) and
  ``illuminant`` (``data.photons`` on ``spectrum.wave``);
* ISETCam multispectral file (``ieSaveMultiSpectralImage``): ``mcCOEF``
  (H x W x n basis coefficients), ``basis`` (``basis`` N x n, ``wave``),
  optional ``imgMean`` (N), ``illuminant`` (``wave``, ``data`` in energy
  units), ``fov`` (degrees) and ``dist`` (m); photons = mcCOEF x basis' + imgMean;
* ICVL: ``rad`` with ``bands``; ARAD: ``cube`` with ``bands``; Harvard:
  ``ref``. Without a ``bands``/``wavelengths`` variable, a 31-band cube gets
  its dataset's sampling (ICVL and ARAD 400:10:700 nm, Harvard 420:10:720 nm)
  with a notice.

ISETCam photons are converted to W/sr/m^2 per band. ICVL, ARAD and Harvard
cubes carry no absolute unit: their values are taken as W/sr/m^2 per band
with a notice (auto exposure makes the scale immaterial to a simulation).
Those datasets have no geometry either: defaults with a notice.

Sizes come from the file before anything is allocated: for v7.3 from the
HDF5 dataset shapes; for v5 from a pass over the file's data elements that
counts their uncompressed length (decompressing in bounded chunks and
discarding the output), so that a small compressed file cannot expand into
an unbounded allocation. Nothing is unpickled (MATLAB objects are refused by
scipy's reader).

MATLAB stores arrays column-major; HDF5 (v7.3) files therefore hold an
H x W x N cube as (N, W, H). A v7.3 cube whose *last* axis is the band axis
(written from Python) is taken as it is.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import FileFormatError
from ..io.files import check_regular
from ..spectra import Spectrum, sampling_wavelengths
from ._intake import MAX_SCENE_VALUES, check_scene_size, finish_scene, photons_to_radiance

__all__ = ["read_mat"]

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Largest uncompressed payload of a v5 file: the largest scene as float64, plus 64 MiB for the rest.
MAX_V5_BYTES = MAX_SCENE_VALUES * 8 + 64 * 2**20
_HARVARD_WAVELENGTHS = sampling_wavelengths(420, 10, 31)
_ICVL_ARAD_WAVELENGTHS = sampling_wavelengths(400, 10, 31)
_CUBES = (("rad", "ICVL"), ("cube", "ARAD"), ("ref", "Harvard"))
_WAVELENGTH_NAMES = ("bands", "wavelengths", "wavelength", "wave", "wl")


def _is_hdf5(path):
    with open(path, "rb") as f:
        head = f.read(2048 + 8)
    return any(head[o : o + 8] == _HDF5_SIGNATURE for o in (0, 512, 1024, 2048))


def _v5_uncompressed_bytes(path):
    """Uncompressed length of a v5 file's data elements, refusing more than :data:`MAX_V5_BYTES`."""
    total = 0
    with open(path, "rb") as f:
        header = f.read(128)
        if len(header) < 128 or not header.startswith(b"MATLAB"):
            raise FileFormatError(path, "not a MATLAB .mat file (no 'MATLAB' header)")
        order = "<" if header[126:128] == b"IM" else ">"
        while True:
            tag = f.read(8)
            if len(tag) < 8:
                break
            dtype, nbytes = struct.unpack(order + "II", tag)
            if dtype == 15:  # miCOMPRESSED: a zlib stream holding one data element
                d = zlib.decompressobj()
                left = nbytes
                while left > 0:
                    chunk = f.read(min(left, 1 << 20))
                    if not chunk:
                        raise FileFormatError(path, "truncated compressed variable")
                    left -= len(chunk)
                    data = chunk
                    while data:
                        try:
                            out = d.decompress(data, 1 << 24)
                        except zlib.error as exc:
                            raise FileFormatError(path, f"corrupt compressed variable ({exc})") from None
                        total += len(out)
                        data = d.unconsumed_tail
                        if total > MAX_V5_BYTES:
                            raise FileFormatError(path, f"variables expand to more than {MAX_V5_BYTES} bytes; too large a scene")
            else:
                total += nbytes
                f.seek(nbytes + (-nbytes % 8), 1)
            if total > MAX_V5_BYTES:
                raise FileFormatError(path, f"variables hold more than {MAX_V5_BYTES} bytes; too large a scene")
    return total


class _V5:
    """Variables of a v5 file, read on demand with scipy.io.loadmat (structs as attribute objects)."""

    transposed = False
    max_values = None

    def __init__(self, path):
        from scipy.io import whosmat

        self.path = path
        _v5_uncompressed_bytes(path)
        try:
            self.shapes = {name: shape for name, shape, _ in whosmat(str(path))}
        except Exception as exc:  # scipy raises several types on a bad file
            raise FileFormatError(path, f"not a readable MATLAB v5 file ({exc})") from None
        self._loaded = {}

    def names(self):
        return set(self.shapes)

    def get(self, name):
        from scipy.io import loadmat

        if name not in self._loaded:
            try:
                m = loadmat(str(self.path), variable_names=[name], squeeze_me=True, struct_as_record=False)
            except Exception as exc:
                raise FileFormatError(self.path, f"cannot read variable {name!r} ({exc})") from None
            self._loaded[name] = m[name]
        return self._loaded[name]

    def field(self, obj, name):
        return getattr(obj, name, None) if obj is not None else None

    def array(self, obj):
        return None if obj is None else np.asarray(obj)


class _H5:
    """Variables of a v7.3 (HDF5) file through h5py; shapes checked before any dataset is read."""

    transposed = True
    max_values = None

    def __init__(self, path):
        import h5py

        self.path = path
        try:
            self.f = h5py.File(str(path), "r")
        except Exception as exc:
            raise FileFormatError(path, f"not a readable MATLAB v7.3 (HDF5) file ({exc})") from None

    def names(self):
        return {k for k in self.f.keys() if not k.startswith("#")}

    def get(self, name):
        return self.f[name] if name in self.f else None

    def field(self, obj, name):
        import h5py

        if isinstance(obj, h5py.Group) and name in obj:
            return obj[name]
        return None

    def array(self, obj):
        import h5py

        if obj is None:
            return None
        if not isinstance(obj, h5py.Dataset):
            raise FileFormatError(self.path, f"{obj.name} is a group, expected an array")
        if obj.dtype.kind not in "biuf":
            raise FileFormatError(self.path, f"{obj.name} holds {obj.dtype}, expected numbers")
        check_scene_size(self.path, obj.shape or (1,), obj.name, self.max_values)
        return obj[()]

    def close(self):
        self.f.close()


def _vector(src, obj):
    a = src.array(obj)
    return None if a is None else np.asarray(a, float).ravel()


def _scalar(src, obj):
    v = _vector(src, obj)
    return None if v is None or v.size == 0 else float(v[0])


def _cube(src, obj, n_bands, what):
    """An (H, W, N) float cube from a variable, undoing MATLAB's column-major order in v7.3 files."""
    if obj is None:
        raise FileFormatError(src.path, f"{what} is missing")
    if src.transposed:
        shape = tuple(obj.shape) if hasattr(obj, "shape") else ()
        check_scene_size(src.path, shape or (0,), what, src.max_values)
        a = src.array(obj)
        if a.ndim == 3 and not (n_bands and a.shape[2] == n_bands and a.shape[0] != n_bands):
            a = a.T  # MATLAB's (H, W, N) is stored (N, W, H)
        elif a.ndim == 2:
            a = a.T
    else:
        a = src.array(obj)
        check_scene_size(src.path, a.shape or (0,), what, src.max_values)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or not np.issubdtype(a.dtype, np.number):
        raise FileFormatError(src.path, f"{what} must be a numeric (H, W, N) array, got shape {a.shape} of {a.dtype}")
    return a


def _wavelengths(src, n, default=None, what="wavelengths"):
    for name in _WAVELENGTH_NAMES:
        if name in src.names():
            w = _vector(src, src.get(name))
            if w.size != n:
                raise FileFormatError(src.path, f"variable {name!r} has {w.size} wavelengths for {n} bands")
            return w
    if default is not None and default.size == n:
        return default
    raise FileFormatError(src.path, f"no wavelength variable ({', '.join(_WAVELENGTH_NAMES)}) for the {n} bands")


def _isetcam_scene(src, label):
    s = src.get("scene")
    data = src.field(s, "data")
    wave = _vector(src, src.field(src.field(s, "spectrum"), "wave"))
    if wave is None:
        raise FileFormatError(src.path, "ISETCam scene has no spectrum.wave")
    photons = _cube(src, src.field(data, "photons"), wave.size, "scene.data.photons")
    if np.issubdtype(photons.dtype, np.integer):  # ISET's compressed storage
        dmin, dmax = _scalar(src, src.field(data, "dmin")), _scalar(src, src.field(data, "dmax"))
        depth = _scalar(src, src.field(data, "bitDepth")) or 16
        if dmin is None or dmax is None:
            raise FileFormatError(src.path, "integer scene.data.photons without data.dmin / data.dmax")
        photons = dmin + (dmax - dmin) * photons.astype(float) / (2.0**depth - 1)
    if photons.shape[2] != wave.size:
        raise FileFormatError(src.path, f"scene.data.photons has {photons.shape[2]} bands for {wave.size} wavelengths")
    fov = _scalar(src, src.field(s, "wAngular"))
    ar = None if not fov else (photons.shape[1] / fov,) * 2
    illum = None
    il = src.field(s, "illuminant")
    if il is not None:
        ip = _vector(src, src.field(src.field(il, "data"), "photons"))
        iw = _vector(src, src.field(src.field(il, "spectrum"), "wave"))
        if ip is not None and iw is not None and ip.size == iw.size:
            illum = Spectrum(iw, photons_to_radiance(ip, iw), "ISETCam illuminant")
    name = src.field(s, "name")
    return dict(data=photons_to_radiance(photons, wave), wavelengths=wave, distance=_scalar(src, src.field(s, "distance")),
                angular_resolution=ar, illuminant=illum, name=str(name) if isinstance(name, str) else label,
                comments="ISETCam scene (photons converted to W/sr/m^2 per band)")


def _isetcam_multispectral(src, label):
    basis = src.get("basis")
    wave = _vector(src, src.field(basis, "wave"))
    b = src.array(src.field(basis, "basis"))
    if wave is None or b is None:
        raise FileFormatError(src.path, "ISETCam multispectral file: 'basis' needs fields 'basis' and 'wave'")
    b = np.atleast_2d(np.asarray(b, float))
    if src.transposed:
        b = b.T
    if b.shape[0] != wave.size and b.shape[1] == wave.size:
        b = b.T
    coef = _cube(src, src.get("mcCOEF"), b.shape[1], "mcCOEF")
    if coef.shape[2] != b.shape[1]:
        raise FileFormatError(src.path, f"mcCOEF has {coef.shape[2]} coefficients per pixel, basis has {b.shape[1]} functions")
    h, w, _ = coef.shape
    check_scene_size(src.path, (h, w, wave.size), max_values=src.max_values)
    photons = (coef.reshape(-1, coef.shape[2]).astype(float) @ b.T).reshape(h, w, wave.size)
    if "imgMean" in src.names():
        mean = _vector(src, src.get("imgMean"))
        if mean is not None and mean.size == wave.size:
            photons += mean
    fov = _scalar(src, src.get("fov")) if "fov" in src.names() else None
    illum = None
    if "illuminant" in src.names():
        il = src.get("illuminant")
        iw, idata = _vector(src, src.field(il, "wave")), _vector(src, src.field(il, "data"))
        if iw is not None and idata is not None and iw.size == idata.size:
            illum = Spectrum(iw, idata, "ISETCam illuminant (energy units)")
    return dict(data=photons_to_radiance(np.clip(photons, 0.0, None), wave), wavelengths=wave,
                distance=_scalar(src, src.get("dist")) if "dist" in src.names() else None,
                angular_resolution=None if not fov else (w / fov,) * 2, illuminant=illum, name=label,
                comments="ISETCam multispectral file (basis x coefficients, photons converted to W/sr/m^2 per band)")


def _dataset_cube(src, var, dataset, label):
    n = None
    for name in _WAVELENGTH_NAMES:
        if name in src.names():
            n = _vector(src, src.get(name)).size
            break
    default = _HARVARD_WAVELENGTHS if var == "ref" else _ICVL_ARAD_WAVELENGTHS
    cube = _cube(src, src.get(var), n or 31, var)
    wls = _wavelengths(src, cube.shape[2], default)
    notices = [f"{dataset} cube {var!r} has no absolute unit: values taken as W/sr/m^2 per band"]
    if n is None:
        notices.append(f"no wavelength variable: {dataset}'s {default[0]:g}-{default[-1]:g} nm in 10 nm steps assumed")
    return dict(data=cube.astype(float), wavelengths=wls, distance=None, angular_resolution=None, illuminant=None,
                name=label, comments=f"{dataset} hyperspectral cube", notices=notices)


def read_mat(path, *, negative="error", max_values=None):
    """Read a MATLAB ``.mat`` hyperspectral scene (see the module docstring for the variables).

    ``max_values`` tightens the bound on every array's size.
    """
    path = Path(path)
    check_regular(path)
    src = _H5(path) if _is_hdf5(path) else _V5(path)
    src.max_values = max_values
    try:
        names = src.names()
        label = path.stem
        if "scene" in names:
            fields = _isetcam_scene(src, label)
        elif "mcCOEF" in names and "basis" in names:
            fields = _isetcam_multispectral(src, label)
        else:
            found = [(v, d) for v, d in _CUBES if v in names]
            if not found:
                raise FileFormatError(
                    path, f"no hyperspectral variable found (variables: {', '.join(sorted(names)) or 'none'}); expected "
                    "'rad' (ICVL), 'cube' (ARAD), 'ref' (Harvard), an ISETCam 'scene' struct, or 'mcCOEF' with 'basis'")
            fields = _dataset_cube(src, *found[0], label)
    finally:
        if isinstance(src, _H5):
            src.close()
    notices = fields.pop("notices", [])
    return finish_scene(path, fields.pop("data"), fields.pop("wavelengths"), notices=notices, negative=negative, **fields)
