"""The five simulation stages against physics: colorimetry, Eq. 1.2 geometry, linearity, mosaic, noise."""

import dataclasses

import colour
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.datasets.sensors import Sensors
from camsim_core.image import image_from_scene
from camsim_core.scene import Scene, macbeth_scene, patch_centers
from camsim_core.simulation import (
    BAYER,
    digitize,
    mosaic,
    optical_blur,
    resampled_size,
    sensor_responses,
)
from camsim_core.spectra import Spectrum

W31 = np.arange(400, 701, 10.0)


def ideal(camera):
    return dataclasses.replace(camera, mosaic=None, noise_sigma=0.0, bits=None)


def flat_scene(h=64, w=64, level=0.05, **kw):
    return Scene(np.full((h, w, 31), level), W31, **kw)


# --- colorimetry ---------------------------------------------------------------------------


def test_cie1931_camera_gives_colour_science_xyz_of_macbeth_patches():
    """Each patch's Lab (white patch as white) within 0.5 dE*ab of colour-science's from reflectance and D65."""
    scene = macbeth_scene("D65", patch_size=12, border=4)
    cam = ideal(cs.load_camera("cie1931")).replace(angular_resolution=scene.angular_resolution)
    img = cs.simulate(scene, cam)
    assert img.data.shape == scene.data.shape[:2] + (3,)
    ours = np.array([img.data[r - 3 : r + 3, c - 3 : c + 3].reshape(-1, 3).mean(0) for r, c in patch_centers(12, 4)])

    sds = colour.SDS_COLOURCHECKERS["BabelColor Average"]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ref = np.array([colour.sd_to_XYZ(sd, cmfs, colour.SDS_ILLUMINANTS["D65"]) for sd in sds.values()])
    white = 18  # 'white 9.5'
    lab_ours = colour.XYZ_to_Lab(ours / ours[white, 1], colour.XYZ_to_xy(ours[white]))
    lab_ref = colour.XYZ_to_Lab(ref / ref[white, 1], colour.XYZ_to_xy(ref[white]))
    de = colour.delta_E(lab_ours, lab_ref, method="CIE 1976")
    assert de.max() < 0.5, de.round(2)


# --- geometry: Eq. 1.2 ---------------------------------------------------------------------


def _object_size(profile):
    """Size in pixels of a uniform object from a resampled profile: area / height (area averaging conserves it)."""
    return profile.sum() / profile.max()


@pytest.mark.parametrize("d", [2.0, 4.0])
def test_object_size_follows_eq_1_2_on_both_axes(d):
    H, W, Nh, Nw = 240, 360, 60, 90
    data = np.zeros((H, W, 31))
    data[(H - Nh) // 2 : (H + Nh) // 2, (W - Nw) // 2 : (W + Nw) // 2] = 0.1
    Phi = (60.0, 40.0)  # x, y pixels per degree of the hyperspectral camera
    scene = Scene(data, W31, distance=2.0, angular_resolution=Phi)
    cam = ideal(cs.load_camera("cie1931")).replace(angular_resolution=(100.0, 50.0), distance=d, height=4000, width=4000)
    img = cs.simulate(scene, cam)
    y = img.data[:, :, 1]
    width = y.max(axis=0)
    height = y.max(axis=1)
    assert _object_size(width) == pytest.approx(resampled_size(Nw, 60.0, 100.0, 2.0, d), abs=0.05)
    assert _object_size(height) == pytest.approx(resampled_size(Nh, 40.0, 50.0, 2.0, d), abs=0.05)


def test_doubling_distance_halves_size_on_both_axes():
    H, W = 200, 300
    data = np.zeros((H, W, 31))
    data[70:130, 90:210] = 0.1  # 60 x 120 object
    scene = Scene(data, W31, distance=1.5, angular_resolution=(40.0, 25.0))
    cam = ideal(cs.load_camera("cie1931")).replace(angular_resolution=(80.0, 60.0), height=4000, width=4000)
    sizes = []
    for d in (1.5, 3.0):
        y = cs.simulate(scene, cam, distance=d).data[:, :, 1]
        sizes.append((_object_size(y.max(axis=1)), _object_size(y.max(axis=0))))
    (h1, w1), (h2, w2) = sizes
    # Eq. 1.2 is not exactly linear in 1/d (tan), but over these small angles the ratio is 2 within 0.5 %
    assert h1 / h2 == pytest.approx(2.0, rel=5e-3)
    assert w1 / w2 == pytest.approx(2.0, rel=5e-3)
    assert h1 == pytest.approx(60 * 60 / 25, rel=5e-3) and w1 == pytest.approx(120 * 80 / 40, rel=5e-3)


def test_resampling_conserves_mean_radiance_when_coarser():
    rng = np.random.default_rng(0)
    scene = Scene(rng.uniform(0, 0.1, (120, 150, 31)), W31, distance=2.0, angular_resolution=(57.3, 57.3))
    cam = ideal(cs.load_camera("cie1931")).replace(angular_resolution=(30.0, 30.0))
    full = sensor_responses(cam, image_from_scene(scene)).data
    out = cs.simulate(scene, cam).data
    # area averaging: each output pixel is a mean, so the image mean is kept up to edge pixels
    np.testing.assert_allclose(out.mean(axis=(0, 1)), full.mean(axis=(0, 1)), rtol=2e-2)


def test_output_never_larger_than_the_pixel_array(cacaphony):
    cam = cs.load_camera("kodak-dcs200-ir").replace(height=100, width=150)
    img = cs.simulate(cacaphony, cam, distance=3.32)
    assert img.data.shape == (100, 150)


# --- exposure and f-stop -------------------------------------------------------------------


def test_exposure_doubles_and_f_stop_root_two_halves_the_linear_response(cacaphony, dcs200_ir):
    cam = ideal(dcs200_ir)
    base = cs.simulate(cacaphony, cam, exposure=0.1, f_stop=8.0).data
    np.testing.assert_allclose(cs.simulate(cacaphony, cam, exposure=0.2, f_stop=8.0).data, 2 * base, rtol=1e-12)
    np.testing.assert_allclose(cs.simulate(cacaphony, cam, exposure=0.1, f_stop=8.0 * np.sqrt(2)).data, base / 2, rtol=1e-12)


def test_sensor_stage_is_the_weighted_sum_scaled_for_exposure(cacaphony64, cacaphony, dcs200_ir):
    cam = dcs200_ir.replace(exposure=0.5, f_stop=11.0)
    img = sensor_responses(cam, image_from_scene(cacaphony64))
    t = np.array([np.interp(W31, dcs200_ir.sensors.wavelengths, row) for row in dcs200_ir.sensors.values])
    expected = np.einsum("hwn,kn->hwk", cacaphony64.data, t) * (0.5 / 1.0) * (5.6 / 11.0) ** 2
    np.testing.assert_allclose(img.data, expected, rtol=1e-12)
    # the shipped float32 scene: the same sums to float32 rounding (31 terms, ~1e-6 relative)
    single = sensor_responses(cam, image_from_scene(cacaphony))
    assert single.data.dtype == np.float32
    np.testing.assert_allclose(single.data, expected, rtol=2e-6)


def test_quantal_sensor_counts_photons():
    """One 550 nm plane, QE 0.5: electrons = q (pi L / 4 N^2) A t lambda / (h c)."""
    L, N, A, t, lam = 0.01, 4.0, (5e-6) ** 2, 0.01, 550e-9
    scene = Scene(np.full((8, 8, 1), L), [550.0])
    sens = Sensors([500.0, 600.0], [[0.5, 0.5]], ("Q",), "Quanta")
    cam = cs.Camera(sensors=sens, pixel_size=(5e-6, 5e-6), exposure=t, f_stop=N, bits=None, angular_resolution=(57.3, 57.3))
    img = cs.simulate(scene, cam)
    expected = 0.5 * (np.pi * L / (4 * N**2)) * A * t * lam / (6.62607015e-34 * 299792458.0)
    np.testing.assert_allclose(img.data, expected, rtol=1e-12)


def test_photon_noise_variance_equals_mean_in_electrons():
    scene = Scene(np.full((300, 300, 1), 1e-2), [550.0])
    sens = Sensors([500.0, 600.0], [[0.5, 0.5]], ("Q",), "Quanta")
    cam = cs.Camera(sensors=sens, pixel_size=(5e-6, 5e-6), exposure=0.01, f_stop=4.0, bits=None,
                    noise_model="photon", angular_resolution=(57.3, 57.3))
    clean = cs.simulate(scene, cam.replace(noise_model="gaussian")).data
    noisy = cs.simulate(scene, cam).data
    mean = clean.mean()
    assert 20 < mean < 1e4
    assert noisy.var() == pytest.approx(mean, rel=0.03)


# --- mosaic --------------------------------------------------------------------------------


@pytest.mark.parametrize("tile", list(BAYER.values()) + [np.array([[0, 1, 2], [2, 0, 1], [1, 2, 0]])],
                         ids=list(BAYER) + ["3x3"])
def test_each_mosaic_pixel_holds_its_tile_sensors_response(cacaphony, dcs200_ir, tile):
    cam = dcs200_ir.replace(mosaic=tile, noise_sigma=0.0, bits=None)
    full = cs.simulate(cacaphony, cam.replace(mosaic=None)).data
    raw = cs.simulate(cacaphony, cam)
    assert raw.mosaiced and raw.data.shape == full.shape[:2]
    n, m = tile.shape
    for i in range(raw.data.shape[0]):
        for j in range(raw.data.shape[1]):
            assert raw.data[i, j] == full[i, j, tile[i % n, j % m]]


def test_tiered_tile_gives_every_sensor_at_every_pixel(cacaphony, dcs200_ir):
    cam = dcs200_ir.replace(mosaic=np.array([[[0, 1, 2]]]), noise_sigma=0.0, bits=None)
    full = cs.simulate(cacaphony, cam.replace(mosaic=None)).data
    np.testing.assert_array_equal(cs.simulate(cacaphony, cam).data, full)


# --- noise and digitization ----------------------------------------------------------------


def test_noise_is_reproducible_and_has_the_requested_sigma(dcs200_ir):
    scene = flat_scene(400, 400, 0.002)
    cam = dcs200_ir.replace(mosaic=None, bits=None, angular_resolution=(57.3, 57.3), noise_sigma=5.0, noise_mean=0.0)
    clean = cs.simulate(scene, cam.replace(noise_sigma=0.0)).data
    a = cs.simulate(scene, cam, seed=7).data
    b = cs.simulate(scene, cam, seed=7).data
    c = cs.simulate(scene, cam, seed=8).data
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert (a - clean).std() == pytest.approx(5.0, rel=0.02)
    assert abs((a - clean).mean()) < 0.05


def test_digitize_rounds_and_clips(dcs200_ir):
    img = cs.CameraImage(np.array([[-3.0, 0.4, 0.6, 254.5, 300.0]]), W31, space="sensor")
    out = digitize(dcs200_ir.replace(bits=8), img)
    np.testing.assert_array_equal(out.data, [[0, 0, 1, 254, 255]])  # round half to even at 254.5
    assert out.quantized and out.bits == 8


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("black", [0.0, 15.0, 0.1])
@pytest.mark.parametrize("shape", [(0, 4), (3, 5), (301, 257, 3)])
def test_digitize_is_round_clip_and_pedestal_value_by_value(dcs200_ir, dtype, black, shape):
    """Every value is rint(v + pedestal) (halves to even, the sum in the image's dtype: float32 2.4 + 0.1 is
    a tie, 2) clipped to [0, 255];
    NaN (an overflow upstream) saturates, infinities clip: numpy's formula written out here, on ties, NaN,
    infinities and values far out of range, in images split into blocks of rows and not."""
    rng = np.random.default_rng(8)
    data = rng.normal(100, 140, shape).astype(dtype)
    specials = [0.5, 1.5, 2.5, -0.5, -0.25, 254.5, 255.5, np.nan, np.inf, -np.inf, 1e30, -1e30, 239.75, 3.4999998, 2.4]
    flat = data.reshape(-1)
    flat[: min(flat.size, len(specials))] = specials[: flat.size]
    img = cs.CameraImage(data, W31, space="sensor")
    out = digitize(dcs200_ir.replace(bits=8, black_level=black), img)
    summed = data + dtype(black)
    expect = np.clip(np.where(np.isnan(summed), 255.0, np.rint(summed)), 0, 255).astype(dtype)
    assert out.data.dtype == dtype and out.data.shape == shape
    np.testing.assert_array_equal(out.data, expect)
    assert out.black_level == black and out.quantized


def test_static_nonlinearity_gamma_and_table(dcs200_ir):
    v = np.array([[0.0, 63.75, 255.0]])
    img = cs.CameraImage(v, W31, space="sensor")
    out = digitize(dcs200_ir.replace(nonlinearity=0.5), img).data
    np.testing.assert_array_equal(out, [[0, np.rint(255 * 0.25**0.5), 255]])
    lut = np.array([0.0, 0.8, 1.0])  # knee at half scale
    out = digitize(dcs200_ir.replace(nonlinearity=lut), cs.CameraImage(np.array([[127.5, 63.75]]), W31, space="sensor")).data
    np.testing.assert_array_equal(out, [[np.rint(0.8 * 255), np.rint(0.4 * 255)]])


# --- architecture --------------------------------------------------------------------------


def test_replace_gives_a_noiseless_unquantized_full_colour_camera(cacaphony, dcs200_ir):
    cam = dataclasses.replace(dcs200_ir, mosaic=None, noise_sigma=0.0, bits=None)
    a = cs.simulate(cacaphony, cam, distance=3.32, exposure=0.1, f_stop=11)
    assert a.data.ndim == 3 and not a.mosaiced and not a.quantized
    assert not np.all(a.data == np.rint(a.data))
    assert a.history == ("scene", "sensor_responses", "resample")  # mosaic, noise, digitize did nothing


def test_blur_per_wavelength_before_the_sensor_stage_commutes_when_uniform(dcs200_ir):
    rng = np.random.default_rng(1)
    scene = Scene(rng.uniform(0, 0.05, (40, 50, 31)), W31, distance=2.0, angular_resolution=(102.6, 102.6))
    cam = dcs200_ir.replace(mosaic=None, noise_sigma=0.0, bits=None, blur_sigma=1.5)
    after = cs.simulate(scene, cam.replace(architecture=(cs.simulation.sensor_responses, optical_blur)))
    before = cs.simulate(scene, cam.replace(architecture=(optical_blur, cs.simulation.sensor_responses)))
    np.testing.assert_allclose(before.data, after.data, rtol=1e-10, atol=1e-12)
    # chromatic aberration: sharp at 550 nm, blurred elsewhere changes the image
    chroma = Spectrum(W31, np.abs(W31 - 550) / 50.0)
    ca = cs.simulate(scene, cam.replace(blur_sigma=chroma, architecture=(optical_blur, cs.simulation.sensor_responses)))
    assert not np.allclose(ca.data, after.data)


def test_stages_return_new_images_and_leave_the_input_alone(cacaphony, dcs200_ir):
    img = image_from_scene(cacaphony)
    out = sensor_responses(dcs200_ir, img)
    assert out is not img and img.space == "spectral" and img.data is cacaphony.data
    with pytest.raises(ValueError):
        cacaphony.data[0, 0, 0] = 1.0  # read-only


def test_mosaic_stage_refuses_a_mosaiced_image(cacaphony, dcs200_ir):
    raw = cs.simulate(cacaphony, dcs200_ir)
    with pytest.raises(cs.ParameterError, match="mosaic"):
        mosaic(dcs200_ir, raw)
