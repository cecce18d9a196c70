"""DNG out, raws in: LibRaw (rawpy) is the independent client that must read camsim's DNG."""

import colour
import numpy as np
import pytest
import rawpy

import camsim_core as cs
from camsim_core.errors import FileFormatError, ParameterError
from camsim_core.io.dng import color_matrix


@pytest.fixture(scope="module")
def dcs_raw():
    cam = cs.load_camera("kodak-dcs200-ir")
    return cs.simulate(cs.load_scene("cacaphony290"), cam, distance=3.32, exposure=0.1, f_stop=11, seed=0)


def _libraw_linear(path):
    with rawpy.imread(str(path)) as r:
        return r.postprocess(demosaic_algorithm=rawpy.DemosaicAlgorithm.LINEAR, output_color=rawpy.ColorSpace.raw,
                             gamma=(1, 1), no_auto_bright=True, output_bps=16, user_wb=[1, 1, 1, 1],
                             use_camera_wb=False, use_auto_wb=False, user_flip=0)


def test_rawpy_reads_pattern_levels_and_demosaics_like_camsim(tmp_path, dcs_raw):
    path = cs.write_dng(dcs_raw, tmp_path / "dcs.dng")
    with rawpy.imread(str(path)) as r:
        desc = r.color_desc.decode()
        pattern = np.vectorize(lambda i: "RGB".index(desc[i]))(r.raw_pattern)
        np.testing.assert_array_equal(pattern, dcs_raw.tile)  # G R / B G, R G B = 0 1 2
        assert r.white_level == 255 and list(r.black_level_per_channel) == [0, 0, 0, 0]
        np.testing.assert_array_equal(r.raw_image_visible, dcs_raw.data)
    libraw = _libraw_linear(path)
    camsim = cs.demosaic(dcs_raw, "bilinear").data
    for c in range(3):
        assert np.corrcoef(libraw[..., c].ravel(), camsim[..., c].ravel())[0, 1] > 0.99


def test_libraw_reads_the_colour_matrix(tmp_path, dcs_raw):
    path = cs.write_dng(dcs_raw, tmp_path / "dcs.dng")
    with rawpy.imread(str(path)) as r:
        rgb_cam = np.asarray(r.color_matrix)[:, :3]
    # LibRaw's camera -> sRGB matrix from ColorMatrix1 (XYZ -> camera): invert cam_xyz @ xyz_rgb, rows normalized
    cam_xyz, _ = color_matrix(dcs_raw.sensitivities, dcs_raw.wavelengths)
    cam_rgb = cam_xyz @ colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ
    cam_rgb = cam_rgb / cam_rgb.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(rgb_cam, np.linalg.inv(cam_rgb), atol=2e-3)


def test_colour_matrix_of_xyz_sensors_is_the_identity_up_to_scale():
    from camsim_core.datasets.sensors import cie1931_xyz

    w = np.arange(400.0, 701.0, 10.0)
    xyz = cie1931_xyz().on(w)
    # sensors = x-bar, y-bar, z-bar listed as (Z, Y, X) so the ranking by wavelength must reorder them
    m, neutral = color_matrix(xyz[::-1], w)
    np.testing.assert_allclose(m / m[0, 0], np.eye(3), atol=1e-9)


def test_black_level_round_trip_and_load_raw(tmp_path):
    cam = cs.load_camera("kodak-dcs200-ir").replace(black_level=16.0, bits=10)
    raw = cs.simulate(cs.load_scene("bfgb128"), cam, exposure=0.5, seed=1)
    path = cs.write_dng(raw, tmp_path / "black.dng")
    with rawpy.imread(str(path)) as r:
        assert list(r.black_level_per_channel) == [16, 16, 16, 16] and r.white_level == 1023
        assert r.raw_image_visible.min() >= 16
    back = cs.load_raw(path)
    np.testing.assert_array_equal(back.data, raw.data)  # the pedestal stays in the data
    assert back.black_level == 16.0
    np.testing.assert_array_equal(back.tile, raw.tile)
    np.testing.assert_allclose(back.sensitivities, raw.sensitivities)
    assert back.bits == 10 and back.mosaiced and back.gain == pytest.approx(raw.gain)
    np.testing.assert_allclose(cs.demosaic(back).data, cs.demosaic(raw).data)
    # and the real raw goes through the same processing
    rendered = cs.render(cs.demosaic(back), "simtoolbox-test")
    assert rendered.data.shape == raw.data.shape + (3,)


def test_load_raw_of_a_foreign_dng_has_no_sensitivities(tmp_path, dcs_raw):
    import tifffile

    path = cs.write_dng(dcs_raw, tmp_path / "x.dng")
    # strip camsim's metadata: a DNG from another writer
    with tifffile.TiffFile(path) as tf:
        assert tf.pages[0].description.startswith("{")
    data = bytearray(path.read_bytes())
    i = data.find(b'{"name"')
    data[i : i + 7] = b"foreign"
    path.write_bytes(bytes(data))
    img = cs.load_raw(path)
    assert img.sensitivities is None and img.bits == 8
    np.testing.assert_array_equal(img.tile, dcs_raw.tile)
    np.testing.assert_array_equal(img.data, dcs_raw.data)


def test_bad_raws_and_bad_dng_requests(tmp_path, dcs_raw):
    (tmp_path / "fake.dng").write_bytes(b"II*\0 not really a dng")
    with pytest.raises(FileFormatError, match="fake.dng.*LibRaw"):
        cs.load_raw(tmp_path / "fake.dng")
    with pytest.raises(FileFormatError, match="(?i)no such file"):
        cs.load_raw(tmp_path / "missing.nef")
    with pytest.raises(ParameterError, match="before demosaicing"):
        cs.write_dng(cs.demosaic(dcs_raw), tmp_path / "x.dng")
    with pytest.raises(ParameterError, match="16 bits"):
        cs.write_dng(dcs_raw.replace(quantized=False, bits=None), tmp_path / "x.dng")
    assert not (tmp_path / "x.dng").exists()


def test_cli_simulate_writes_a_dng(tmp_path, capsys):
    from camsim_core.cli import main

    out = tmp_path / "edge.dng"
    assert main(["simulate", "--scene", "bfgb128", "--camera", "kodak-dcs200-ir", "--auto-exposure", "--bits", "12",
                 "--black-level", "64", "--out", str(out)]) == 0
    with rawpy.imread(str(out)) as raw:
        assert raw.white_level == 4095 and list(raw.black_level_per_channel) == [64] * 4
    assert main(["simulate", "--scene", "bfgb128", "--camera", "kodak-dcs200-ir", "--render", "baseline",
                 "--out", str(tmp_path / "r.dng")]) == 2
    assert "DNG holds the raw mosaic" in capsys.readouterr().err and not (tmp_path / "r.dng").exists()
