"""A camsim DNG's exposure, f-number and ISO as raw tools read them: LibRaw (rawpy), tifffile, exiftool."""

import json
import shutil
import subprocess

import numpy as np
import pytest
import rawpy
import tifffile

import camsim_core as cs
from camsim_core.errors import ParameterError


@pytest.fixture(scope="module")
def raw():
    cam = cs.load_camera("kodak-dcs200-ir")
    return cs.simulate(cs.load_scene("bfgb128"), cam, exposure=0.125, f_stop=5.6, seed=0)


def test_libraw_reads_exposure_f_number_and_iso(tmp_path, raw):
    path = cs.write_dng(raw, tmp_path / "shot.dng", analog_gain=4.0)
    with rawpy.imread(str(path)) as r:
        other = r.other
        np.testing.assert_array_equal(r.raw_image_visible, raw.data)  # the pixels are untouched
    assert other.shutter_speed == pytest.approx(0.125, rel=1e-6)
    assert other.aperture == pytest.approx(5.6, rel=1e-6)
    assert other.iso_speed == 400  # ISO 100 x the analog gain


def test_exif_ifd_holds_the_tags_as_exif_defines_them(tmp_path, raw):
    path = cs.write_dng(raw, tmp_path / "shot.dng")
    with tifffile.TiffFile(path) as tf:
        page = tf.pages[0]
        exif = page.tags["ExifTag"].value  # tifffile follows IFD 0's pointer to the EXIF IFD
        meta = json.loads(page.description)
    assert exif["ExposureTime"] == (1, 8) and exif["FNumber"] == (28, 5)
    assert exif["ISOSpeedRatings"] == 100 and exif["ExifVersion"] == "0230"
    assert meta["exposure_s"] == 0.125 and meta["f_stop"] == 5.6  # camsim's own metadata stays
    back = cs.load_raw(path)
    assert back.exposure == 0.125 and back.f_stop == 5.6


@pytest.mark.parametrize("exposure, expected", [(1e-6, (1, 1_000_000)), (1 / 3, (1, 3)), (30.0, (30, 1)),
                                                (0.0166, (83, 5000))])
def test_exposures_are_exact_rationals(tmp_path, raw, exposure, expected):
    path = cs.write_dng(raw.replace(exposure=exposure), tmp_path / "t.dng")
    with tifffile.TiffFile(path) as tf:
        assert tf.pages[0].tags["ExifTag"].value["ExposureTime"] == expected


def test_iso_is_bounded_and_bad_values_are_refused(tmp_path, raw):
    path = cs.write_dng(raw, tmp_path / "hi.dng", analog_gain=1000.0)
    with rawpy.imread(str(path)) as r:
        assert r.other.iso_speed == 65535  # EXIF's ISOSpeedRatings is a 16-bit count
    with pytest.raises(ParameterError, match="analog_gain"):
        cs.write_dng(raw, tmp_path / "x.dng", analog_gain=0.0)
    with pytest.raises(ParameterError, match="exposure"):
        cs.write_dng(raw.replace(exposure=float("nan")), tmp_path / "x.dng")
    assert not (tmp_path / "x.dng").exists()


@pytest.mark.skipif(shutil.which("exiftool") is None, reason="exiftool is not installed (Debian: libimage-exiftool-perl)")
def test_exiftool_shows_them_and_validates_the_file(tmp_path, raw):
    path = cs.write_dng(raw, tmp_path / "shot.dng", analog_gain=2.0)
    out = subprocess.run(["exiftool", "-j", "-n", "-validate", "-warning", "-ExposureTime", "-FNumber", "-ISO",
                          str(path)], capture_output=True, text=True, check=True, timeout=60)
    tags = json.loads(out.stdout)[0]
    assert tags["ExposureTime"] == 0.125 and tags["FNumber"] == 5.6 and tags["ISO"] == 200
    assert tags["Validate"] in ("OK", "0 0 0") and "Warning" not in tags  # -n gives errors, warnings, minor counts
