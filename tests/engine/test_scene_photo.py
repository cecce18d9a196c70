"""A photo as a scene: seen by the CIE 1931 camera, it gives back the photo's colours."""

import colour
import numpy as np
import pytest
from PIL import Image
from skimage import data as skdata
from skimage.transform import resize

import camsim_core as cs
from camsim_core.errors import FileFormatError, ParameterError
from camsim_core.scene import scene_from_rgb


def _xyz_camera(scene):
    h, w = scene.shape[:2]
    return cs.load_camera("cie1931").replace(mosaic=None, noise_sigma=0.0, bits=None, height=h, width=w,
                                             angular_resolution=scene.angular_resolution, distance=None)


def _lab_through_cie1931(scene, white_scene):
    xyz = cs.simulate(scene, _xyz_camera(scene)).data
    white = cs.simulate(white_scene, _xyz_camera(white_scene)).data[0, 0]
    return colour.XYZ_to_Lab(xyz / white[1], colour.XYZ_to_xy(white))


@pytest.fixture(scope="module")
def photo():
    rgb = resize(skdata.coffee(), (40, 60), anti_aliasing=True)  # float in [0, 1]
    return np.clip(rgb, 0, 1)


def test_cie1931_camera_recovers_photo_colours_within_1_de2000(photo):
    scene = scene_from_rgb(photo)
    lab = _lab_through_cie1931(scene, scene_from_rgb(np.ones((1, 1, 3))))
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    expected = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(photo), d65)
    de = colour.delta_E(lab, expected, method="CIE 2000")
    assert de.mean() < 1.0, de.mean()
    assert np.percentile(de, 95) < 2.0


def test_illuminant_and_luminance_act_physically(photo):
    d65 = scene_from_rgb(photo, luminance=100.0)
    bright = scene_from_rgb(photo, luminance=250.0)
    np.testing.assert_allclose(bright.data, 2.5 * d65.data, rtol=1e-12)  # linear in luminance
    a = scene_from_rgb(photo, illuminant="A")
    # the same surfaces under illuminant A, seen against D65's white, are much yellower
    lab_a = _lab_through_cie1931(a, scene_from_rgb(np.ones((1, 1, 3))))
    lab_d65 = _lab_through_cie1931(d65, scene_from_rgb(np.ones((1, 1, 3))))
    assert (lab_a[..., 2] - lab_d65[..., 2]).mean() > 10
    assert "plausible, not measured" in d65.notices[0]


def test_white_has_the_luminance_asked():
    from camsim_core.datasets.sensors import cie1931_xyz

    s = scene_from_rgb(np.ones((2, 2, 3)), luminance=80.0)
    y = 683.0 * cie1931_xyz().on(s.wavelengths)[1] @ s.data[0, 0]
    assert y == pytest.approx(80.0, rel=1e-3)


def test_photo_file_loads_like_the_array(tmp_path, photo):
    img = (photo * 255).round().astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "coffee.png")
    scene = cs.load_scene(tmp_path / "coffee.png")
    np.testing.assert_allclose(scene.data, scene_from_rgb(img / 255.0).data)
    assert scene.name == "coffee"


def test_bad_photo_input(tmp_path):
    with pytest.raises(ParameterError, match="rgb.*\\[0, 1\\]"):
        scene_from_rgb(np.full((2, 2, 3), 255.0))
    with pytest.raises(ParameterError, match="rgb.*\\(H, W, 3\\)"):
        scene_from_rgb(np.zeros((4, 4)))
    (tmp_path / "fake.jpg").write_bytes(b"no jpeg here")
    with pytest.raises(FileFormatError, match="fake.jpg.*readable image"):
        cs.load_scene(tmp_path / "fake.jpg")
