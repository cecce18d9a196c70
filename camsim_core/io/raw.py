"""Wrapping real raw mosaics as camera images, so that real raws go through the same processing.

* :func:`raw_from_array` - any mosaic array plus its tile;
* :func:`read_dcs200_raw` - a Kodak DCS-200 raw TIFF (8-bit Bayer mosaic, as
  shipped in ``assets/simtoolbox/DCS200TestIR``), with the camera's
  sensitivities and geometry from ``kodak-dcs200-ir``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FileFormatError, ParameterError
from ..image import CameraImage, check_tile
from ..spectra import Spectrum

__all__ = ["raw_from_array", "read_dcs200_raw"]

_FIELDS = ("exposure", "f_stop", "distance", "angular_resolution", "gain", "noise_sigma", "name", "unit", "extra")


def _tile(tile, k):
    if isinstance(tile, str):
        from ..simulation import bayer

        return check_tile(bayer(tile.upper()), 3, "tile")
    return check_tile(tile, k if k else int(np.max(tile)) + 1, "tile")


def _black_level(value, k):
    """A validated black level: one float, or a tuple of ``k`` (one per sensor class)."""
    try:
        b = np.asarray(value, float)
    except (TypeError, ValueError):
        b = np.array(np.nan)
    if b.ndim > 1 or (b.ndim == 1 and b.size != k) or not np.all(np.isfinite(b)) or np.any(b < 0):
        raise ParameterError("black_level", f"must be a finite number >= 0 of digital units, or {k} of them (one per sensor class); got {value!r}")
    return float(b) if b.ndim == 0 else tuple(float(v) for v in b)


def raw_from_array(array, tile, *, sensitivities=None, wavelengths=None, sensor_names=None, bits="auto",
                   illuminant=None, black_level=0.0, **metadata):
    """A mosaiced :class:`~camsim_core.image.CameraImage` from a raw array.

    Parameters
    ----------
    array : array_like (H, W), or (H, W, T) for a tiered tile
        Raw values in digital units.
    tile : array_like (n, m) or (n, m, T) of 0-based sensor indices, or a Bayer phase name
        (``"GRBG"``, ``"RGGB"``, ``"BGGR"``, ``"GBRG"``, with R, G, B = 0, 1, 2).
    sensitivities : Sensors, or array (K, N) with ``wavelengths``, optional
        Needed for rendering; demosaicing works without.
    sensor_names : sequence of str, optional
    bits : int, None or "auto"
        "auto": 8 for uint8 data, 16 for uint16, else None (unquantized).
    illuminant : Spectrum, optional
        The scene illuminant, if known, for illuminant-based rendering.
    black_level : float, or one float per sensor class
        The raw's pedestal, digital units (>= 0): carried in the image's
        ``black_level`` and subtracted by processing (``demosaic``, ``render``,
        values clipped at 0) as a raw converter does; the data keep it. A
        real raw's pedestal left in would render as a coloured cast.
    **metadata
        Any of ``exposure`` (s), ``f_stop``, ``distance`` (m),
        ``angular_resolution`` (x, y px/deg), ``gain`` (digital units per unit
        of sensitivities @ radiance), ``noise_sigma`` (DU), ``name``, ``unit``, ``extra``.

    Examples
    --------
    >>> import numpy as np
    >>> raw = raw_from_array(np.zeros((4, 6), np.uint16), "RGGB", black_level=64)
    >>> raw.shape, raw.bits, raw.tile.tolist(), raw.black_level
    ((4, 6), 16, [[0, 1], [1, 2]], 64.0)
    """
    unknown = sorted(set(metadata) - set(_FIELDS))
    if unknown:
        raise ParameterError("metadata", f"unknown field(s) {unknown}; valid: {', '.join(_FIELDS)}")
    a = np.asarray(array)
    if a.ndim not in (2, 3) or a.size == 0:
        raise ParameterError("array", f"a raw mosaic must be (H, W) or (H, W, tiers), got shape {a.shape}")
    if not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise ParameterError("array", f"must hold numbers, got dtype {a.dtype}")
    if bits == "auto":
        bits = {np.dtype(np.uint8): 8, np.dtype(np.uint16): 16}.get(a.dtype)
    wls = None
    sens = None
    if sensitivities is not None:
        if hasattr(sensitivities, "values") and hasattr(sensitivities, "wavelengths"):
            wls, sens = np.asarray(sensitivities.wavelengths, float), np.asarray(sensitivities.values, float)
            sensor_names = sensor_names or tuple(sensitivities.names)
        else:
            if wavelengths is None:
                raise ParameterError("wavelengths", "needed with a sensitivity array (K, N)")
            wls, sens = np.asarray(wavelengths, float).ravel(), np.atleast_2d(np.asarray(sensitivities, float))
            if sens.shape[1] != wls.size:
                raise ParameterError("sensitivities", f"must be (K, {wls.size}) to match the wavelengths, got {sens.shape}")
    k = 0 if sens is None else sens.shape[0]
    t = _tile(tile, k)
    if t.ndim == 3 and (a.ndim != 3 or a.shape[2] != t.shape[2]):
        raise ParameterError("array", f"a tile with {t.shape[2]} tiers needs (H, W, {t.shape[2]}) data, got {a.shape}")
    if t.ndim == 2 and a.ndim != 2:
        raise ParameterError("array", f"a 2-D tile needs (H, W) data, got {a.shape}")
    if not k:
        k = int(t.max()) + 1
    if sensor_names is None:
        sensor_names = ("R", "G", "B") if k == 3 else tuple(f"S{i + 1}" for i in range(k))
    if len(sensor_names) != k:
        raise ParameterError("sensor_names", f"{len(sensor_names)} names for {k} sensor classes")
    if illuminant is not None and not isinstance(illuminant, Spectrum):
        raise ParameterError("illuminant", "must be a Spectrum")
    fields = dict(unit="digital units", name="raw")
    fields.update(metadata)
    if "angular_resolution" in fields:
        fields["angular_resolution"] = tuple(fields["angular_resolution"])
    black = _black_level(black_level, k)
    data = a.astype(float)
    return CameraImage(
        data=data,
        wavelengths=np.zeros(0) if wls is None else wls,
        sensitivities=sens,
        sensor_names=tuple(sensor_names),
        tile=t,
        bits=bits,
        black_level=black,
        mosaiced=True,
        quantized=bits is not None and np.issubdtype(a.dtype, np.integer),
        illuminant=illuminant,
        space="sensor",
        history=("raw",),
        **fields,
    )


def read_dcs200_raw(path, *, camera="kodak-dcs200-ir", exposure=0.1, f_stop=11.0, distance=3.32, illuminant=None,
                    black_level=0.0):
    """Read a Kodak DCS-200 raw TIFF (one 8-bit plane, a GR/BG Bayer mosaic) as a camera image.

    The sensitivities, tile, angular resolution and calibration come from
    ``camera`` (by default the IR-filtered DCS-200 of
    ``assets/simtoolbox/cameras/kodakdcs200_50mmIR.Scam``); ``exposure`` and
    ``f_stop`` default to the shipped test image's settings (0.1 s, f/11,
    3.32 m, per ``assets/simtoolbox/README.md``) and set ``gain`` as the
    simulator's sensor stage would, so that a real raw and a simulated one
    render on the same scale. ``black_level``: see :func:`raw_from_array`
    (the shipped test image's darkest values are about 15 DU).
    """
    import tifffile

    from ..camera import load_camera
    from ..simulation.sensor import exposure_gain

    path = Path(path)
    if not path.exists():
        raise FileFormatError(path, "no such file")
    try:
        a = tifffile.imread(path)
    except Exception as exc:  # tifffile raises several types on a bad file
        raise FileFormatError(path, f"not a readable TIFF ({exc})") from None
    if a.ndim != 2:
        raise FileFormatError(path, f"a DCS-200 raw holds one mosaic plane, this TIFF has shape {a.shape}")
    if a.dtype != np.uint8:
        raise FileFormatError(path, f"a DCS-200 raw is 8-bit, this TIFF holds {a.dtype}")
    cam = load_camera(camera).replace(exposure=float(exposure), f_stop=float(f_stop))
    return raw_from_array(
        a,
        cam.mosaic,
        sensitivities=cam.sensors,
        bits=8,
        illuminant=illuminant,
        black_level=black_level,
        exposure=float(exposure),
        f_stop=float(f_stop),
        distance=float(distance),
        angular_resolution=cam.angular_resolution,
        gain=exposure_gain(cam),
        noise_sigma=float(cam.noise_sigma),
        name=path.stem,
    )
