"""Physical camera presets: real sensors in electrons behind a diffraction-limited lens.

Each preset is a JSON file in ``assets/sensors/`` holding the sensor's
published parameters (pitch, array size, saturation capacity, read noise,
ADC bits, lens), with its ``source`` and what was ``derived`` or
``assumed`` stated beside the numbers. The camera built from it has
quantal sensitivities (QE curves), the electron-level sensor
(``noise_model="photon"``, EMVA 1288 fields), ``optics="diffraction"``
with cos^4 relative illumination, and the angular resolution that its
pitch and focal length give at the camera's distance: a pixel of pitch p
images an object patch p / m, seen from the lens at d under
atan(p / (f (1 + m))) radians, m = f / (d - f) the thin lens's
magnification at the focus distance (:func:`angular_resolution_for`;
pitch / f at infinity, half that angle at unit magnification). The
optics stage's diffraction blur uses the working f-number N (1 + m) at the
same distance (:func:`camsim_core.optics.stage.working_f_number`).
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..datasets import asset_path
from ..datasets.sensors import WAVELENGTHS_380_780, Sensors
from ..errors import FileFormatError, ParameterError
from ..simulation import bayer
from .camera import MAX_CAMERA_SIDE, Camera

__all__ = ["PHYSICAL_NAMES", "physical_camera", "read_sensor_sheet", "angular_resolution_for", "SENSOR_FIELDS",
           "sensor_values", "with_sensor", "with_settings"]

SENSOR_SHEETS = asset_path("sensors")

#: Shipped physical presets (files ``assets/sensors/NAME.json``).
PHYSICAL_NAMES = ("phone-1.4um", "imx174")

_REQUIRED = ("pixel_pitch_um", "height", "width", "qe_peak", "qe_center_nm", "qe_sigma_nm", "full_well", "read_noise",
             "dark_current", "dsnu", "prnu", "bits", "focal_length_mm", "f_number", "source")


#: Each numeric field of a sensor sheet: (lowest, highest, whole number). Beyond these a sheet is refused
#: (a negative read noise or QE, a QE above 1, a 1e40-pixel height, a billion-bit ADC).
_SHEET_NUMBERS = {
    "pixel_pitch_um": (0.01, 1e4, False), "height": (1, MAX_CAMERA_SIDE, True), "width": (1, MAX_CAMERA_SIDE, True),
    "full_well": (1e-300, 1e12, False), "read_noise": (0.0, 1e9, False), "dark_current": (0.0, 1e12, False),
    "dsnu": (0.0, 1e9, False), "prnu": (0.0, 10.0, False), "bits": (1, 32, True), "focal_length_mm": (1e-3, 1e6, False),
    "f_number": (0.5, 1e4, False), "exposure_s": (1e-300, 1e6, False), "fill_factor": (1e-300, 1.0, False),
    "black_level": (0.0, 1e12, False),
}
#: The per-channel fields (``{"R": ..., "G": ..., "B": ...}``) and their ranges.
_SHEET_CHANNELS = {"qe_peak": (1e-300, 1.0), "qe_center_nm": (1.0, 1e5), "qe_sigma_nm": (1e-3, 1e5)}


def _in_range(v, lo, hi):
    """Whether ``v`` is a JSON number (not a boolean) from ``lo`` to ``hi`` (NaN and infinities are not)."""
    return not isinstance(v, bool) and isinstance(v, (int, float)) and lo <= v <= hi


def _check_sheet(p, sheet):
    """Refuse a sheet whose fields are of the wrong type or out of range (FileFormatError naming the file and field)."""
    if not isinstance(sheet, dict):
        raise FileFormatError(p, "a sensor sheet is a JSON object {field: value}")
    missing = [k for k in _REQUIRED if k not in sheet]
    if missing:
        raise FileFormatError(p, f"missing field(s) {', '.join(missing)}")
    for key, (lo, hi, whole) in _SHEET_NUMBERS.items():
        if key not in sheet:
            continue
        v = sheet[key]
        if not _in_range(v, lo, hi) or (whole and v != int(v)):
            raise FileFormatError(p, f"{key} must be a {'whole ' if whole else ''}number from {lo:g} to {hi:g}, got {repr(v):.40}")
    for key, (lo, hi) in _SHEET_CHANNELS.items():
        v = sheet[key]
        if not isinstance(v, dict) or set(v) != {"R", "G", "B"} or not all(_in_range(x, lo, hi) for x in v.values()):
            raise FileFormatError(p, f"{key} must be {{\"R\": ..., \"G\": ..., \"B\": ...}} with numbers from {lo:g} to {hi:g}, got {v!r}")


@lru_cache(maxsize=8)
def read_sensor_sheet(path):
    """The parameters of a sensor sheet (JSON), checked for the fields a camera needs.

    Every numeric field must be a finite number in its range (whole numbers
    for ``height``, ``width`` and ``bits``, 1 to 32 bits; quantum
    efficiencies in (0, 1]); errors are :class:`FileFormatError` naming the
    file and the field.
    """
    p = Path(path)
    try:
        sheet = json.loads(p.read_text())
    except FileNotFoundError:
        raise FileFormatError(p, "no such sensor sheet") from None
    except (OSError, ValueError) as exc:
        raise FileFormatError(p, f"not a JSON sensor sheet: {exc}") from None
    _check_sheet(p, sheet)
    return sheet


def angular_resolution_for(pitch_m, focal_length_mm, distance=None):
    """Pixels per degree of a pixel pitch behind a lens focused at ``distance`` m (None: at infinity).

    1 / degrees(atan(pitch / (f (1 + m)))), m = f / (d - f): the sensor sits
    at s' = f (1 + m) behind the lens, so a pixel sees the object patch
    pitch / m, which subtends pitch / (f (1 + m)) radians from d (pitch / f at
    infinity). With it, the optics stage's sample pitch at the sensor
    (:func:`camsim_core.optics.irradiance.sample_pitch`) is the pixel pitch at any distance.
    """
    f = float(focal_length_mm) * 1e-3
    m = 0.0
    if distance is not None:
        from ..optics.irradiance import magnification

        m = magnification(focal_length_mm, distance)
    return 1.0 / np.degrees(np.arctan(float(pitch_m) / (f * (1.0 + m))))


def _angular_resolution(camera):
    """(x, y) pixels per degree of the camera's pixel pitch and focal length at its distance."""
    return (angular_resolution_for(camera.pixel_size[1], camera.focal_length, camera.distance),
            angular_resolution_for(camera.pixel_size[0], camera.focal_length, camera.distance))


def _follows_lens(camera):
    """Whether the camera's angular resolution is that of its pitch and focal length (at infinity or at its
    distance), rather than set by hand: then it follows them when they or the distance change."""
    try:
        ours = [_angular_resolution(camera), _angular_resolution(camera.replace(distance=None))]
    except ParameterError:  # focused inside the focal length: no image, and no angle of a pixel to follow
        return False
    return any(np.allclose(camera.angular_resolution, phi, rtol=1e-9, atol=0.0) for phi in ours)


def qe_sensors(peaks, centers, sigmas, name=""):
    """R, G, B quantum-efficiency curves (Gaussian shapes) on 380:5:780 nm, as quantal Sensors."""
    w = WAVELENGTHS_380_780
    names = ("R", "G", "B")
    v = np.array([peaks[c] * np.exp(-0.5 * ((w - centers[c]) / sigmas[c]) ** 2) for c in names])
    return Sensors(w, v, names, "Quanta", name)


def physical_camera(name_or_path, **changes):
    """The camera of a sensor sheet: a shipped name (``PHYSICAL_NAMES``) or a JSON path, with field ``changes``."""
    key = str(name_or_path)
    path = SENSOR_SHEETS / f"{key.lower()}.json" if key.lower() in PHYSICAL_NAMES else Path(key)
    s = read_sensor_sheet(str(path))
    pitch = float(s["pixel_pitch_um"]) * 1e-6
    phi = angular_resolution_for(pitch, s["focal_length_mm"])
    full_scale = 2 ** int(s["bits"]) - 1
    try:
        cam = Camera(
            sensors=qe_sensors(s["qe_peak"], s["qe_center_nm"], s["qe_sigma_nm"], f"{s.get('name', key)} QE"),
            name=s.get("name", key),
            mosaic=bayer("RGGB", order=(0, 1, 2)) if s.get("mosaic", "RGGB") == "RGGB" else None,
            height=int(s["height"]),
            width=int(s["width"]),
            angular_resolution=(phi, phi),
            focal_length=float(s["focal_length_mm"]),
            pixel_size=(pitch, pitch),
            f_stop=float(s["f_number"]),
            cal_f_stop=float(s["f_number"]),
            exposure=float(s.get("exposure_s", 0.01)),
            noise_model="photon",
            read_noise=float(s["read_noise"]),
            electrons_per_dn=float(s["full_well"]) / full_scale,
            bits=int(s["bits"]),
            optics="diffraction",
            relative_illumination=True,
            fill_factor=float(s.get("fill_factor", 1.0)),
            full_well=float(s["full_well"]),
            dark_current=float(s["dark_current"]),
            dsnu=float(s["dsnu"]),
            prnu=float(s["prnu"]),
            black_level=float(s.get("black_level", 0.0)),
            seed=0,
            comments=f"{s.get('description', '')}\nsource: {s['source']}",
        )
    except ValueError as exc:
        raise FileFormatError(path, str(exc)) from None
    if not changes:
        return cam
    cam = cam.replace(**changes)
    if "angular_resolution" not in changes:  # the pitch, focal length and distance given: the angle of a pixel follows
        cam = cam.replace(angular_resolution=_angular_resolution(cam))
    return cam


#: The electron-level sensor's fields a design may set, in the units a user reads them in:
#: name -> (unit, lowest, highest, what it is). Percentages are the camera's fractions x 100.
SENSOR_FIELDS = {
    "pixel_pitch_um": ("um", 0.5, 20.0, "pixel pitch (the sensor keeps its size: the pixel count follows)"),
    "fill_factor_pct": ("%", 1.0, 100.0, "light-sensitive share of the pixel's area"),
    "full_well_e": ("e-", 10.0, 1e7, "saturation capacity (the ADC's range spans it)"),
    "read_noise_e": ("e- rms", 0.0, 1e3, "temporal dark noise"),
    "dark_current_e_per_s": ("e-/s", 0.0, 1e6, "dark current (with its shot noise)"),
    "dsnu_e": ("e- rms", 0.0, 1e4, "dark signal non-uniformity, a fixed pattern"),
    "prnu_pct": ("%", 0.0, 100.0, "photo-response non-uniformity, a fixed pattern"),
}


def sensor_values(camera):
    """The camera's :data:`SENSOR_FIELDS` in their units (``full_well_e`` None: no saturation).

    Unit conversions are rounded to 12 significant digits (5.86 um, not 5.859999999999999).
    """
    def tidy(v):
        return float(f"{v:.12g}")

    return {
        "pixel_pitch_um": tidy(camera.pixel_size[1] * 1e6),
        "fill_factor_pct": tidy(camera.fill_factor * 100.0),
        "full_well_e": camera.full_well,
        "read_noise_e": camera.read_noise,
        "dark_current_e_per_s": camera.dark_current,
        "dsnu_e": camera.dsnu,
        "prnu_pct": tidy(camera.prnu * 100.0),
    }


def _spans_full_well(camera):
    """Whether the camera's ADC range spans its saturation capacity (``electrons_per_dn = full_well / full_scale``)."""
    return (camera.full_well is not None and camera.bits is not None
            and abs(camera.electrons_per_dn * camera.full_scale / camera.full_well - 1.0) < 1e-9)


def with_sensor(camera, bits=..., **values):
    """An electron-level camera with sensor fields changed, keeping it a consistent device.

    ``values`` are :data:`SENSOR_FIELDS` in their units (um, %, e-, e-/s);
    ``bits`` the ADC's (None: unquantized; omitted: kept). What follows from them:

    * ``pixel_pitch_um``: the sensor keeps its size, so its pixel array
      scales (height, width); the angular resolution follows from the pitch,
      the focal length and the distance (:func:`angular_resolution_for`);
      the full well, unless given, scales with the pixel's area (the same electrons per um^2).
    * A camera whose angular resolution is its pitch and focal length's (at
      infinity or at its distance: a sheet's camera moved to another
      distance) gets the one at its distance, pitch / (f (1 + m)) radians
      per pixel, whichever fields change.
    * When the camera's ADC range spans its full well (the shipped sheets'
      ``electrons_per_dn = full_well / (2^bits - 1)``), it keeps spanning
      it at a new full well or bit depth: an 8-bit readout of a 12-bit
      sensor drops the low bits instead of clipping at a sixteenth of the well.

    Raises ParameterError naming the field (and its unit and range) for an
    unknown field, a value out of range, or a camera in digital units
    (the chapter's cameras: their model is calibrated in DN, not electrons).
    """
    if camera.noise_model != "photon":
        names = ", ".join(values) or "sensor"
        raise ParameterError(names, f"belongs to the electron-level sensor; {camera.name or 'this camera'} is "
                                    f"calibrated in digital units (choose one of {', '.join(PHYSICAL_NAMES)})")
    for name, value in values.items():
        if name not in SENSOR_FIELDS:
            raise ParameterError(name, f"is not a sensor field; expected one of {', '.join(SENSOR_FIELDS)}")
        unit, low, high, _ = SENSOR_FIELDS[name]
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                or not np.isfinite(value) or not low <= value <= high:
            raise ParameterError(name, f"must be a number of {unit} in [{low:g}, {high:g}], got {value!r}")
    spans = _spans_full_well(camera)
    follows = _follows_lens(camera)
    changes = {}
    full_well = camera.full_well
    if "pixel_pitch_um" in values:
        pitch = float(values["pixel_pitch_um"]) * 1e-6
        old = camera.pixel_size[1]
        k = old / pitch
        phi = angular_resolution_for(pitch, camera.focal_length, camera.distance)
        changes.update(pixel_size=(pitch, pitch), angular_resolution=(phi, phi),
                       height=max(1, int(round(camera.height * k))), width=max(1, int(round(camera.width * k))))
        if full_well is not None:
            full_well = full_well / k**2
    if "full_well_e" in values:
        full_well = float(values["full_well_e"])
    if full_well != camera.full_well:
        changes["full_well"] = full_well
    if "fill_factor_pct" in values:
        changes["fill_factor"] = float(values["fill_factor_pct"]) / 100.0
    if "read_noise_e" in values:
        changes["read_noise"] = float(values["read_noise_e"])
    if "dark_current_e_per_s" in values:
        changes["dark_current"] = float(values["dark_current_e_per_s"])
    if "dsnu_e" in values:
        changes["dsnu"] = float(values["dsnu_e"])
    if "prnu_pct" in values:
        changes["prnu"] = float(values["prnu_pct"]) / 100.0
    if follows and "angular_resolution" not in changes:
        phi = _angular_resolution(camera)
        if phi != camera.angular_resolution:
            changes["angular_resolution"] = phi
    if bits is not ...:
        changes["bits"] = bits
    new_bits = changes.get("bits", camera.bits)
    if spans and full_well is not None and new_bits is not None:
        changes["electrons_per_dn"] = full_well / float(2 ** int(new_bits) - 1)
    try:
        return camera.replace(**changes)
    except ParameterError:
        raise
    except (TypeError, ValueError) as exc:
        raise ParameterError("sensor", str(exc)) from None


def with_settings(camera, *, bits=..., sensor=None, **changes):
    """The camera with its settings changed as the explorer, its parameters files and the command line change them.

    One path for all three, so that a camera set to the same values is the same camera whichever tool set them.

    Parameters
    ----------
    camera : Camera
        The camera to change (a shipped preset, a .Scam file's, a sensor sheet's).
    bits : int or None, optional
        The ADC's bit depth, 1 to 32; 0 or None: unquantized (the explorer's and the parameters files' 0).
        Omitted: kept.
    sensor : dict, optional
        :data:`SENSOR_FIELDS` in their units (um, %, e-, e-/s), for an electron-level camera only
        (:func:`with_sensor`).
    **changes
        Other :class:`~camsim_core.Camera` fields: ``distance`` (m), ``exposure`` (s), ``f_stop``,
        ``noise_sigma`` (DN), ``black_level`` (DN), ``seed``, ``mosaic``, ``height``, ``width``...

    Returns
    -------
    Camera
        A camera in digital units (the chapter's) with the fields replaced. An electron-level camera
        (``noise_model="photon"``) stays a consistent device (:func:`with_sensor`): an ADC that spans the
        full well keeps spanning it at another bit depth (imx174 at 8 bits: 32,000 / 255 = 125.5 e-/DN,
        not 7.81 e-/DN clipping at a sixteenth of the well), and an angular resolution that is the pitch and
        focal length's follows the distance (px/deg at the focus distance, not at infinity).

    Raises
    ------
    ParameterError
        For a bit depth outside 0 to 32, sensor fields on a camera in digital units, or a field's bad value.

    Examples
    --------
    >>> from camsim_core import load_camera
    >>> imx = load_camera("imx174")
    >>> cam = with_settings(imx, bits=8, distance=3.32)
    >>> round(cam.electrons_per_dn, 1), round(cam.angular_resolution[0], 2), round(imx.angular_resolution[0], 2)
    (125.5, 35.87, 35.74)
    >>> with_settings(imx, bits=0).bits is None
    True
    >>> with_settings(load_camera("kodak-dcs200"), bits=12, distance=2.0).electrons_per_dn
    1.0
    """
    if bits is not ...:
        if isinstance(bits, (int, np.integer)) and not isinstance(bits, bool) and int(bits) == 0:
            bits = None
        elif bits is not None and not (isinstance(bits, (int, np.integer)) and not isinstance(bits, bool) and 1 <= bits <= 32):
            raise ParameterError("bits", f"must be a whole number from 1 to 32, or 0 (or None) for no quantization; got {bits!r}")
    sensor = dict(sensor or {})
    if camera.noise_model != "photon" and not sensor:
        return camera.replace(**changes, **({} if bits is ... else {"bits": bits}))
    # whether the pixel's angle follows the lens is read before the changes: a sheet's camera already at one
    # distance, moved to another, still follows it
    follows = "angular_resolution" not in changes and camera.noise_model == "photon" and _follows_lens(camera)
    cam = with_sensor(camera.replace(**changes) if changes else camera, bits=bits, **sensor)
    if follows:
        try:
            phi = _angular_resolution(cam)
        except ParameterError:  # focused inside the focal length: no angle of a pixel to follow
            return cam
        if phi != cam.angular_resolution:
            cam = cam.replace(angular_resolution=phi)
    return cam
