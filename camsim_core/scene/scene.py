"""The hyperspectral scene (chapter section 3, the paragraphs before 3.1)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..spectra import Spectrum

__all__ = ["Scene", "check_radiance", "radiance_dtype", "scale_light", "WAVELENGTH_RANGE", "RadianceClipped"]


class RadianceClipped(UserWarning):
    """Negative radiances were set to 0 (``negative="clip"``); ``note`` says how many, and the lowest.

    Examples
    --------
    >>> RadianceClipped("scene.npz", "2 negative radiance values clipped to 0 (the lowest -1)").note
    '2 negative radiance values clipped to 0 (the lowest -1)'
    """

    def __init__(self, where, note):
        super().__init__(f"{where}: {note}")
        self.note = note


def radiance_dtype(data):
    """The floating dtype a radiance cube keeps: float32 and float64 stay as they are, anything else becomes float64.

    Examples
    --------
    >>> import numpy as np
    >>> radiance_dtype(np.zeros(2, np.float32)), radiance_dtype(np.zeros(2, np.uint16))
    (dtype('float32'), dtype('float64'))
    """
    dt = np.asarray(data).dtype
    return dt if dt in (np.float32, np.float64) else np.dtype(np.float64)


def check_radiance(data, where, negative="error"):
    """Validate a radiance cube: finite everywhere; negatives an error, or clipped with a warning.

    ``negative="clip"`` sets negative values to 0 and warns (:class:`RadianceClipped`) with their count
    and the lowest (calibrated captures and dark-subtracted cubes dip below zero by their noise).
    A float32 cube stays float32 (half the memory of float64, and every
    stage runs in it); other types become float64. The checks run on
    blocks of rows, so they need no full-size temporary.

    Examples
    --------
    >>> import numpy as np
    >>> check_radiance(np.ones((1, 2, 3), np.uint8), "scene").dtype
    dtype('float64')
    >>> check_radiance(np.full((1, 1, 2), -1.0), "scene.npz")
    Traceback (most recent call last):
    ...
    camsim_core.errors.ParameterError: scene.npz: radiance has 2 negative values (min -1); expected non-negative (load with negative='clip' to clip them)
    """
    a = np.asarray(data)
    a = a.astype(radiance_dtype(a), copy=False)
    if a.ndim != 3:
        raise ParameterError(where, f"radiance must be an (H, W, N) array, got shape {a.shape}")
    nonfinite = negatives = 0
    lowest = 0.0
    for block in _row_blocks(a):
        nonfinite += int(np.count_nonzero(~np.isfinite(block)))
        below = int(np.count_nonzero(block < 0))
        if below:
            negatives += below
            lowest = min(lowest, float(block.min()))
    if nonfinite:
        raise ParameterError(where, f"radiance has {nonfinite} NaN or infinite values; expected finite, non-negative values")
    if negatives:
        if negative == "clip":
            warnings.warn(RadianceClipped(where, f"{negatives} negative radiance values clipped to 0 (the lowest "
                                                 f"{lowest:.3g})"), stacklevel=3)
            a = np.where(a < 0, a.dtype.type(0), a)
        else:
            raise ParameterError(
                where, f"radiance has {negatives} negative values (min {lowest:g}); expected non-negative (load with negative='clip' to clip them)"
            )
    return a


def _row_blocks(a, target=1 << 22):
    """Views of ``a`` by blocks of rows of about ``target`` elements."""
    rows = max(1, target // max(1, a[0].size)) if a.shape[0] else 1
    return (a[i : i + rows] for i in range(0, a.shape[0], rows))


#: Wavelengths (nm) a scene may sample: far ultraviolet to thermal infrared. A file claiming 0 nm, a negative
#: wavelength or 2**31 nm is a broken file, not a scene.
WAVELENGTH_RANGE = (100.0, 20000.0)


def _span(w):
    bad = w[~np.isfinite(w) | (w < WAVELENGTH_RANGE[0]) | (w > WAVELENGTH_RANGE[1])]
    return f"{bad.size} outside (e.g. {bad[0]:g})" if bad.size else f"{w.min():g}-{w.max():g}"


@dataclass(frozen=True, eq=False)
class Scene:
    """A calibrated hyperspectral image.

    Attributes
    ----------
    data : ndarray (H, W, N)
        Radiance, W/sr/m^2 per wavelength band of the sampling (see
        :mod:`camsim_core.spectra`). Read-only. float32 stays float32
        (the simulation then runs in single precision), anything else
        becomes float64. A read-only array is kept as it is (no copy).
    wavelengths : ndarray (N,)
        nm, finite, strictly increasing, within :data:`WAVELENGTH_RANGE`.
    distance : float
        m, from the hyperspectral camera to the scene.
    angular_resolution : tuple (x, y)
        Pixels per degree of the camera that took the scene.
    unit : str
    illuminant : Spectrum or None
        The measured scene illuminant, with its own sampling.
    name, comments : str
    notices : tuple of str
        What a reader had to assume (default geometry, unknown units): shown
        to the user beside the scene, never a silent guess.

    Examples
    --------
    A 2 x 3 pixel scene of 31 bands (400-700 nm), as flat as can be:

    >>> import numpy as np
    >>> scene = Scene(np.ones((2, 3, 31)), np.arange(400.0, 701.0, 10.0), distance=2.0, name="flat")
    >>> scene.shape, scene.distance, scene.data.flags.writeable
    ((2, 3, 31), 2.0, False)
    """

    data: np.ndarray
    wavelengths: np.ndarray
    distance: float = 1.0
    angular_resolution: tuple = (57.3, 57.3)
    unit: str = "W/sr/m^2 per band"
    illuminant: Spectrum | None = None
    name: str = ""
    comments: str = ""
    notices: tuple = ()

    def __post_init__(self):
        where = f"scene {self.name!r}" if self.name else "scene"
        data = check_radiance(self.data, where)
        w = np.asarray(self.wavelengths, float).ravel()
        if w.size != data.shape[2]:
            raise ParameterError(f"{where} wavelengths", f"{w.size} wavelengths for {data.shape[2]} planes")
        if not np.all(np.isfinite(w)) or np.any(w < WAVELENGTH_RANGE[0]) or np.any(w > WAVELENGTH_RANGE[1]):
            raise ParameterError(f"{where} wavelengths", f"must be finite, from {WAVELENGTH_RANGE[0]:g} to "
                                                         f"{WAVELENGTH_RANGE[1]:g} nm, got {_span(w)}")
        if w.size > 1 and np.any(np.diff(w) <= 0):
            raise ParameterError(f"{where} wavelengths", "must be strictly increasing")
        if not np.isfinite(self.distance) or self.distance <= 0:
            raise ParameterError(f"{where} distance", f"must be a positive number of metres, got {self.distance}")
        ar = tuple(float(v) for v in np.broadcast_to(np.asarray(self.angular_resolution, float), (2,)))
        if not all(np.isfinite(v) and v > 0 for v in ar):
            raise ParameterError(f"{where} angular_resolution", f"must be positive pixels per degree (x, y), got {ar}")
        data = np.ascontiguousarray(data)
        if data is self.data and data.flags.writeable:
            data = data.copy()  # never freeze or share the caller's own array
        data.flags.writeable = False
        w.flags.writeable = False
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "wavelengths", w)
        object.__setattr__(self, "angular_resolution", ar)
        object.__setattr__(self, "distance", float(self.distance))
        object.__setattr__(self, "notices", tuple(str(n) for n in self.notices))

    @property
    def shape(self):
        """(H, W, N): pixels and wavelength bands.

        Examples
        --------
        >>> import numpy as np
        >>> Scene(np.zeros((2, 3, 4)), [400, 500, 600, 700]).shape
        (2, 3, 4)
        """
        return tuple(self.data.shape)

    def preview(self, max_side=256):
        """sRGB preview (h, w, 3) in [0, 1]: CIE 1931 XYZ of the radiance, its 99th percentile of Y as white.

        Parameters
        ----------
        max_side : int or None
            Longest side of the preview, pixels (block means of the scene's
            pixels); ``None``: the scene's own size.

        Returns
        -------
        ndarray (h, w, 3)
            See :func:`camsim_core.scene.preview.scene_srgb`.

        Examples
        --------
        >>> import numpy as np
        >>> scene = Scene(np.ones((40, 60, 31)), np.arange(400.0, 701.0, 10.0), name="flat")
        >>> scene.preview(max_side=30).shape
        (20, 30, 3)
        """
        from .preview import scene_srgb

        return scene_srgb(self, max_side=max_side)

    def _summary_rows(self):
        h, w, n = self.data.shape
        from ..preview import wavelength_text

        rows = [("name", self.name or "(unnamed)"), ("shape", f"{h} x {w} pixels x {n} bands"),
                ("wavelengths", wavelength_text(self.wavelengths)), ("unit", self.unit),
                ("distance", f"{self.distance:g} m"),
                ("angular resolution", f"{self.angular_resolution[0]:g} x {self.angular_resolution[1]:g} px/deg"),
                ("illuminant", "none" if self.illuminant is None else self.illuminant.name or "known")]
        rows += [("notice", n) for n in self.notices]
        return rows

    def _repr_html_(self):
        """Jupyter's view: an sRGB preview (at most 256 px on its long side) beside the scene's metadata.

        Examples
        --------
        >>> import numpy as np
        >>> out = Scene(np.ones((4, 4, 31)), np.arange(400.0, 701.0, 10.0), name="<flat>")._repr_html_()
        >>> "data:image/png;base64," in out, "&lt;flat&gt;" in out, "<flat>" in out
        (True, True, False)
        """
        from ..preview import PREVIEW_SIDE, summary_html

        rgb = self.preview(PREVIEW_SIDE) if self.data.size else None  # an empty scene: the table alone
        return summary_html(f"Scene {self.name!r}" if self.name else "Scene", rgb, self._summary_rows())

    def _repr_png_(self):
        """PNG bytes of the sRGB preview (at most 256 px on its long side), for Jupyter; None for an empty scene."""
        from ..preview import PREVIEW_SIDE, png_bytes

        return png_bytes(self.preview(PREVIEW_SIDE)) if self.data.size else None

    def describe(self):
        """A dict of the scene's metadata (for ``camsim info`` and the explorer).

        Examples
        --------
        >>> import numpy as np
        >>> info = Scene(np.ones((2, 3, 31)), np.arange(400.0, 701.0, 10.0), name="flat").describe()
        >>> info["size_px"], info["wavelengths_nm"]
        ('2 x 3', '400-700 (31 samples)')
        """
        h, w, n = self.data.shape
        return {
            "name": self.name,
            "kind": "scene",
            "size_px": f"{h} x {w}",
            "planes": n,
            "wavelengths_nm": f"{self.wavelengths[0]:g}-{self.wavelengths[-1]:g} ({n} samples)",
            "distance_m": self.distance,
            "angular_resolution_px_per_deg": {"x": self.angular_resolution[0], "y": self.angular_resolution[1]},
            "unit": self.unit,
            "radiance_range": [float(self.data.min()), float(self.data.max())],
            "illuminant": None if self.illuminant is None else self.illuminant.name or "known",
            "comments": self.comments,
            "notices": list(self.notices),
        }


#: Light levels :func:`scale_light` accepts, as factors of the scene's own.
LIGHT_RANGE = (1e-4, 1e4)


def scale_light(scene, factor):
    """The scene under ``factor`` times its light: radiance and illuminant scaled, reflectances unchanged.

    A dimmer or brighter version of the same scene (a dusk or a sunlit
    version of a room): what matters to a sensor that counts photons, whose
    shot noise, read noise and dark current do not scale with the light.
    ``factor`` is dimensionless, in ``LIGHT_RANGE``; 1 returns ``scene``
    itself. The radiance keeps its dtype.

    Examples
    --------
    >>> import numpy as np
    >>> scene = Scene(np.ones((1, 1, 2)), [500, 600], name="flat")
    >>> dusk = scale_light(scene, 0.01)
    >>> dusk.data.ravel().tolist(), dusk.name
    ([0.01, 0.01], 'flat x0.01 light')
    """
    import dataclasses

    f = float(factor)
    if not (np.isfinite(f) and LIGHT_RANGE[0] <= f <= LIGHT_RANGE[1]):
        raise ParameterError("light", f"must be a factor in [{LIGHT_RANGE[0]:g}, {LIGHT_RANGE[1]:g}], got {factor!r}")
    if f == 1.0:
        return scene
    illuminant = scene.illuminant
    if illuminant is not None:
        illuminant = Spectrum(illuminant.wavelengths, illuminant.values * f, illuminant.name)
    data = scene.data * scene.data.dtype.type(f)
    return dataclasses.replace(scene, data=data, illuminant=illuminant, name=f"{scene.name} x{f:g} light")
