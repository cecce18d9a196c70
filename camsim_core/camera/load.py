"""Loading cameras: shipped names and the original simulator's ``.Scam`` files."""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from ..datasets import SIMTOOLBOX
from ..datasets.sensors import (
    WAVELENGTHS_380_780,
    Sensors,
    cie1931_xyz,
    common_scale,
    gaussian_sensors,
    kodak_dcs200,
    mixture,
    smith_pokorny_cones,
    stockman_sharpe_cones,
)
from ..errors import FileFormatError, ParameterError
from ..io.simtoolbox import (
    MAX_SAMPLES,
    checked_number,
    checked_sensitivities,
    checked_wavelengths,
    group_number,
    group_numbers,
    matrix,
    read_tagged,
    wavelength_sampling,
)
from ..optics.diffraction import MIN_F_NUMBER
from ..simulation import DEFAULT_ARCHITECTURE, FOUR_SENSOR_GRID, bayer, digitize, mosaic, noise, optical_blur, resample, sensor_responses
from ..spectra import sampling_wavelengths
from .camera import ANGULAR_RESOLUTION_RANGE, MAX_CAMERA_PIXELS, MAX_CAMERA_SIDE, PIXEL_PITCH_RANGE, Camera
from .physical import PHYSICAL_NAMES, physical_camera

__all__ = ["load_camera", "read_scam", "CAMERA_NAMES", "camera_preset"]

CAMERA_NAMES = (
    "kodak-dcs200",
    "kodak-dcs200-ir",
    "human-cones",
    "stockman-sharpe",
    "cie1931",
    "gaussian-3",
    "gaussian-4",
    "phone-1.4um",
    "imx174",
)

#: The original simulator's stage functions (``#Sim#Alg`` names, case-insensitive) and camsim's
#: stage for each; ``None``: a placeholder that passes the image through.
_ALG = {
    "simweightrawimages": sensor_responses,
    "simresample": resample,
    "simmosaic": mosaic,
    "simnoise": noise,
    "simquantize": digitize,
    "simopticalblur": optical_blur,
    "simdonothingonimage": None,
}

#: ``##SimNoise ##SimType`` of the original and camsim's noise model for it.
_NOISE_TYPES = {"gaussianiid": "gaussian", "gaussianiidpercent": "gaussian-range"}


def _architecture(path, algs):
    """The stages a ``.Scam`` file lists in ``#Sim#Alg``, in its order; the chapter's five when it lists none."""
    if not algs:
        return DEFAULT_ARCHITECTURE
    stages = []
    for a in algs:
        key = a.strip().lower()
        if key not in _ALG:
            raise FileFormatError(
                path,
                f"#Sim#Alg names the stage {a!r}, which camsim does not know; known: "
                + ", ".join(sorted({"SimWeightRawImages", "SimReSample", "SimMosaic", "SimNoise", "SimQuantize",
                                    "SimOpticalBlur", "SimDoNothingOnImage"})),
            )
        if _ALG[key] is not None:
            stages.append(_ALG[key])
    if not stages:
        raise FileFormatError(path, "#Sim#Alg lists no stage that does anything")
    return tuple(stages)


def read_scam(path):
    """Read a SimToolbox ``.Scam`` camera file.

    Mosaic indices are 1-based in the file (``##SimMosaic``, row by row) and
    0-based here.

    Stages: the camera's ``architecture`` is the list of ``#Sim#Alg`` lines,
    in the file's order, as the original's ``SimSimulateCamera`` calls them:
    ``SimWeightRawImages`` -> ``sensor_responses``, ``SimReSample`` ->
    ``resample``, ``SimMosaic`` -> ``mosaic``, ``SimNoise`` -> ``noise``,
    ``SimQuantize`` -> ``digitize``, ``SimOpticalBlur`` -> ``optical_blur``
    (``blur_sigma`` 0 here: the original's blur was a placeholder), and
    ``SimDoNothingOnImage`` is dropped. Any other name is refused
    (:class:`FileFormatError` naming the file). A file with no ``#Sim#Alg``
    gets the chapter's five stages. So the shipped DCS-200 files, which list
    no noise stage, give noiseless cameras, and ``quantal_50mm.Scam`` (no
    ``SimQuantize``) an unquantized one: the ``##SimNoise`` and
    ``##SimQuantize`` parameters are still read into the camera, but only
    a listed stage applies them.

    Noise (``##SimNoise``), in the original's units: ``gaussianIID`` adds
    ``Mean + sqrt(Variance) * randn`` in digital units (``noise_model
    "gaussian"``, ``noise_mean = Mean``, ``noise_sigma = sqrt(Variance)``,
    e.g. 0.05 and 0.1 DU in the DCS-200 files); ``gaussianIIDpercent`` adds
    it in fractions of the image's own range, clipped to that range
    (``noise_model "gaussian-range"``). Another type is refused.

    The black level (``black_level``) is 0: no SimToolbox file has one.

    Every field is checked before use, and a bad one is refused with a
    :class:`FileFormatError` naming the file and the tag: sensitivities
    must be finite and >= 0, each sensor responding somewhere (quantum
    efficiencies at most 1); ``#SimHeight`` and ``#SimWidth`` whole numbers
    from 1 to :data:`~camsim_core.camera.camera.MAX_CAMERA_SIDE` with at
    most :data:`~camsim_core.camera.camera.MAX_CAMERA_PIXELS` pixels in all
    (refused before anything is allocated); the angular resolution and the
    pixel pitch within
    :data:`~camsim_core.camera.camera.ANGULAR_RESOLUTION_RANGE` and
    :data:`~camsim_core.camera.camera.PIXEL_PITCH_RANGE`; the lens, the
    calibration exposure and f-number positive (f-number at least
    :data:`~camsim_core.optics.diffraction.MIN_F_NUMBER`); the noise
    variance >= 0; the bits 1 to 32.
    """
    path = Path(path)
    t = read_tagged(path)
    n = t.number("NumberSensors", required=True, integer=True, positive=True)
    height = t.number("Height", required=True, integer=True, positive=True, maximum=MAX_CAMERA_SIDE)
    width = t.number("Width", required=True, integer=True, positive=True, maximum=MAX_CAMERA_SIDE)
    if height * width > MAX_CAMERA_PIXELS:
        raise FileFormatError(path, f"#SimHeight x #SimWidth is {height} x {width} = {height * width} pixels; "
                                    f"a camera has at most {MAX_CAMERA_PIXELS}")
    ws = t.get_tag("WavelengthSampling")
    if isinstance(ws, dict):
        wls = wavelength_sampling(t)
    elif ws is not None:
        s = _three_numbers(path, ws)
        wls = sampling_wavelengths(*s)
    else:
        raise FileFormatError(path, "required tag #SimWavelengthSampling is missing")
    sens = matrix(t, "SpectralSensitivity", "one row of sensitivities per sensor")
    if sens.shape != (n, wls.size):
        raise FileFormatError(path, f"#Sim#SpectralSensitivity is {sens.shape[0]} x {sens.shape[1]}, expected {n} x {wls.size}")
    unit = t.text("Unit", "Watts").strip().capitalize()
    if unit not in ("Watts", "Quanta"):
        raise FileFormatError(path, f"#SimUnit must be Watts or Quanta for a camera, found {unit!r}")
    names = ("R", "G", "B") if n == 3 else tuple(f"S{i + 1}" for i in range(n))
    checked_sensitivities(path, "#Sim#SpectralSensitivity", sens, names, wls, unit)
    try:
        sensors = Sensors(wls, sens, names, unit, t.text("Name"))
    except ValueError as exc:
        raise FileFormatError(path, f"#Sim#SpectralSensitivity: {exc}") from None
    tile = None
    if t.has("SpatialLayout"):
        dims = group_numbers(t, "SpatialLayout", "Dims")
        mos = group_numbers(t, "SpatialLayout", "Mosaic")
        if dims.size != 3 or np.any(dims < 1) or np.any(dims != np.round(dims)) or np.any(dims > 64):
            raise FileFormatError(path, f"##SimDims is {dims.tolist()}; expected three whole numbers from 1 to 64")
        dims = dims.astype(int)
        if mos.size != int(np.prod(dims)):
            raise FileFormatError(path, f"##SimMosaic has {mos.size} entries for ##SimDims {dims.tolist()}")
        if np.any(mos != np.round(mos)) or np.any(mos < 1) or np.any(mos > n):
            raise FileFormatError(path, f"##SimMosaic entries must be whole sensor numbers from 1 to {n}")
        tile = mos.astype(int).reshape(tuple(dims)) - 1
        if tile.shape[2] == 1:
            tile = tile[:, :, 0]
        if tile.shape[:2] == (1, 1):
            tile = None  # one pixel with every sensor: a full-colour camera
    lo, hi = ANGULAR_RESOLUTION_RANGE
    ax = group_number(t, "AngularResolution", "X", minimum=lo, maximum=hi)
    ay = group_number(t, "AngularResolution", "Y", minimum=lo, maximum=hi)
    noise_mean = noise_sigma = 0.0
    noise_model = "gaussian"
    if t.has("Noise"):
        group = t.get_tag("Noise")
        kind = " ".join(group.get("Type", ["gaussianIID"])).strip() if isinstance(group, dict) else "gaussianIID"
        if kind.lower() not in _NOISE_TYPES:
            raise FileFormatError(path, f"##SimNoise ##SimType {kind!r} is not a noise type camsim knows (gaussianIID, gaussianIIDpercent)")
        noise_model = _NOISE_TYPES[kind.lower()]
        mean = group_number(t, "Noise", "Mean", required=False)
        noise_mean = float(mean) if mean is not None else 0.0
        var = group_number(t, "Noise", "Variance", minimum=0.0, required=False)
        noise_sigma = float(np.sqrt(var)) if var is not None else 0.0
    bits = None
    if t.has("Quantize"):
        bits = group_number(t, "Quantize", "Bits", integer=True, positive=True, required=False)
        if bits is not None and bits > 32:
            raise FileFormatError(path, f"#SimQuantize ##SimBits is {bits}; expected 1 to 32")
    lo, hi = PIXEL_PITCH_RANGE
    ph = t.number("PixelHeight", 9e-6, minimum=lo, maximum=hi)
    pw = t.number("PixelWidth", 9e-6, minimum=lo, maximum=hi)
    focal_length = t.number("Lens", 50.0, positive=True)
    cal_exposure = t.number("CalExposureTime", 1.0, positive=True)
    cal_f_stop = t.number("CalFStop", 5.6, minimum=MIN_F_NUMBER)
    algs = [a for a in t.get_tag("Alg", []) if a and a.strip()]
    architecture = _architecture(path, algs)
    comments = t.text("Comments")
    try:
        return Camera(
            sensors=sensors,
            name=path.stem,
            mosaic=tile,
            height=height,
            width=width,
            angular_resolution=(ax, ay),
            focal_length=focal_length,
            pixel_size=(ph, pw),
            cal_exposure=cal_exposure,
            cal_f_stop=cal_f_stop,
            exposure=cal_exposure,
            f_stop=cal_f_stop,
            noise_model=noise_model,
            noise_mean=noise_mean,
            noise_sigma=noise_sigma,
            bits=bits,
            seed=0,
            architecture=architecture,
            comments=comments,
        )
    except ValueError as exc:
        raise FileFormatError(path, str(exc)) from None


def _three_numbers(path, lines):
    """``start step count`` of a one-line ``#SimWavelengthSampling``, checked."""
    from ..io.simtoolbox import _numbers

    v = _numbers(path, "WavelengthSampling", lines)
    if v.size < 3:
        raise FileFormatError(path, "#SimWavelengthSampling should hold start, step and count")
    start = checked_number(path, "#SimWavelengthSampling start", v[:1], positive=True)
    step = checked_number(path, "#SimWavelengthSampling step", v[1:2], positive=True)
    count = checked_number(path, "#SimWavelengthSampling count", v[2:3], integer=True, positive=True)
    if count > MAX_SAMPLES:
        raise FileFormatError(path, f"#SimWavelengthSampling count is {count}, more than {MAX_SAMPLES}")
    checked_wavelengths(path, "#SimWavelengthSampling", start, step, count)
    return start, step, count


@functools.lru_cache(maxsize=2)
def _dcs200_geometry(ir=True):
    """The DCS-200 file's camera with the chapter's five stages, noiseless as the file's stage list makes it.

    Read once per process (a Camera is frozen and its arrays read-only, so presets share it): the ideal
    image's camera is built from it on every explorer move.
    """
    cam = read_scam(SIMTOOLBOX / "cameras" / ("kodakdcs200_50mmIR.Scam" if ir else "kodakdcs200_50mm.Scam"))
    return cam.replace(architecture=DEFAULT_ARCHITECTURE, noise_mean=0.0, noise_sigma=0.0)


def camera_preset(name, **changes):
    """A shipped camera by name (see ``CAMERA_NAMES``), with optional field ``changes``.

    Every preset has the Kodak DCS-200's geometry (50 mm lens, 102.6 px/deg,
    1012 x 1524 pixels, f/5.6 and 1 s calibration), 8 bits, seed 0, black
    level 0, and the chapter's five stages (so that ``noise_sigma=`` switches
    noise on); it is noiseless, as the DCS-200 file, which lists no noise
    stage, makes the camera it describes (``load_camera`` of the ``.Scam``
    path gives exactly the file's stages).
    ``human-cones`` are Smith-Pokorny cones and ``cie1931`` the CIE 1931
    functions, not mosaiced and noiseless, brought to the DCS-200's scale
    (see :func:`~camsim_core.datasets.sensors.common_scale`; XYZ with one
    factor for all three so that its ratios stay colorimetric).
    ``gaussian-3`` / ``gaussian-4`` are the section 5 Gaussian sensors (27 nm
    standard deviation) on a Bayer tile / the 2 x 2 grid. ``phone-1.4um``
    and ``imx174`` are physical cameras from published sensor sheets
    (:mod:`camsim_core.camera.physical`), with their own geometry.
    """
    key = name.lower()
    if key in PHYSICAL_NAMES:
        return physical_camera(key, **changes)
    base = _dcs200_geometry(ir=key != "kodak-dcs200")
    if key in ("kodak-dcs200", "kodak-dcs200-ir"):
        cam = base.replace(name=key)
    elif key in ("human-cones", "stockman-sharpe"):
        cones = smith_pokorny_cones() if key == "human-cones" else stockman_sharpe_cones()
        s = Sensors(WAVELENGTHS_380_780, common_scale(cones), cones.names, "Watts", cones.name)
        cam = base.replace(name=key, sensors=s, mosaic=None, noise_sigma=0.0, noise_mean=0.0)
    elif key == "cie1931":
        xyz = cie1931_xyz()
        v = xyz.on(WAVELENGTHS_380_780)
        ref = kodak_dcs200().on(WAVELENGTHS_380_780).sum(axis=1).mean()
        s = Sensors(WAVELENGTHS_380_780, v * (ref / v[1].sum()), xyz.names, "Watts", xyz.name)
        cam = base.replace(name=key, sensors=s, mosaic=None, noise_sigma=0.0, noise_mean=0.0)
    elif key == "gaussian-3":
        s = gaussian_sensors([640, 520, 460], 27.0, names=("R", "G", "B"))
        cam = base.replace(name=key, sensors=s, mosaic=bayer("GRBG"), noise_sigma=0.0, noise_mean=0.0)
    elif key == "gaussian-4":
        s = gaussian_sensors([460, 520, 580, 640], 27.0)
        cam = base.replace(name=key, sensors=s, mosaic=FOUR_SENSOR_GRID, noise_sigma=0.0, noise_mean=0.0)
    elif key.startswith("mixture-"):
        try:
            alpha = float(key.split("-", 1)[1])
        except ValueError:
            alpha = float("nan")
        if not 0.0 <= alpha <= 1.0:
            raise ParameterError("camera", f"{name!r}: a mixture is 'mixture-ALPHA' with ALPHA from 0 to 1 (e.g. mixture-0.5)")
        cam = base.replace(name=key, sensors=mixture(alpha))
    else:
        raise FileFormatError(name, f"not a shipped camera name ({', '.join(CAMERA_NAMES)}, mixture-ALPHA) nor a file")
    return cam.replace(**changes) if changes else cam


def load_camera(name_or_path):
    """A :class:`Camera` from a shipped name (``CAMERA_NAMES``, or ``mixture-ALPHA``) or a ``.Scam`` path.

    Examples
    --------
    The Kodak DCS-200: an 8-bit camera with a Bayer mosaic (G R / B G; R, G, B = 0, 1, 2):

    >>> import numpy as np
    >>> camera = load_camera("kodak-dcs200")
    >>> camera.bits, np.asarray(camera.mosaic).tolist()
    (8, [[1, 0], [2, 1]])
    """
    if isinstance(name_or_path, Camera):
        return name_or_path
    key = str(name_or_path)
    if key.lower() in CAMERA_NAMES or key.lower().startswith("mixture-"):
        return camera_preset(key)
    p = Path(key)
    if os.path.lexists(p):
        if p.suffix.lower() != ".scam":
            raise FileFormatError(p, "unknown camera format: expected a SimToolbox .Scam file")
        return read_scam(p)
    raise FileFormatError(p, f"no such file, and not a shipped camera name ({', '.join(CAMERA_NAMES)})")
