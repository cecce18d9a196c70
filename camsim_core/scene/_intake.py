"""What every scene reader shares: size limits, default geometry with a notice, unit conversion.

* Sizes are checked from a file's header **before** anything is allocated:
  a scene may hold at most :data:`MAX_SCENE_VALUES` radiance values (2 GiB
  as float64).
* Missing geometry gets :data:`DEFAULT_DISTANCE` and
  :data:`DEFAULT_ANGULAR_RESOLUTION`, and the reader says so: a
  :class:`SceneNotice` warning and a line in ``Scene.notices``.
* Radiance ends up in the engine's units, W/sr/m^2 per band of the scene's
  own sampling (see :mod:`camsim_core.spectra`). Photon radiance
  (photons/s/sr/m^2/nm, ISETCam's unit) is converted by E = h c / lambda per
  photon times the band width; spectral radiance per nm by the band width.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import FileFormatError, ParameterError
from ..simulation.sensor import LIGHT_SPEED, PLANCK
from ..spectra import band_width
from .scene import Scene, check_radiance

__all__ = [
    "MAX_SCENE_VALUES",
    "DEFAULT_DISTANCE",
    "DEFAULT_ANGULAR_RESOLUTION",
    "SceneNotice",
    "check_scene_size",
    "photons_to_radiance",
    "per_nm_to_per_band",
    "finish_scene",
]

#: Largest number of radiance values (H x W x N) a reader accepts: 2**28, 2 GiB as float64.
MAX_SCENE_VALUES = 2**28
#: Distance (m) given to a scene whose file does not say.
DEFAULT_DISTANCE = 1.0
#: Angular resolution (x, y) in pixels per degree given to a scene whose file does not say
#: (57.3 px/deg: one pixel per 1/57.3 degree, i.e. about 0.3 mrad; camsim's ``Scene`` default).
DEFAULT_ANGULAR_RESOLUTION = (57.3, 57.3)


class SceneNotice(UserWarning):
    """A reader had to assume something about a scene (geometry, units); also kept in ``Scene.notices``."""


def check_scene_size(path, shape, what="the radiance cube", max_values=None):
    """Refuse a cube whose header promises more than ``max_values`` values (at most :data:`MAX_SCENE_VALUES`), or an empty one.

    ``max_values`` is the caller's tighter bound (an upload's
    :attr:`~camsim_core.io.upload.UploadLimits.max_scene_values`).
    """
    dims = [int(d) for d in shape]
    if not dims or any(d <= 0 for d in dims):
        raise FileFormatError(path, f"{what} has shape {tuple(dims)}; expected positive sizes")
    total = int(np.prod(np.asarray(dims, dtype=object)))
    limit = MAX_SCENE_VALUES if max_values is None else min(int(max_values), MAX_SCENE_VALUES)
    if total > limit:
        raise FileFormatError(
            path,
            f"{what} has shape {tuple(dims)} = {total} values, more than the {limit} allowed"
            + (" (2 GiB as float64); crop or bin it first" if limit == MAX_SCENE_VALUES else ""),
        )
    return total


def photons_to_radiance(photons, wavelengths):
    """Photon radiance (photons/s/sr/m^2/nm) -> W/sr/m^2 per band: x h c / lambda x band width."""
    w = np.asarray(wavelengths, float)
    energy = PLANCK * LIGHT_SPEED / (w * 1e-9)  # J per photon
    return np.asarray(photons, float) * (energy * band_width(w))


def per_nm_to_per_band(values, wavelengths):
    """Spectral radiance per nm -> per band of ``wavelengths`` (x band width, nm)."""
    return np.asarray(values, float) * band_width(wavelengths)


def _warn(path, message, notices):
    notices.append(message)
    warnings.warn(f"{path}: {message}", SceneNotice, stacklevel=4)


def finish_scene(path, data, wavelengths, *, distance=None, angular_resolution=None, illuminant=None,
                 unit="W/sr/m^2 per band", name="", comments="", notices=(), negative="error"):
    """Validate and build the :class:`Scene`, giving missing geometry its default with a notice.

    ``notices`` (messages the reader already has, e.g. about units) are
    warned here together with the geometry ones.
    """
    notes = []
    for message in notices:
        _warn(path, message, notes)
    if distance is None:
        distance = DEFAULT_DISTANCE
        _warn(path, f"no distance in the file: {DEFAULT_DISTANCE:g} m assumed", notes)
    if angular_resolution is None:
        angular_resolution = DEFAULT_ANGULAR_RESOLUTION
        _warn(path, f"no field of view or angular resolution in the file: {DEFAULT_ANGULAR_RESOLUTION[0]:g} px/deg assumed", notes)
    wls = np.asarray(wavelengths, float).ravel()
    cube = np.asarray(data)
    if cube.ndim != 3:
        raise FileFormatError(path, f"the radiance cube must be (H, W, N), got shape {cube.shape}")
    if wls.size != cube.shape[2]:
        raise FileFormatError(path, f"{wls.size} wavelengths for {cube.shape[2]} bands")
    try:
        cube = check_radiance(cube, str(path), negative)
        return Scene(cube, wls, distance, angular_resolution, unit, illuminant, name, comments, tuple(notes))
    except ParameterError as exc:
        raise FileFormatError(path, str(exc)) from None
