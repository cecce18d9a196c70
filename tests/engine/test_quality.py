"""SNR of uniform fields, Macbeth per-patch colour accuracy, PSNR and SSIM."""

import colour
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.camera import camera_preset
from camsim_core.errors import ParameterError
from camsim_core.metrics import (macbeth_delta_e, macbeth_patch_boxes, patch_map, psnr, region_snr, snr_vs_light,
                                 ssim)
from camsim_core.metrics.chart import _patch_means
from camsim_core.rendering import to_xyz
from camsim_core.scene import macbeth_scene, uniform_scene

MONITOR = "simtoolbox-test"


@pytest.fixture(scope="module")
def flat():
    return uniform_scene(256, luminance=100.0)


def _flat_camera(scene, **changes):
    cam = cs.load_camera("kodak-dcs200-ir").replace(mosaic=None, bits=None, noise_sigma=2.0, distance=None, seed=3,
                                                    angular_resolution=scene.angular_resolution, exposure=0.5)
    return cam.replace(**changes)


def test_flat_field_snr_is_signal_over_noise_sigma(flat):
    sigma = 2.0
    noisy = cs.simulate(flat, _flat_camera(flat, noise_sigma=sigma))
    signal = cs.simulate(flat, _flat_camera(flat, noise_sigma=0.0)).data[0, 0]  # the noiseless response
    res = region_snr(noisy)
    for k, name in enumerate("RGB"):
        assert res[name]["snr"] == pytest.approx(signal[k] / sigma, rel=0.03)
        assert res[name]["snr_db"] == pytest.approx(20 * np.log10(signal[k] / sigma), abs=0.3)


def test_raw_snr_per_class_and_pedestal(flat):
    cam = _flat_camera(flat, mosaic=cs.load_camera("kodak-dcs200-ir").mosaic, black_level=40.0)
    raw = cs.simulate(flat, cam)
    signal = cs.simulate(flat, _flat_camera(flat, noise_sigma=0.0)).data[0, 0]
    res = region_snr(raw, roi=(10, 200, 20, 240))
    assert "luminance" not in res  # a mosaic has no luminance before demosaicing
    for k, name in enumerate("RGB"):
        assert res[name]["mean"] == pytest.approx(signal[k], rel=0.01)  # the pedestal is subtracted
        assert res[name]["snr"] == pytest.approx(signal[k] / 2.0, rel=0.05)  # fewer samples per class


def test_snr_grows_with_light_as_the_gaussian_model_says():
    cam = cs.load_camera("kodak-dcs200-ir").replace(noise_sigma=2.0, mosaic=None, bits=None)
    curve = snr_vs_light(cam, [5.0, 20.0, 80.0], size=96, exposure=0.5)
    # additive noise of fixed sigma: SNR proportional to signal, +12.04 dB per factor 4 of light
    np.testing.assert_allclose(np.diff(curve["G"]), 20 * np.log10(4), atol=0.5)
    saturating = snr_vs_light(cam.replace(bits=8), [5.0, 400.0], size=32, exposure=0.5)
    assert np.isfinite(saturating["G"][0]) and np.isnan(saturating["G"][1])


def _chart_images(name, scene):
    cam = camera_preset(name).replace(mosaic=None, noise_sigma=0.0)
    ex = cs.auto_exposure(scene, cam)
    rendered = cs.render(cs.simulate(scene, cam, exposure=ex), MONITOR)
    return rendered, cs.ideal_image(scene, cam, MONITOR, exposure=ex, reference="chapter")  # quantized as the camera


def test_cone_camera_macbeth_de_is_zero_and_a_real_camera_is_not():
    m = macbeth_scene()
    cones = macbeth_delta_e(*_chart_images("human-cones", m), MONITOR)
    assert cones["per_patch"].shape == (24,) and cones["max"] < 0.5  # 0 within 8-bit quantization
    dcs = macbeth_delta_e(*_chart_images("kodak-dcs200-ir", m), MONITOR)
    assert dcs["mean"] > 2.0


def test_ideal_chart_matches_colour_science_colorimetry():
    """The rendered ideal chart against the chart's XYZ under D65 computed by colour-science alone."""
    m = macbeth_scene()
    cam = camera_preset("human-cones").replace(noise_sigma=0.0, bits=12)
    white_scene = uniform_scene(32, angular_resolution=m.angular_resolution)
    ex = cs.auto_exposure(white_scene, cam)
    mon = cs.load_monitor(MONITOR)
    ideal = cs.ideal_image(m, cam, mon, exposure=ex)
    xyz = _patch_means(to_xyz(ideal, mon), macbeth_patch_boxes(ideal.shape))
    white = to_xyz(cs.ideal_image(white_scene, cam, mon, exposure=ex, white=m.illuminant), mon).reshape(-1, 3).mean(0)
    d65 = colour.SDS_ILLUMINANTS["D65"]
    truth = np.array([colour.sd_to_XYZ(sd, illuminant=d65) for sd in colour.SDS_COLOURCHECKERS["BabelColor Average"].values()])
    tw = colour.sd_to_XYZ(colour.sd_ones(), illuminant=d65)
    de = colour.delta_E(colour.XYZ_to_Lab(xyz / white[1], colour.XYZ_to_xy(white)),
                        colour.XYZ_to_Lab(truth / tw[1], colour.XYZ_to_xy(tw)), method="CIE 2000")
    # Smith-Pokorny cones are not exactly a transform of the CIE 1931 functions; patch 18 (cyan) is out of gamut
    assert de.mean() < 1.2
    assert np.delete(de, 17).max() < 1.5


def test_patch_boxes_and_map():
    boxes = macbeth_patch_boxes((84, 124))  # the default chart, 1:1
    assert boxes[0] == (8, 16, 8, 16) and boxes[23] == (68, 76, 108, 116)
    half = macbeth_patch_boxes((42, 62))
    assert half[0] == (4, 8, 4, 8)
    m = patch_map((84, 124), boxes, np.arange(24.0))
    assert m[12, 12] == 0 and m[72, 112] == 23 and np.isnan(m[0, 0])
    with pytest.raises(ParameterError, match="too small"):
        macbeth_patch_boxes((8, 12))


def test_psnr_and_ssim_against_their_definitions(rng):
    ref = rng.uniform(0, 255, size=(64, 64, 3)).round()
    noise = rng.normal(0, 3.0, size=ref.shape)
    img = ref + noise
    mse = np.mean(noise**2)
    assert psnr(img, ref, data_range=255) == pytest.approx(10 * np.log10(255**2 / mse), rel=1e-9)
    assert ssim(ref, ref, data_range=255) == pytest.approx(1.0)
    assert ssim(img, ref, data_range=255) < ssim(ref + noise / 3, ref, data_range=255) < 1.0
    with pytest.raises(ParameterError, match="shape"):
        psnr(img[:10], ref)


@pytest.mark.parametrize("shape", [(900, 1300, 3), (60, 70, 4)])
def test_ssim_of_a_colour_image_is_scikit_images_channel_average(rng, shape):
    """A large colour image's channels are measured on the machine's cores (one each): the number is still
    scikit-image's own SSIM with ``channel_axis``, to the last bit."""
    from skimage.metrics import structural_similarity

    ref = rng.uniform(0, 255, size=shape).round()
    img = ref + rng.normal(0, 4.0, size=shape)
    assert ssim(img, ref, data_range=255) == structural_similarity(ref, img, data_range=255, channel_axis=2)


def test_psnr_of_identical_images_is_infinite_without_a_warning(rng):
    """A design compared with itself (the explorer's A/B of one pinned design) gives PSNR inf, and
    writes no divide-by-zero warning to the server's log."""
    import warnings

    ref = rng.uniform(0, 255, size=(16, 16, 3)).round()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert psnr(ref.copy(), ref, data_range=255) == np.inf
        assert np.isfinite(psnr(ref + 1, ref, data_range=255))


def test_region_snr_detrended_measures_the_noise_about_the_fields_shading():
    """A field with an 8 % quadratic fall-off and Gaussian noise of sigma 2: detrended, the sigma is the noise's
    (to its sampling error) and the mean is the field's; without, the fall-off counts as noise."""
    from camsim_core.metrics.snr import region_snr

    rng = np.random.default_rng(7)
    h, w = 200, 300
    y, x = np.mgrid[0:h, 0:w]
    shading = 1.0 - 0.08 * (((x - w / 2) / (w / 2)) ** 2 + ((y - h / 2) / (h / 2)) ** 2) / 2
    field = 1000.0 * shading + rng.normal(0.0, 2.0, (h, w))
    flat = region_snr(field, detrend=True)["0"]
    raw = region_snr(field)["0"]
    assert flat["sigma"] == pytest.approx(2.0, rel=0.02) and raw["sigma"] > 5 * flat["sigma"]
    assert flat["mean"] == pytest.approx(raw["mean"], rel=1e-12)
    tiny = np.array([[9.0, 10.0], [11.0, 10.0]])  # too few samples for the surface: measured as it is
    assert region_snr(tiny, detrend=True)["0"] == region_snr(tiny)["0"]
