"""The camera image: data plus the metadata that the next stage needs.

One structure travels the whole pipeline (chapter section 3, and 4.1: "there
is no formal distinction between routines that simulate camera function and
routines that apply processing operations to camera data"). Its ``data`` is

* ``(H, W, N)`` spectral planes while ``sensitivities`` is ``None`` (the image
  right after it leaves the scene, before the sensor stage: a blur per
  wavelength can act here);
* ``(H, W, K)`` one plane per sensor class after the sensor stage, or after
  demosaicing;
* ``(H, W)`` one mosaic plane plus its ``tile`` after the mosaic stage (as a
  raw file holds it), or ``(H, W, T)`` for a tile with ``T`` tiers (a
  field-sequential design);
* ``(H, W, 3)`` linear monitor settings or 8-bit monitor values after
  rendering (``space`` says which).

Images are immutable: every stage returns a new one (``image.replace(...)``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .errors import ParameterError
from .spectra import Spectrum

__all__ = ["CameraImage", "image_from_scene", "check_tile", "subtract_black_level"]

#: What ``CameraImage.space`` may be.
SPACES = ("spectral", "sensor", "monitor-linear", "monitor")


def check_tile(tile, n_sensors, name="mosaic"):
    """Validate a mosaic tile: an integer array (n, m) or (n, m, tiers) of 0-based sensor indices.

    Examples
    --------
    >>> check_tile([[1, 0], [2, 1]], 3).tolist()
    [[1, 0], [2, 1]]
    >>> check_tile([[0, 3]], 3)
    Traceback (most recent call last):
    ...
    camsim_core.errors.ParameterError: mosaic: tile names sensor index 3, but the camera has 3 sensors (valid indices 0..2)
    """
    if tile is None:
        return None
    t = np.asarray(tile)
    if t.ndim not in (2, 3) or t.size == 0:
        raise ParameterError(name, f"a tile must be a 2-D (rows, cols) or 3-D (rows, cols, tiers) array, got shape {t.shape}")
    if not np.issubdtype(t.dtype, np.integer):
        if not np.all(np.equal(np.mod(t, 1), 0)):
            raise ParameterError(name, "tile entries must be integer sensor indices")
        t = t.astype(int)
    bad = (t < 0) | (t >= n_sensors)
    if bad.any():
        raise ParameterError(
            name,
            f"tile names sensor index {int(t[bad].flat[0])}, but the camera has {n_sensors} "
            f"sensors (valid indices 0..{n_sensors - 1})",
        )
    t = np.array(t, dtype=np.intp)
    t.flags.writeable = False
    return t


@dataclass(frozen=True, eq=False)
class CameraImage:
    """Image data and its description, as it passes through simulation and processing.

    Attributes
    ----------
    data : ndarray
        See the module docstring for its shapes.
    wavelengths : ndarray (N,)
        nm. The sampling of the spectral planes, or of ``sensitivities``.
    sensitivities : ndarray (K, N) or None
        Sensor spectral sensitivities on ``wavelengths``; ``None`` while the
        data are still spectral planes.
    sensor_names : tuple of str
    tile : ndarray (n, m) or (n, m, tiers) of int, or None
        The mosaic tile (0-based sensor indices, the tile's top-left at pixel
        (0, 0)). Kept after demosaicing so processing knows the sampling.
    exposure : float
        s.
    f_stop : float
    distance : float
        m, from camera to scene.
    angular_resolution : tuple (x, y)
        Pixels per degree.
    bits : int or None
        Quantization depth; ``None`` for an unquantized image.
    gain : float
        Digital units per unit of ``sensitivities @ radiance``: the exposure
        and f-stop scaling of the sensor stage. Processing divides it out to
        compare images taken at different settings.
    noise_sigma : float
        Standard deviation (digital units) of the noise added; processing
        such as Bayesian demosaicing uses it in its likelihood.
    black_level : float or tuple of float
        Pedestal (digital units) that ``data`` still holds: every value is
        the signal plus this offset; one value for every sensor class, or one
        per sensor class (a real raw's per-channel black levels). Processing
        subtracts it (:func:`subtract_black_level`) and sets it to 0.
    mosaiced, quantized : bool
    illuminant : Spectrum or None
        The scene illuminant, carried along for balancing.
    space : str
        One of ``"spectral"``, ``"sensor"``, ``"monitor-linear"``, ``"monitor"``.
    unit : str
    history : tuple of str
        Names of the stages applied so far, in order.
    name : str

    Examples
    --------
    An unquantized 2 x 2 image of three sensor planes:

    >>> import numpy as np
    >>> w = np.arange(400.0, 701.0, 10.0)
    >>> image = CameraImage(np.ones((2, 2, 3)), w, np.ones((3, w.size)), ("R", "G", "B"), name="flat")
    >>> image.shape, image.n_sensors, image.full_scale
    ((2, 2), 3, None)
    >>> image.then("noise", noise_sigma=2.0).history
    ('noise',)
    """

    data: np.ndarray
    wavelengths: np.ndarray
    sensitivities: np.ndarray | None = None
    sensor_names: tuple = ()
    tile: np.ndarray | None = None
    exposure: float = 1.0
    f_stop: float = 1.0
    distance: float = 1.0
    angular_resolution: tuple = (1.0, 1.0)
    bits: int | None = None
    gain: float = 1.0
    noise_sigma: float = 0.0
    black_level: float | tuple = 0.0
    mosaiced: bool = False
    quantized: bool = False
    illuminant: Spectrum | None = None
    space: str = "sensor"
    unit: str = ""
    history: tuple = ()
    name: str = ""
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.space not in SPACES:
            raise ParameterError("space", f"must be one of {SPACES}, got {self.space!r}")
        ax, ay = (float(v) for v in self.angular_resolution)
        object.__setattr__(self, "angular_resolution", (ax, ay))

    # -- convenience -------------------------------------------------------
    @property
    def n_sensors(self):
        """Number of sensor classes (0 while the image is spectral)."""
        return 0 if self.sensitivities is None else int(np.shape(self.sensitivities)[0])

    @property
    def shape(self):
        """(H, W) of the image."""
        return tuple(self.data.shape[:2])

    @property
    def full_scale(self):
        """Largest digital value: 2**bits - 1, or ``None`` when unquantized."""
        return None if self.bits is None else float(2 ** self.bits - 1)

    def replace(self, **changes):
        """A new image with ``changes`` applied and nothing else touched."""
        return dataclasses.replace(self, **changes)

    def then(self, stage_name, **changes):
        """A new image with ``changes`` and ``stage_name`` appended to the history."""
        return dataclasses.replace(self, history=self.history + (stage_name,), **changes)

    def preview(self, max_side=256):
        """sRGB preview (h, w, 3) in [0, 1] of the image, as its ``space`` is shown (see :mod:`camsim_core.preview`).

        Parameters
        ----------
        max_side : int or None
            Longest side of the preview, pixels (block means of the image's
            pixels); ``None``: the image's own size.

        Returns
        -------
        ndarray (h, w, 3)

        Examples
        --------
        Rendered 8-bit monitor settings are shown as they are:

        >>> import numpy as np
        >>> image = CameraImage(np.full((2, 2, 3), 255.0), np.array([]), space="monitor")
        >>> image.preview()[0, 0].tolist()
        [1.0, 1.0, 1.0]
        """
        from .preview import image_srgb

        return image_srgb(self, max_side=max_side)

    def _summary_rows(self):
        from .preview import wavelength_text

        shape = " x ".join(str(v) for v in self.data.shape)
        rows = [("name", self.name or "(unnamed)"), ("shape", shape), ("space", self.space),
                ("wavelengths", wavelength_text(self.wavelengths)), ("unit", self.unit or "digital values")]
        if self.sensor_names:
            rows.append(("sensors", ", ".join(str(n) for n in self.sensor_names)))
        if self.mosaiced and self.tile is not None:
            rows.append(("mosaic tile", "; ".join(" ".join(str(v) for v in r) for r in np.asarray(self.tile).tolist())))
        rows += [("bits", "unquantized" if self.bits is None else self.bits),
                 ("exposure", f"{self.exposure:g} s, f/{self.f_stop:g}"),
                 ("history", " > ".join(str(h) for h in self.history) or "none")]
        return rows

    def _repr_html_(self):
        """Jupyter's view: an sRGB preview (at most 256 px on its long side) beside the image's metadata.

        Examples
        --------
        >>> import numpy as np
        >>> out = CameraImage(np.zeros((2, 2, 3)), np.array([]), space="monitor", name="a<b")._repr_html_()
        >>> "data:image/png;base64," in out, "a&lt;b" in out, "a<b" in out
        (True, True, False)
        """
        from .preview import PREVIEW_SIDE, summary_html

        kind = {"spectral": "Spectral image", "sensor": "Camera image",
                "monitor-linear": "Rendered image (linear)", "monitor": "Rendered image"}[self.space]
        if self.space == "sensor" and self.mosaiced:
            kind = "Raw camera image"
        title = f"{kind} {self.name!r}" if self.name else kind
        try:
            rgb = self.preview(PREVIEW_SIDE)
        except (ValueError, TypeError, IndexError):  # an image no preview can show (empty, 4-D): the table alone
            rgb = None
        return summary_html(title, rgb, self._summary_rows())

    def _repr_png_(self):
        """PNG bytes of the sRGB preview (at most 256 px on its long side), for Jupyter; None when there is none."""
        from .preview import PREVIEW_SIDE, png_bytes

        try:
            return png_bytes(self.preview(PREVIEW_SIDE))
        except (ValueError, TypeError, IndexError):  # empty or of a shape no preview shows
            return None

    def metadata(self):
        """JSON-serializable description (everything but the data).

        Examples
        --------
        >>> import numpy as np
        >>> meta = CameraImage(np.zeros((2, 2)), np.array([550.0]), bits=10).metadata()
        >>> meta["shape"], meta["bits"], meta["wavelengths"]
        ([2, 2], 10, [550.0])
        """
        return {
            "name": self.name,
            "shape": list(self.data.shape),
            "space": self.space,
            "unit": self.unit,
            "sensor_names": list(self.sensor_names),
            "wavelengths": [float(w) for w in self.wavelengths],
            "sensitivities": None if self.sensitivities is None else np.asarray(self.sensitivities).tolist(),
            "tile": None if self.tile is None else np.asarray(self.tile).tolist(),
            "exposure_s": self.exposure,
            "f_stop": self.f_stop,
            "distance_m": self.distance,
            "angular_resolution_px_per_deg": list(self.angular_resolution),
            "bits": self.bits,
            "gain": self.gain,
            "noise_sigma": self.noise_sigma,
            "black_level": self.black_level if np.isscalar(self.black_level) else list(self.black_level),
            "mosaiced": self.mosaiced,
            "quantized": self.quantized,
            "illuminant": None
            if self.illuminant is None
            else {"wavelengths": self.illuminant.wavelengths.tolist(), "values": self.illuminant.values.tolist()},
            "history": list(self.history),
        }


def subtract_black_level(image):
    """The image without its pedestal: ``data - black_level`` (floating point, signed), ``black_level`` 0.

    Values below the pedestal stay negative: the noise around black is what
    the sensor measured, and clipping it at 0 (as dcraw does before
    demosaicing) would bias every dark pixel upwards (a dark frame with a
    64 DN pedestal and 8 DN noise, demosaiced, had a mean of +3.1 DN instead
    of 0) and shrink its noise. Processing (demosaicing, balancing, metrics,
    SNR) keeps the signed values; only a display or a file format clips.
    The ADC's own clip (a raw value of 0 or the full scale) stays where the
    sensor put it. The result keeps ``extra["saturation"]``: the level
    (after subtraction, per sensor class when the pedestal is) at which the
    raw clipped, ``full_scale - black_level`` (``None`` when unquantized).
    An image without a pedestal is returned as it is.

    Examples
    --------
    A 10-bit raw with a pedestal of 64: a dark pixel 2 DN below it stays negative.

    >>> import numpy as np
    >>> raw = CameraImage(np.array([[62.0, 1023.0]]), np.array([550.0]), bits=10, black_level=64.0)
    >>> out = subtract_black_level(raw)
    >>> out.data.tolist(), out.black_level, out.extra["saturation"]
    ([[-2.0, 959.0]], 0.0, 959.0)
    """
    black = np.asarray(image.black_level, float)
    if not np.any(black):
        return image
    data = np.asarray(image.data, float)
    if black.ndim:  # one per sensor class
        if image.mosaiced and image.tile is not None:
            from .simulation.mosaic import tile_index_map

            black = black[tile_index_map(image.tile, data.shape[:2])]
            black = black if black.shape == data.shape else black.reshape(data.shape)
        elif data.ndim != 3 or data.shape[2] != black.size:
            raise ParameterError("black_level", f"{black.size} per-class values for an image of shape {data.shape}")
    data = data - black
    extra = dict(image.extra)
    if image.full_scale is not None and "saturation" not in extra:
        level = image.full_scale - np.asarray(image.black_level, float)
        extra["saturation"] = float(level) if level.ndim == 0 else tuple(float(v) for v in level)
    return image.replace(data=data, black_level=0.0, extra=extra, history=image.history + ("subtract_black_level",))


def image_from_scene(scene):
    """The scene as the pipeline's first image: spectral planes with the scene's geometry.

    Examples
    --------
    >>> import numpy as np
    >>> from camsim_core.scene import Scene
    >>> image = image_from_scene(Scene(np.ones((2, 3, 31)), np.arange(400.0, 701.0, 10.0), name="flat"))
    >>> image.space, image.data.shape, image.history
    ('spectral', (2, 3, 31), ('scene',))
    """
    return CameraImage(
        data=scene.data,
        wavelengths=scene.wavelengths,
        sensitivities=None,
        sensor_names=(),
        distance=scene.distance,
        angular_resolution=scene.angular_resolution,
        illuminant=scene.illuminant,
        space="spectral",
        unit=scene.unit,
        history=("scene",),
        name=scene.name,
    )
