"""The camera: a parameter structure plus an architecture (chapter section 3).

The architecture is the ordered tuple of stages ``stage(camera, image) ->
image`` applied to the scene; the parameters differentiate one camera from
another within an architecture. Reordering is a matter of passing another
tuple, e.g. ``(optical_blur, sensor_responses, resample, mosaic, noise,
digitize)`` with a per-wavelength ``blur_sigma`` for chromatic aberration.

``dataclasses.replace(camera, mosaic=None, noise_sigma=0.0, bits=None)``
gives the same camera non-mosaiced, noiseless and unquantized.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..datasets.sensors import Sensors
from ..errors import ParameterError
from ..image import check_tile
from ..optics.diffraction import MIN_F_NUMBER
from ..optics.fused import lens_sensor_responses
from ..optics.stage import check_optics_fields, optics as optics_stage, optics_active
from ..simulation.electrons import check_sensor_fields
from ..simulation import DEFAULT_ARCHITECTURE, sensor_responses
from ..spectra import Spectrum

__all__ = ["Camera", "NOISE_MODELS", "MAX_CAMERA_SIDE", "MAX_CAMERA_PIXELS", "ANGULAR_RESOLUTION_RANGE",
           "PIXEL_PITCH_RANGE", "MIN_DISTANCE", "check_camera_size"]

NOISE_MODELS = ("gaussian", "photon", "gaussian-range")

#: Most pixels on one side of a camera's array, 2**16: a guard against absurd sizes (a 1e40-pixel
#: height, a 200000 x 200000 array), not a physical limit; the largest single sensors are ~14000 px wide.
MAX_CAMERA_SIDE = 65536
#: Most pixels in a camera's array, 2**29 (~537 MP): 12 MP and 50 MP sensors, the 150 MP medium-format ones
#: and the explorer's finest pitch (the IMX174's 1920 x 1200 at 0.5 um instead of 5.86 um, 316 MP) pass. The
#: array bounds the simulated image (the image covers the scene's extent, cropped to the array), it is not
#: allocated by itself.
MAX_CAMERA_PIXELS = 2**29
#: Pixels per degree a camera may have, (lowest, highest): a pixel narrower than 1000 degrees and wider
#: than 1e-5 degree (a 1 um pixel behind a 2 m lens has ~35000 px/deg). Beyond them resampling a scene
#: would need absurd arrays.
ANGULAR_RESOLUTION_RANGE = (1e-3, 1e5)
#: Pixel pitch a camera may have, m (lowest, highest): 10 nm to 1 cm. A quantal sensor's electrons scale
#: with the pixel's area; beyond these the counts under- or overflow.
PIXEL_PITCH_RANGE = (1e-8, 1e-2)
#: Closest distance of a camera to its scene, m (1 mm): closer, resampling the scene would need absurd arrays.
MIN_DISTANCE = 1e-3


def _is_number(v):
    return not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))


def check_camera_size(height, width, name="height, width"):
    """``(height, width)`` as ints, or a ParameterError naming ``name``.

    Each must be a whole number of pixels from 1 to :data:`MAX_CAMERA_SIDE`,
    and their product at most :data:`MAX_CAMERA_PIXELS` (checked before
    anything is allocated: a 200000 x 200000 array is refused).

    Parameters
    ----------
    height, width : int or float
        The array's rows and columns; whole floats (1012.0) are accepted.
    name : str
        What the error names (a field, a tag or a command-line option).

    Returns
    -------
    (int, int)
    """
    out = []
    for what, v in (("height", height), ("width", width)):
        whole = isinstance(v, (int, np.integer)) or (_is_number(v) and np.isfinite(v) and v == int(v))
        if not _is_number(v) or not whole or not 1 <= v <= MAX_CAMERA_SIDE:
            raise ParameterError(name, f"the {what} must be a whole number of pixels from 1 to {MAX_CAMERA_SIDE}, got {v!r}")
        out.append(int(v))
    if out[0] * out[1] > MAX_CAMERA_PIXELS:
        raise ParameterError(name, f"{out[0]} x {out[1]} = {out[0] * out[1]} pixels; a camera has at most {MAX_CAMERA_PIXELS}")
    return out[0], out[1]


def _pair(value, name):
    """``value`` (one number or two) as two floats, or a ParameterError naming ``name``."""
    try:
        return tuple(float(v) for v in np.broadcast_to(np.asarray(value, float), (2,)))
    except (TypeError, ValueError):
        raise ParameterError(name, f"expected one or two numbers, got {value!r}") from None


@dataclass(frozen=True, eq=False)
class Camera:
    """Camera parameters.

    Attributes
    ----------
    sensors : Sensors
        Spectral sensitivities, >= 0 ("Watts": digital units per unit radiance
        band at ``cal_exposure`` and ``cal_f_stop``; "Quanta": quantum
        efficiency, see :func:`~camsim_core.simulation.sensor.sensor_responses`).
    mosaic : ndarray (n, m) or (n, m, tiers) of int, or None
        0-based sensor index at each tile position; ``None`` for a full-colour camera.
    height, width : int
        Size of the sensor array, pixels: each 1 to :data:`MAX_CAMERA_SIDE`,
        at most :data:`MAX_CAMERA_PIXELS` in all.
    angular_resolution : (x, y)
        Pixels per degree, within :data:`ANGULAR_RESOLUTION_RANGE`.
    focal_length : float
        mm.
    pixel_size : (height, width)
        Pixel pitch, m, within :data:`PIXEL_PITCH_RANGE` (quantal cameras: the pixel area is their product).
    cal_exposure, cal_f_stop : float
        Conditions of the sensitivity calibration (s, f-number).
    exposure, f_stop : float
        Conditions of the simulated picture.
    distance : float or None
        m from the scene, at least :data:`MIN_DISTANCE`; ``None`` keeps the scene's own distance.
    noise_model : "gaussian", "photon" or "gaussian-range"
        Additive Gaussian noise in digital units (the chapter's model, the
        original's ``gaussianIID``), the electron-level sensor of quantal
        cameras (photon shot noise, read noise and the EMVA 1288 fields
        below, :mod:`camsim_core.simulation.electrons`), or Gaussian noise
        in fractions of the image's range (the original's
        ``gaussianIIDpercent``; see :func:`~camsim_core.simulation.noise.noise`).
    noise_mean, noise_sigma : float
        Digital units (fractions of the image's range for
        "gaussian-range"). ``noise_sigma == 0`` switches the noise stage off.
    black_level : float
        Digital units, >= 0 (default 0). The sensor's pedestal (the dark
        offset that a real camera's electronics add so that noise around
        black is not clipped): added to every pixel by the ``digitize`` stage
        before quantization, carried in the image's ``black_level``, and
        subtracted by processing (``demosaic``, ``render``) as a raw
        converter does. The Kodak DCS-200's real raws read about 15 DU.
    read_noise : float
        Temporal dark noise sigma_d, e- rms (photon model).
    electrons_per_dn : float
        Inverse conversion gain of a quantal sensor at unit analog gain, e- per DN.
    optics : "none" or "diffraction"
        "diffraction": the optics stage blurs each spectral plane by the
        diffraction-limited OTF of the f-number at its wavelength
        (:mod:`camsim_core.optics`). "none" (default): no optical blur.
    defocus : float
        Focus error, dioptres (1/m); needs ``optics="diffraction"``. 0 = in focus.
    lens_transmittance : Spectrum or None
        Lens transmittance, fraction per wavelength; None = 1 (a perfect lens).
    relative_illumination : bool
        Apply the cos^4 fall-off of irradiance with the field angle.
    vignetting : float
        Extra fraction of light lost at the corner of the pixel array
        (growing with the square of the image height); 0 = none.
    fill_factor : float
        Fraction (0, 1] of the pixel area that collects light (quantal sensors).
    full_well : float or None
        Saturation capacity mu_e.sat, e-; None = no saturation (photon model).
    dark_current : float
        Dark current mu_I, e-/s (photon model; its shot noise included).
    dsnu : float
        Dark signal non-uniformity DSNU_1288, e- rms (fixed pattern, photon model).
    prnu : float
        Photo response non-uniformity PRNU_1288, fraction rms (0.01 = 1 %; fixed pattern, photon model).
    analog_gain : float
        Gain before the ADC (dimensionless): system gain K = analog_gain / electrons_per_dn DN/e-.
    pattern_seed : int
        Seed of the DSNU and PRNU patterns: the sensor's identity, the same in every frame.
    bits : int or None
        1-32; ``None`` for no quantization.
    nonlinearity : None, float or array
        Static non-linearity before quantization: a power (v/full)**gamma, or
        a lookup table of normalized output at evenly spaced normalized
        inputs (like the Kodak DCS-420's).
    blur_sigma : float or Spectrum
        Gaussian optical blur, standard deviation in camera pixels; a
        Spectrum gives it per wavelength (used by ``optical_blur`` on
        spectral planes). 0 = no blur.
    seed : int or None
        Seed of the noise generator; the same seed gives the same noise.
    architecture : tuple of stages
        Applied in order by :func:`~camsim_core.simulation.simulate`. A camera
        whose optics are on (diffraction, transmittance, relative illumination
        or vignetting) and whose architecture names no lens stage gets one: in
        place of ``sensor_responses``, the fused
        :func:`~camsim_core.optics.fused.lens_sensor_responses` (the same
        image within 0.1 % of the blur's MTF, without spectral planes at the sensor);
        without a ``sensor_responses`` stage, the ``optics`` stage first. Name
        ``optics`` before ``sensor_responses`` for the spectral planes at the sensor.
    """

    sensors: Sensors
    name: str = ""
    mosaic: np.ndarray | None = None
    height: int = 1012
    width: int = 1524
    angular_resolution: tuple = (102.6, 102.6)
    focal_length: float = 50.0
    pixel_size: tuple = (9e-6, 9e-6)
    cal_exposure: float = 1.0
    cal_f_stop: float = 5.6
    exposure: float = 1.0
    f_stop: float = 5.6
    distance: float | None = None
    noise_model: str = "gaussian"
    noise_mean: float = 0.0
    noise_sigma: float = 0.0
    black_level: float = 0.0
    read_noise: float = 0.0
    electrons_per_dn: float = 1.0
    bits: int | None = 8
    nonlinearity: object = None
    blur_sigma: object = 0.0
    seed: int | None = None
    optics: str = "none"
    defocus: float = 0.0
    lens_transmittance: Spectrum | None = None
    relative_illumination: bool = False
    vignetting: float = 0.0
    fill_factor: float = 1.0
    full_well: float | None = None
    dark_current: float = 0.0
    dsnu: float = 0.0
    prnu: float = 0.0
    analog_gain: float = 1.0
    pattern_seed: int = 0
    architecture: tuple = DEFAULT_ARCHITECTURE
    comments: str = ""

    def __post_init__(self):
        if not isinstance(self.sensors, Sensors):
            raise ParameterError("sensors", f"must be a Sensors set, got {type(self.sensors).__name__}")
        sv = self.sensors.values
        if sv.size and sv.min() < 0:
            k, j = np.unravel_index(np.argmin(sv), sv.shape)
            raise ParameterError("sensors", f"spectral sensitivities must be >= 0 (a sensor cannot record negative light); "
                                            f"{self.sensors.names[k]} is {sv[k, j]:g} at {self.sensors.wavelengths[j]:g} nm")
        h, w = check_camera_size(self.height, self.width)
        object.__setattr__(self, "height", h)
        object.__setattr__(self, "width", w)
        object.__setattr__(self, "mosaic", check_tile(self.mosaic, len(self.sensors), "mosaic"))
        for field_name in ("exposure", "f_stop", "cal_exposure", "cal_f_stop", "focal_length", "electrons_per_dn"):
            v = getattr(self, field_name)
            if not (isinstance(v, (int, float, np.floating, np.integer)) and np.isfinite(v) and v > 0):
                raise ParameterError(field_name, f"must be a positive number, got {v!r}")
        if self.f_stop < MIN_F_NUMBER:
            raise ParameterError("f_stop", f"must be an f-number >= {MIN_F_NUMBER} (numerical aperture <= 1), got {self.f_stop!r}")
        ps = _pair(self.pixel_size, "pixel_size")
        lo, hi = PIXEL_PITCH_RANGE
        if not all(np.isfinite(v) and lo <= v <= hi for v in ps):
            raise ParameterError("pixel_size", f"the pixel pitch must be {lo:g} to {hi:g} m (height, width), got {self.pixel_size!r}")
        object.__setattr__(self, "pixel_size", ps)
        if self.distance is not None and not (_is_number(self.distance) and np.isfinite(self.distance)
                                              and self.distance >= MIN_DISTANCE):
            raise ParameterError("distance", f"must be a finite number of metres >= {MIN_DISTANCE:g}, or None, got {self.distance!r}")
        ar = _pair(self.angular_resolution, "angular_resolution")
        lo, hi = ANGULAR_RESOLUTION_RANGE
        if not all(np.isfinite(v) and lo <= v <= hi for v in ar):
            raise ParameterError("angular_resolution", f"must be {lo:g} to {hi:g} pixels per degree (x, y), got {ar}")
        object.__setattr__(self, "angular_resolution", ar)
        if self.noise_model not in NOISE_MODELS:
            raise ParameterError("noise_model", f"must be one of {NOISE_MODELS}, got {self.noise_model!r}")
        for field_name in ("noise_sigma", "read_noise"):
            v = getattr(self, field_name)
            if not (_is_number(v) and np.isfinite(v) and v >= 0):
                raise ParameterError(field_name, f"must be a non-negative number, got {v!r}")
        bl = self.black_level
        if isinstance(bl, bool) or not isinstance(bl, (int, float, np.floating, np.integer)) or not (np.isfinite(bl) and bl >= 0):
            raise ParameterError("black_level", f"must be a finite number of digital units >= 0, got {bl!r}")
        object.__setattr__(self, "black_level", float(bl))
        if self.seed is not None and (isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0):
            raise ParameterError("seed", f"must be a whole number >= 0 or None, got {self.seed!r}")
        if not (_is_number(self.noise_mean) and np.isfinite(self.noise_mean)):
            raise ParameterError("noise_mean", f"must be a finite number, got {self.noise_mean!r}")
        if self.noise_model == "photon" and self.sensors.unit != "Quanta":
            raise ParameterError("noise_model", "photon noise needs sensitivities in quanta (sensors.unit == 'Quanta')")
        if self.bits is not None:
            if isinstance(self.bits, bool) or int(self.bits) != self.bits or not 1 <= self.bits <= 32:
                raise ParameterError("bits", f"must be a whole number from 1 to 32, or None for no quantization; got {self.bits!r}")
            object.__setattr__(self, "bits", int(self.bits))
        if self.nonlinearity is not None and not np.isscalar(self.nonlinearity):
            lut = np.asarray(self.nonlinearity, float).ravel()
            if lut.size < 2 or not np.all(np.isfinite(lut)) or np.any(np.diff(lut) < 0):
                raise ParameterError("nonlinearity", "a lookup table must hold at least 2 finite, non-decreasing values")
            object.__setattr__(self, "nonlinearity", lut)
        elif self.nonlinearity is not None and not (np.isfinite(self.nonlinearity) and self.nonlinearity > 0):
            raise ParameterError("nonlinearity", f"a gamma must be a positive number, got {self.nonlinearity!r}")
        if not isinstance(self.blur_sigma, Spectrum) and not (np.isfinite(self.blur_sigma) and self.blur_sigma >= 0):
            raise ParameterError("blur_sigma", f"must be a non-negative number of pixels or a Spectrum, got {self.blur_sigma!r}")
        if not self.architecture or not all(callable(s) for s in self.architecture):
            raise ParameterError("architecture", "must be a non-empty sequence of stage(camera, image) functions")
        check_optics_fields(self)
        check_sensor_fields(self)
        architecture = tuple(self.architecture)
        if optics_active(self) and optics_stage not in architecture and lens_sensor_responses not in architecture:
            if sensor_responses in architecture:
                # the lens fused with the sensor responses: the same image, without spectral planes at the sensor
                architecture = tuple(lens_sensor_responses if s is sensor_responses else s for s in architecture)
            else:
                architecture = (optics_stage,) + architecture  # the lens acts on the spectral planes, first
        object.__setattr__(self, "architecture", architecture)

    def replace(self, **changes):
        """A validated copy with ``changes`` (same as ``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    @property
    def n_sensors(self):
        return len(self.sensors)

    @property
    def full_scale(self):
        return None if self.bits is None else float(2 ** self.bits - 1)

    def describe(self):
        return {
            "name": self.name,
            "kind": "camera",
            "sensors": list(self.sensors.names),
            "sensor_unit": self.sensors.unit,
            "wavelengths_nm": f"{self.sensors.wavelengths[0]:g}-{self.sensors.wavelengths[-1]:g}",
            "mosaic": None if self.mosaic is None else self.mosaic.tolist(),
            "size_px": f"{self.height} x {self.width}",
            "angular_resolution_px_per_deg": {"x": self.angular_resolution[0], "y": self.angular_resolution[1]},
            "focal_length_mm": self.focal_length,
            "calibration": {"exposure_s": self.cal_exposure, "f_stop": self.cal_f_stop},
            "exposure_s": self.exposure,
            "f_stop": self.f_stop,
            "distance_m": self.distance,
            "noise": {"model": self.noise_model, "mean": self.noise_mean, "sigma": self.noise_sigma},
            "black_level_du": self.black_level,
            "optics": {"model": self.optics, "defocus_dioptres": self.defocus,
                       "lens_transmittance": None if self.lens_transmittance is None else "spectrum",
                       "relative_illumination_cos4": bool(self.relative_illumination), "vignetting": self.vignetting},
            "sensor": {"pixel_pitch_um": [v * 1e6 for v in self.pixel_size], "fill_factor": self.fill_factor,
                       "full_well_e": self.full_well, "read_noise_e": self.read_noise, "dark_current_e_per_s": self.dark_current,
                       "dsnu_e": self.dsnu, "prnu_fraction": self.prnu, "electrons_per_dn": self.electrons_per_dn,
                       "analog_gain": self.analog_gain, "pattern_seed": self.pattern_seed},
            "bits": self.bits,
            "architecture": [getattr(s, "__name__", repr(s)) for s in self.architecture],
            "comments": self.comments,
        }
