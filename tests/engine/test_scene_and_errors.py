"""Scenes (.npz round trip, generators) and every bad-input path: clear errors, no output file."""

import dataclasses
import json
import numpy as np
import pytest
import tifffile

import camsim_core as cs
from camsim_core.cli import main
from camsim_core.datasets.sensors import Sensors
from camsim_core.scene import Scene, read_npz_scene, save_npz_scene, stripe_scene

W31 = np.arange(400, 701, 10.0)


def test_npz_round_trip(tmp_path, cacaphony):
    p = save_npz_scene(cacaphony, tmp_path / "c.npz")
    back = cs.load_scene(p)
    np.testing.assert_array_equal(back.data, cacaphony.data)
    np.testing.assert_array_equal(back.wavelengths, cacaphony.wavelengths)
    assert back.distance == cacaphony.distance and back.angular_resolution == cacaphony.angular_resolution
    # the measured illuminant is per 5 nm band; saved per 10 nm band of the scene, it doubles
    np.testing.assert_allclose(back.illuminant.values, 2 * cacaphony.illuminant.on(cacaphony.wavelengths))


def test_npz_with_object_array_is_refused_without_unpickling(tmp_path):
    p = tmp_path / "evil.npz"
    np.savez(p, data=np.array([{"a": 1}], dtype=object), wavelengths=W31)
    with pytest.raises(cs.FileFormatError, match="evil.npz"):
        read_npz_scene(p)


def test_npz_missing_key(tmp_path):
    p = tmp_path / "nowl.npz"
    np.savez(p, data=np.zeros((4, 4, 31)))
    with pytest.raises(cs.FileFormatError, match="'wavelengths' is missing"):
        cs.load_scene(p)


def test_npz_not_a_zip(tmp_path):
    p = tmp_path / "junk.npz"
    p.write_bytes(b"not a zip at all")
    with pytest.raises(cs.FileFormatError, match="junk.npz"):
        cs.load_scene(p)


def test_nan_radiance_is_an_error():
    data = np.full((4, 4, 31), 0.1)
    data[1, 2, 3] = np.nan
    with pytest.raises(cs.ParameterError, match="1 NaN"):
        Scene(data, W31)


def test_negative_radiance_is_an_error_or_an_explicit_clip(tmp_path):
    data = np.full((4, 4, 31), 0.1)
    data[0, 0, :2] = -0.01
    with pytest.raises(cs.ParameterError, match="2 negative"):
        Scene(data, W31)
    p = tmp_path / "neg.npz"
    np.savez(p, data=data, wavelengths=W31)
    with pytest.raises(cs.ParameterError, match="negative"):
        cs.load_scene(p)
    with pytest.warns(UserWarning, match="2 negative radiance values clipped"):
        s = cs.load_scene(p, negative="clip")
    assert s.data.min() == 0.0


def test_sensitivities_outside_the_scene_range_are_an_error(cacaphony):
    ir = Sensors(np.arange(800, 901, 10.0), np.ones((3, 11)), ("a", "b", "c"))
    cam = cs.load_camera("kodak-dcs200-ir").replace(sensors=ir)
    with pytest.raises(cs.ParameterError, match="800-900 nm.*does not overlap.*400-700"):
        cs.simulate(cacaphony, cam)


def test_tile_naming_a_missing_sensor_is_an_error(dcs200_ir):
    with pytest.raises(cs.ParameterError, match=r"mosaic: tile names sensor index 3.*3 sensors"):
        dcs200_ir.replace(mosaic=np.array([[0, 1], [2, 3]]))


@pytest.mark.parametrize("sigma", [-1.0, np.nan])
def test_negative_sigma_is_an_error(dcs200_ir, sigma):
    with pytest.raises(cs.ParameterError, match="noise_sigma"):
        dcs200_ir.replace(noise_sigma=sigma)


@pytest.mark.parametrize("bits", [0, 33, 2.5])
def test_bits_out_of_range_are_an_error(dcs200_ir, bits):
    with pytest.raises(cs.ParameterError, match="bits: must be a whole number from 1 to 32"):
        dcs200_ir.replace(bits=bits)


@pytest.mark.parametrize("field,value", [("exposure", 0.0), ("f_stop", -2.0), ("distance", 0.0)])
def test_non_positive_settings_are_errors(dcs200_ir, field, value):
    with pytest.raises(cs.ParameterError, match=field):
        dcs200_ir.replace(**{field: value})


def test_stripe_scene_puts_green_on_every_blue_pixel_and_no_red_one():
    s = stripe_scene(8, 8)
    g = s.data[:, :, 13]  # 530 nm: green stripes high, white high
    b = s.data[:, :, 5]  # 450 nm: stripes low
    assert np.all(b[:, 0::2] < b[:, 1::2])
    assert np.allclose(g[:, 0::2], g[:, 1::2])


# --- the CLI --------------------------------------------------------------------------------


def test_cli_writes_the_dcs200_raw_of_the_chapter(tmp_path, cacaphony, dcs200_ir, capsys):
    out = tmp_path / "raw.tif"
    rc = main(["simulate", "--scene", "cacaphony290", "--camera", "kodak-dcs200-ir", "--distance", "3.32",
               "--exposure", "0.1", "--f-stop", "11", "--out", str(out)])
    assert rc == 0
    raw = tifffile.imread(out)
    assert raw.dtype == np.uint8 and raw.ndim == 2
    expected = cs.simulate(cacaphony, dcs200_ir, distance=3.32, exposure=0.1, f_stop=11)
    np.testing.assert_array_equal(raw, expected.data)
    meta = json.loads((tmp_path / "raw.tif.json").read_text())
    assert meta["tile"] == [[1, 0], [2, 1]] and meta["mosaiced"] and meta["bits"] == 8
    assert meta["exposure_s"] == 0.1 and meta["f_stop"] == 11 and meta["distance_m"] == 3.32


def test_cli_unquantized_output_goes_to_npy_and_not_to_tiff(tmp_path, capsys):
    out = tmp_path / "f.npy"
    assert main(["simulate", "--scene", "macbeth", "--camera", "cie1931", "--unquantized", "--out", str(out)]) == 0
    data = np.load(out, allow_pickle=False)
    assert data.shape[2] == 3 and not np.all(data == np.rint(data))
    assert main(["simulate", "--scene", "macbeth", "--camera", "cie1931", "--unquantized", "--out", str(tmp_path / "f.tif")]) == 2
    assert "not quantized" in capsys.readouterr().err
    assert not (tmp_path / "f.tif").exists() and not (tmp_path / "f.tif.json").exists()


def test_cli_16_bit_colour_png_is_refused_and_16_bit_tiff_written(tmp_path, capsys):
    assert main(["simulate", "--scene", "macbeth", "--camera", "cie1931", "--bits", "12", "--out", str(tmp_path / "x.png")]) == 2
    assert "use .tif" in capsys.readouterr().err
    assert main(["simulate", "--scene", "macbeth", "--camera", "cie1931", "--bits", "12", "--out", str(tmp_path / "x.tif")]) == 0
    assert tifffile.imread(tmp_path / "x.tif").dtype == np.uint16
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.tif", "x.tif.json"]


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--noise-sigma", "-1"], "noise_sigma"),
        (["--bits", "0"], "bits"),
        (["--bits", "33"], "bits"),
        (["--scene", "nowhere.npz"], "nowhere.npz: no such file"),
        (["--camera", "nope"], "nope"),
    ],
)
def test_cli_bad_input_prints_one_clear_line_and_writes_nothing(tmp_path, capsys, extra, message):
    out = tmp_path / "raw.tif"
    args = ["simulate", "--scene", "cacaphony290", "--camera", "kodak-dcs200-ir", "--out", str(out)]
    for i in range(0, len(extra), 2):
        if extra[i] in args:
            args[args.index(extra[i]) + 1] = extra[i + 1]
        else:
            args += extra[i : i + 2]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_cli_info(capsys):
    assert main(["info", "kodak-dcs200-ir"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["kind"] == "camera" and info["mosaic"] == [[1, 0], [2, 1]]
    assert main(["info", "cacaphony290"]) == 0
    assert json.loads(capsys.readouterr().out)["size_px"] == "182 x 290"
    assert main(["info", "nothing-here"]) == 2


def test_scale_light_scales_radiance_and_illuminant_and_keeps_reflectance():
    from camsim_core.scene import scale_light

    scene = cs.load_scene("cacaphony290")
    assert scale_light(scene, 1.0) is scene
    dim = scale_light(scene, 0.25)
    assert dim.data.dtype == scene.data.dtype and dim.data.shape == scene.data.shape
    np.testing.assert_allclose(dim.data, 0.25 * scene.data, rtol=1e-12)
    np.testing.assert_allclose(dim.illuminant.values, 0.25 * scene.illuminant.values, rtol=1e-12)
    # reflectance (radiance over illuminant, per band) is the scene's own
    def reflectance(sc):  # radiance over the illuminant at the scene's wavelengths
        e = np.interp(sc.wavelengths, sc.illuminant.wavelengths, sc.illuminant.values)
        return sc.data / e

    np.testing.assert_allclose(reflectance(dim), reflectance(scene), rtol=1e-12)
    f32 = Scene(scene.data.astype(np.float32), scene.wavelengths)
    assert scale_light(f32, 3.0).data.dtype == np.float32
    for bad in (0.0, -1.0, float("nan"), 1e9):
        with pytest.raises(cs.CamsimError, match="light"):
            scale_light(scene, bad)


def test_a_camera_responds_linearly_to_the_light_level():
    from camsim_core.scene import scale_light

    shipped = cs.load_scene("cacaphony290")
    scene = dataclasses.replace(shipped, data=shipped.data.astype(np.float64))  # linearity to float64 precision
    cam = cs.load_camera("kodak-dcs200-ir").replace(bits=None, noise_sigma=0.0)
    one = np.asarray(cs.simulate(scene, cam).data, float)
    three = np.asarray(cs.simulate(scale_light(scene, 3.0), cam).data, float)
    np.testing.assert_allclose(three, 3.0 * one, rtol=1e-9, atol=1e-9)
    # and in the shipped scene's float32, to its rounding
    one32 = np.asarray(cs.simulate(shipped, cam).data, float)
    three32 = np.asarray(cs.simulate(scale_light(shipped, 3.0), cam).data, float)
    np.testing.assert_allclose(three32, 3.0 * one32, rtol=2e-6)
