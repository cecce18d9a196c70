"""One test per kind of bad file the reader audit found: each is refused with a CamsimError naming the file
and the field, or (for overexposure) simulated as saturation, never a traceback from numpy or a wrong image."""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.camera.load import read_scam
from camsim_core.datasets import SIMTOOLBOX
from camsim_core.errors import CamsimError
from camsim_core.monitor import read_smon
from camsim_core.scene import macbeth_scene, read_npz_scene, read_simg

SCAM = SIMTOOLBOX / "cameras" / "kodakdcs200_50mmIR.Scam"
SMON = SIMTOOLBOX / "monitors" / "SimToolboxTest.Smon"


def _text(path):
    return path.read_bytes().decode("latin-1").replace("\r", "\n")


def _sub_after(text, tag, value, nth_line=1):
    """``text`` with the ``nth_line``-th line after the line ``tag`` replaced by ``value``."""
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == tag)
    lines[i + nth_line] = value
    return "\n".join(lines)


@pytest.fixture
def simg_dir(tmp_path):
    for f in (SIMTOOLBOX / "BFGB_128").iterdir():
        if f.name == "BFGB_128.Simg" or f.name.isdigit():
            shutil.copy(f, tmp_path / f.name)
    return tmp_path


def _refused(reader, path, *words):
    with pytest.raises(CamsimError) as info:
        reader(path)
    msg = str(info.value)
    assert path.name in msg, msg
    for w in words:
        assert re.search(w, msg), (w, msg)
    return msg


@pytest.mark.parametrize("value", ["nan", "inf", "-128", "0", "127.5"])
def test_simg_height_not_a_positive_whole_number(simg_dir, value):
    h = simg_dir / "BFGB_128.Simg"
    h.write_text(_sub_after(_text(h), "#SimHeight", value), encoding="latin-1")
    _refused(read_simg, h, "#SimHeight")


@pytest.mark.parametrize("value", ["nan", "inf", "-31", "0", "30.5"])
def test_simg_number_of_samples_bad(simg_dir, value):
    h = simg_dir / "BFGB_128.Simg"
    h.write_text(_sub_after(_text(h), "##SimNumberSamples", value), encoding="latin-1")
    _refused(read_simg, h, "NumberSamples")


def test_simg_empty_start_value(simg_dir):
    h = simg_dir / "BFGB_128.Simg"
    h.write_text(_sub_after(_text(h), "##SimStart", ""), encoding="latin-1")
    _refused(read_simg, h, "Start")


@pytest.mark.parametrize("value", ["nan", "-10", "0"])
def test_simg_step_nan_or_not_positive(simg_dir, value):
    h = simg_dir / "BFGB_128.Simg"
    h.write_text(_sub_after(_text(h), "##SimStep", value), encoding="latin-1")
    _refused(read_simg, h, "Step")


@pytest.mark.parametrize("value", ["nan", "inf", "-1", "2.5"])
def test_scam_bits_bad(tmp_path, value):
    p = tmp_path / "cam.Scam"
    p.write_text(_sub_after(_text(SCAM), "##SimBits", value), encoding="latin-1")
    _refused(read_scam, p, "Bits")


@pytest.mark.parametrize("value", ["nan", "inf", "-3", "0", "2.5"])
def test_scam_number_of_sensors_bad(tmp_path, value):
    p = tmp_path / "cam.Scam"
    p.write_text(_sub_after(_text(SCAM), "#SimNumberSensors", value), encoding="latin-1")
    _refused(read_scam, p, "NumberSensors")


def test_matrix_header_minus_one(tmp_path):
    p = tmp_path / "cam.Scam"
    p.write_text(_text(SCAM).replace("#Sim#SpectralSensitivity\n", "#Sim#SpectralSensitivity\n-1 -1\n", 1)
                 if "#Sim#SpectralSensitivity\n" in _text(SCAM) else re.sub(r"(#Sim#SpectralSensitivity)\s*\n\s*\d+\s+\d+", r"\1\n-1 -1", _text(SCAM)),
                 encoding="latin-1")
    _refused(read_scam, p, "SpectralSensitivity", "whole numbers")


def test_fractional_mosaic_indices(tmp_path):
    text = _text(SCAM)
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip() == "##SimMosaic")
    lines[i + 1] = "1.5 " + " ".join(lines[i + 1].split()[1:]) if len(lines[i + 1].split()) > 1 else "1.5"
    p = tmp_path / "cam.Scam"
    p.write_text("\n".join(lines), encoding="latin-1")
    _refused(read_scam, p, "Mosaic", "whole sensor numbers")


def test_fractional_camera_height(tmp_path):
    p = tmp_path / "cam.Scam"
    p.write_text(_sub_after(_text(SCAM), "#SimHeight", "1012.5"), encoding="latin-1")
    _refused(read_scam, p, "Height", "whole number")


def _npz(tmp_path, **changes):
    s = macbeth_scene(patch_size=4, border=1)
    arrays = dict(data=s.data, wavelengths=s.wavelengths, distance=np.float64(1.0))
    arrays.update(changes)
    p = tmp_path / "bad.npz"
    np.savez(p, **arrays)
    return p


@pytest.mark.parametrize("changes, words", [
    ({"distance": np.array([1.0, 2.0])}, "'distance' must be one number"),
    ({"distance": np.array("far")}, "'distance' must hold real numbers"),
    ({"wavelengths": np.array(["400"] * 31)}, "'wavelengths' must hold real numbers"),
    ({"data": np.zeros((0, 24, 31))}, "at least one pixel"),
    ({"data": np.zeros((4, 4, 31)) + 1j}, "'data' must hold real numbers, found dtype complex"),
    ({"data": np.zeros((4, 4, 31), dtype="timedelta64[s]")}, "'data' must hold real numbers, found dtype timedelta"),
    ({"illuminant": -np.ones(31)}, "'illuminant' must be finite and non-negative"),
    ({"illuminant": np.full(31, np.nan)}, "'illuminant' must be finite and non-negative"),
    ({"wavelengths": np.r_[np.nan, np.arange(410.0, 710.0, 10.0)]}, "'wavelengths' must be finite"),
])
def test_npz_metadata_of_the_wrong_type_shape_or_value(tmp_path, changes, words):
    _refused(read_npz_scene, _npz(tmp_path, **changes), re.escape(words))


def test_nan_in_monitor_emission_spectra_is_refused_quietly(tmp_path, capfd):
    text = _text(SMON)
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip().startswith("#Sim#EmissionSpectra"))
    lines[i + 2] = "NaN " + " ".join(lines[i + 2].split()[1:])
    p = tmp_path / "mon.Smon"
    p.write_text("\n".join(lines), encoding="latin-1")
    _refused(read_smon, p, "EmissionSpectra", "NaN")
    assert capfd.readouterr().out == ""  # nothing from LAPACK on stdout


@pytest.mark.parametrize("tag, bad, words", [
    ("#Sim#GammaTable", "inf", "GammaTable"),
    ("#Sim#EmissionSpectra", "-inf", "EmissionSpectra"),
])
def test_non_finite_gamma_tables_and_primaries(tmp_path, tag, bad, words):
    lines = _text(SMON).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip().startswith(tag))
    lines[i + 3] = bad + " " + " ".join(lines[i + 3].split()[1:])
    p = tmp_path / "mon.Smon"
    p.write_text("\n".join(lines), encoding="latin-1")
    _refused(read_smon, p, words)


def _monitor_with_gamma(tmp_path, rows):
    text = _text(SMON)
    text = re.sub(r"#Sim#GammaInput\s*\n\s*\d+\s+\d+\s*\n(?:[^#].*\n)*", "#Sim#GammaInput\n%d 1\n%s\n" % (
        len(rows), "\n".join(f"{r[0]}" for r in rows)), text)
    text = re.sub(r"#Sim#GammaTable\s*\n\s*\d+\s+\d+\s*\n(?:[^#].*\n)*", "#Sim#GammaTable\n%d 3\n%s\n" % (
        len(rows), "\n".join(" ".join(str(v) for v in r[1:]) for r in rows)), text)
    p = tmp_path / "mon.Smon"
    p.write_text(text, encoding="latin-1")
    return p


def test_all_zero_or_one_entry_gamma_tables_are_refused(tmp_path):
    assert read_smon(_monitor_with_gamma(tmp_path, [(0, 0, 0, 0), (1, 1, 1, 1)])).gamma_input.size == 2
    _refused(read_smon, _monitor_with_gamma(tmp_path, [(0, 0, 0, 0), (1, 0, 0, 0)]), "all-zero table renders black")
    _refused(read_smon, _monitor_with_gamma(tmp_path, [(1, 1, 1, 1)]), "at least 2")


def test_negative_simg_illuminant_is_refused(simg_dir):
    h = simg_dir / "BFGB_128.Simg"
    text = _text(h) + "#SimActualIlluminant\n##SimS\n400 10 3\n##SimSpd\n1 -2 3\n##SimEnd\n"
    h.write_text(text, encoding="latin-1")
    _refused(read_simg, h, "ActualIlluminant", "negative")


def test_errors_name_the_file_for_non_finite_sensitivities(tmp_path):
    lines = _text(SCAM).split("\n")
    i = next(k for k, line in enumerate(lines) if line.strip().startswith("#Sim#SpectralSensitivity"))
    lines[i + 2] = "nan " + " ".join(lines[i + 2].split()[1:])
    p = tmp_path / "cam.Scam"
    p.write_text("\n".join(lines), encoding="latin-1")
    _refused(read_scam, p, "SpectralSensitivity")


def test_overexposure_saturates_instead_of_writing_zeros():
    scene = macbeth_scene(patch_size=4, border=1)
    cam = cs.load_camera("kodak-dcs200-ir").replace(noise_sigma=0.0, exposure=1e308)
    with np.errstate(all="ignore"):
        raw = cs.simulate(scene, cam)
    # every pixel that gets light saturates: all those a normal exposure records, and no value lies between.
    # The black border's pixels get none (zero light times any exposure is zero), so they may stay at 0
    seen = cs.simulate(scene, cam.replace(exposure=0.1)).data > 0
    assert seen.mean() > 0.5
    assert np.all(raw.data[seen] == 2 ** cam.bits - 1)
    assert set(np.unique(raw.data)) <= {0.0, 2.0 ** cam.bits - 1} and np.mean(raw.data > 0) > seen.mean()


def test_f_stop_of_1e_308_is_refused_not_simulated_black():
    with pytest.raises(CamsimError, match="f_stop"):
        cs.load_camera("kodak-dcs200-ir").replace(f_stop=1e-308)


def test_huge_radiance_saturates(tmp_path):
    s = macbeth_scene(patch_size=4, border=1)
    scene = cs.Scene(np.full_like(s.data, 1e308), s.wavelengths)
    with np.errstate(all="ignore"):
        raw = cs.simulate(scene, cs.load_camera("kodak-dcs200-ir").replace(noise_sigma=0.0))
    assert np.all(raw.data == 255)
