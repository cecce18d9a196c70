"""One test per kind of physically impossible value the camera, monitor and sensor readers used to accept.

Each bad file is refused with a CamsimError whose text names the file and the field (tag); a camera built
in code with the same values is refused with a ParameterError naming the field. The files are the shipped
ones with one value changed, so that everything else in them is known to be good.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from camsim_core.camera import Camera
from camsim_core.camera.camera import MAX_CAMERA_PIXELS, MAX_CAMERA_SIDE, check_camera_size
from camsim_core.camera.load import load_camera, read_scam
from camsim_core.camera.physical import SENSOR_SHEETS, physical_camera
from camsim_core.datasets import SIMTOOLBOX
from camsim_core.datasets.sensors import Sensors, read_dat_sensors
from camsim_core.errors import CamsimError, FileFormatError, ParameterError
from camsim_core.monitor import Monitor, load_monitor, read_smon

SCAM = SIMTOOLBOX / "cameras" / "kodakdcs200_50mmIR.Scam"
QUANTAL = SIMTOOLBOX / "cameras" / "quantal_50mm.Scam"
SMON = SIMTOOLBOX / "monitors" / "SimToolboxTest.Smon"
DAT = SIMTOOLBOX / "spectra" / "KodakDCS200.dat"


def _text(path):
    return path.read_bytes().decode("latin-1").replace("\r", "\n")


def _sub_after(text, tag, value, nth_line=1):
    """``text`` with the ``nth_line``-th line after the line ``tag`` replaced by ``value``."""
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == tag)
    lines[i + nth_line] = value
    return "\n".join(lines)


def _first_value_to(line, value):
    """A line of numbers with its first number replaced by ``value``."""
    parts = line.split()
    return " ".join([value] + parts[1:])


def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text, encoding="latin-1")
    return p


def _refused(reader, path, *words):
    with pytest.raises(CamsimError) as info:
        reader(path)
    msg = str(info.value)
    assert path.name in msg, msg
    for w in words:
        assert re.search(w, msg), (w, msg)
    return msg


def _dat(path):
    return read_dat_sensors(path, ("R", "G", "B"), "test")


# -- .dat sensors ----------------------------------------------------------------------------------
def test_dat_negative_sensitivity(tmp_path):
    text = _text(DAT)
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "#SimData")
    lines[i + 2] = _first_value_to(lines[i + 2], "-0.5")  # the second sensor (G) at the first wavelength, 380 nm
    p = _write(tmp_path, "neg.dat", "\n".join(lines))
    msg = _refused(_dat, p, "#SimData", ">= 0")
    assert "G is -0.5 at 380 nm" in msg


def test_dat_sensor_zero_at_every_wavelength(tmp_path):
    lines = _text(DAT).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "#SimData")
    lines[i + 3] = " ".join(["0"] * 81)  # B
    _refused(_dat, _write(tmp_path, "dead.dat", "\n".join(lines)), "#SimData", "B is 0 at every wavelength")


def test_dat_step_too_small_to_separate_wavelengths(tmp_path):
    p = _write(tmp_path, "step.dat", _sub_after(_text(DAT), "#SimWavelengthSampling", "380 1e-300 81"))
    _refused(_dat, p, "#SimWavelengthSampling", "does not separate")


# -- .Scam cameras ---------------------------------------------------------------------------------
def test_scam_negative_sensitivity(tmp_path):
    lines = _text(SCAM).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "#Sim#SpectralSensitivity")
    lines[i + 2] = _first_value_to(lines[i + 2], "-3")  # R at 380 nm
    p = _write(tmp_path, "neg.Scam", "\n".join(lines))
    msg = _refused(read_scam, p, "#Sim#SpectralSensitivity", ">= 0")
    assert "R is -3 at 380 nm" in msg


def test_scam_sensor_zero_at_every_wavelength(tmp_path):
    lines = _text(SCAM).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "#Sim#SpectralSensitivity")
    lines[i + 3] = " ".join(["0"] * 81)  # G
    _refused(read_scam, _write(tmp_path, "dead.Scam", "\n".join(lines)), "#Sim#SpectralSensitivity", "G is 0 at every")


def test_scam_quantum_efficiency_above_one(tmp_path):
    lines = _text(QUANTAL).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "#Sim#SpectralSensitivity")
    lines[i + 2] = _first_value_to(lines[i + 2], "1.5")
    _refused(read_scam, _write(tmp_path, "qe.Scam", "\n".join(lines)), "#Sim#SpectralSensitivity", "at most 1", "1.5")


@pytest.mark.parametrize("tag, value", [("#SimHeight", "1e40"), ("#SimWidth", "200000"), ("#SimHeight", "65537"),
                                        ("#SimWidth", "1e308")])
def test_scam_huge_height_or_width(tmp_path, tag, value):
    p = _write(tmp_path, "huge.Scam", _sub_after(_text(SCAM), tag, value))
    _refused(read_scam, p, tag, "at most 65536")


def test_scam_array_of_too_many_pixels(tmp_path):
    text = _sub_after(_sub_after(_text(SCAM), "#SimHeight", "60000"), "#SimWidth", "60000")  # 3.6e9 pixels
    _refused(read_scam, _write(tmp_path, "big.Scam", text), "#SimHeight x #SimWidth", "60000 x 60000", "at most 536870912")


def test_scam_largest_array_is_accepted(tmp_path):
    # 16384 x 32768 = 2**29 pixels: the limit itself loads
    text = _sub_after(_sub_after(_text(SCAM), "#SimHeight", "16384"), "#SimWidth", "32768")
    cam = read_scam(_write(tmp_path, "limit.Scam", text))
    assert (cam.height, cam.width) == (16384, 32768)


@pytest.mark.parametrize("value", ["1e308", "1e15", "5e-324", "0", "-102.6"])
def test_scam_angular_resolution_out_of_range(tmp_path, value):
    p = _write(tmp_path, "ang.Scam", _sub_after(_text(SCAM), "##SimX", value))
    _refused(read_scam, p, "AngularResolution ##SimX")


@pytest.mark.parametrize("value", ["1e308", "1e-308", "-1e-4", "0", "nan"])
def test_quantal_pixel_pitch_out_of_range(tmp_path, value):
    p = _write(tmp_path, "pitch.Scam", _sub_after(_text(QUANTAL), "#SimPixelHeight", value))
    _refused(read_scam, p, "#SimPixelHeight")


@pytest.mark.parametrize("tag, value", [("#SimLens", "0"), ("#SimLens", "-50"), ("#SimCalExposureTime", "0"),
                                        ("#SimCalExposureTime", "-1"), ("#SimCalFStop", "0.1"), ("#SimCalFStop", "-5.6")])
def test_scam_lens_and_calibration_not_positive(tmp_path, tag, value):
    _refused(read_scam, _write(tmp_path, "cal.Scam", _sub_after(_text(SCAM), tag, value)), tag)


def test_scam_negative_noise_variance(tmp_path):
    p = _write(tmp_path, "noise.Scam", _text(SCAM) + "\n##SimNoise\n##SimType\ngaussianIID\n##SimVariance\n-0.01\n##SimEnd\n")
    _refused(read_scam, p, "##SimVariance", "at least 0")


def test_scam_sensitivities_written_as_a_section(tmp_path):
    p = _write(tmp_path, "section.Scam", _text(SCAM).replace("#Sim#SpectralSensitivity", "#SimSpectralSensitivity"))
    _refused(read_scam, p, "#Sim#SpectralSensitivity", "must be a matrix")


# -- .Smon monitors --------------------------------------------------------------------------------
def _ambient_lines(text):
    lines = text.split("\n")
    return lines, next(k for k, line in enumerate(lines) if line.strip() == "#Sim#AmbientSpectrum")


def test_smon_negative_ambient(tmp_path):
    lines, i = _ambient_lines(_text(SMON))
    lines[i + 2] = "-0.25"  # the first wavelength, 380 nm
    msg = _refused(read_smon, _write(tmp_path, "amb.Smon", "\n".join(lines)), "#Sim#AmbientSpectrum", ">= 0")
    assert "-0.25 at 380 nm" in msg


def test_smon_ambient_of_the_wrong_size(tmp_path):
    lines, i = _ambient_lines(_text(SMON))
    lines[i + 1] = "50 2"  # 100 values where 101 wavelengths need 101
    _refused(read_smon, _write(tmp_path, "amb.Smon", "\n".join(lines)), "#Sim#AmbientSpectrum", "100 values for 101")


@pytest.mark.parametrize("value", ["1.5", "-0.1"])
def test_smon_background_outside_0_1(tmp_path, value):
    lines = _text(SMON).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "#Sim#BgColor")
    j = next(k for k in range(i + 2, len(lines)) if lines[k].strip())
    lines[j] = value
    _refused(read_smon, _write(tmp_path, "bg.Smon", "\n".join(lines)), "#Sim#BgColor", r"\[0, 1\]")


def test_smon_emission_spectra_written_as_a_section(tmp_path):
    p = _write(tmp_path, "sec.Smon", _text(SMON).replace("#Sim#EmissionSpectra", "#SimEmissionSpectra"))
    _refused(read_smon, p, "#Sim#EmissionSpectra", "must be a matrix")


def test_smon_gamma_input_written_as_a_group(tmp_path):
    p = _write(tmp_path, "grp.Smon", _text(SMON).replace("#Sim#GammaInput", "##SimGammaInput\n##SimX"))
    _refused(read_smon, p, "#Sim#GammaInput")


def test_shipped_files_still_load():
    assert read_scam(SCAM).sensors.values.min() == pytest.approx(0.241447)
    assert read_smon(SMON).ambient.min() == pytest.approx(7.048e-07)
    assert _dat(DAT).values.shape == (3, 81)
    for name in ("human-cones", "cie1931", "gaussian-4", "imx174", "phone-1.4um", "mixture-0.5"):
        assert load_camera(name).height >= 1


# -- cameras and monitors built in code -------------------------------------------------------------
def _sensors(values):
    return Sensors(np.array([500.0, 550.0, 600.0]), values, ("A", "B"), "Watts", "s")


def test_camera_with_negative_sensitivities():
    with pytest.raises(ParameterError, match=r"sensors: .*>= 0.*B is -1 at 550 nm"):
        Camera(sensors=_sensors([[1, 2, 3], [1, -1, 3]]))


@pytest.mark.parametrize("height, width", [(1e40, 10), (200000, 200000), (10, 65537), (float("nan"), 10),
                                           (float("inf"), 10), (2.5, 10), ("100", 10), (True, 10), (0, 10)])
def test_camera_with_an_absurd_or_wrong_array(height, width):
    cam = load_camera("kodak-dcs200-ir")
    with pytest.raises(ParameterError, match="height, width"):
        cam.replace(height=height, width=width)


def test_camera_array_limits():
    assert (MAX_CAMERA_SIDE, MAX_CAMERA_PIXELS) == (65536, 2**29)
    cam = load_camera("kodak-dcs200-ir").replace(height=6144.0, width=8192)  # 50 MP, given as a whole float
    assert (cam.height, cam.width) == (6144, 8192) and type(cam.height) is int
    with pytest.raises(ParameterError, match="65536 x 65536 = 4294967296 pixels"):
        check_camera_size(65536, 65536)


@pytest.mark.parametrize("changes, field", [
    (dict(angular_resolution=(1e308, 1e308)), "angular_resolution"),
    (dict(angular_resolution=(5e-324, 100.0)), "angular_resolution"),
    (dict(angular_resolution="wide"), "angular_resolution"),
    (dict(pixel_size=(1.0, 1.0)), "pixel_size"),
    (dict(pixel_size=(1e-300, 1e-300)), "pixel_size"),
    (dict(distance=1e-308), "distance"),
    (dict(distance=float("nan")), "distance"),
    (dict(noise_mean="abc"), "noise_mean"),
    (dict(noise_sigma="1"), "noise_sigma"),
])
def test_camera_fields_out_of_range(changes, field):
    with pytest.raises(ParameterError) as info:
        load_camera("kodak-dcs200-ir").replace(**changes)
    assert info.value.name == field


def test_monitor_built_with_negative_ambient_or_a_bad_background():
    m = load_monitor("simtoolbox-test")
    with pytest.raises(ParameterError, match="ambient"):
        Monitor(m.wavelengths, m.primaries, m.gamma_input, m.gamma_table, -np.ones(m.wavelengths.size))
    with pytest.raises(ParameterError, match="background"):
        Monitor(m.wavelengths, m.primaries, m.gamma_input, m.gamma_table, None, (0.5, 2.0, 0.5))
    with pytest.raises(ParameterError, match="primaries"):
        Monitor(m.wavelengths, -m.primaries, m.gamma_input, m.gamma_table)
    with pytest.raises(ParameterError, match="bits"):
        Monitor(m.wavelengths, m.primaries, m.gamma_input, m.gamma_table, bits=64)


# -- sensor sheets (physical cameras) ----------------------------------------------------------------
@pytest.mark.parametrize("field, value", [("height", 1e40), ("height", 2.5), ("bits", 1000000000), ("read_noise", -7.0),
                                          ("qe_peak", {"R": 0.5, "G": 1.5, "B": 0.5}), ("qe_peak", {"R": 0.5}),
                                          ("qe_sigma_nm", {"R": 30, "G": 0, "B": 30}), ("full_well", "lots")])
def test_sensor_sheet_field_out_of_range(tmp_path, field, value):
    sheet = json.loads((SENSOR_SHEETS / "imx174.json").read_text())
    sheet[field] = value
    p = tmp_path / f"bad-{field}.json"
    p.write_text(json.dumps(sheet))
    with pytest.raises(FileFormatError) as info:
        physical_camera(str(p))
    assert p.name in str(info.value) and field in str(info.value)
