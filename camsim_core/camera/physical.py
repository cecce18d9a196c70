"""Physical camera presets: real sensors in electrons behind a diffraction-limited lens.

Each preset is a JSON file in ``assets/sensors/`` holding the sensor's
published parameters (pitch, array size, saturation capacity, read noise,
ADC bits, lens), with its ``source`` and what was ``derived`` or
``assumed`` stated beside the numbers. The camera built from it has
quantal sensitivities (QE curves), the electron-level sensor
(``noise_model="photon"``, EMVA 1288 fields), ``optics="diffraction"``
with cos^4 relative illumination, and the angular resolution that its
pitch and focal length give (pitch / focal length radians per pixel).
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..datasets.sensors import WAVELENGTHS_380_780, Sensors
from ..errors import FileFormatError
from ..simulation import bayer
from .camera import Camera

__all__ = ["PHYSICAL_NAMES", "physical_camera", "read_sensor_sheet", "angular_resolution_for"]

SENSOR_SHEETS = Path(__file__).resolve().parents[2] / "assets" / "sensors"

#: Shipped physical presets (files ``assets/sensors/NAME.json``).
PHYSICAL_NAMES = ("phone-1.4um", "imx174")

_REQUIRED = ("pixel_pitch_um", "height", "width", "qe_peak", "qe_center_nm", "qe_sigma_nm", "full_well", "read_noise",
             "dark_current", "dsnu", "prnu", "bits", "focal_length_mm", "f_number", "source")


@lru_cache(maxsize=8)
def read_sensor_sheet(path):
    """The parameters of a sensor sheet (JSON), checked for the fields a camera needs."""
    p = Path(path)
    try:
        sheet = json.loads(p.read_text())
    except FileNotFoundError:
        raise FileFormatError(p, "no such sensor sheet") from None
    except (OSError, ValueError) as exc:
        raise FileFormatError(p, f"not a JSON sensor sheet: {exc}") from None
    missing = [k for k in _REQUIRED if k not in sheet]
    if missing:
        raise FileFormatError(p, f"missing field(s) {', '.join(missing)}")
    return sheet


def angular_resolution_for(pitch_m, focal_length_mm):
    """Pixels per degree of a pixel pitch behind a lens: 1 / degrees(atan(pitch / f))."""
    return 1.0 / np.degrees(np.arctan(float(pitch_m) / (float(focal_length_mm) * 1e-3)))


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
    return cam.replace(**changes) if changes else cam
