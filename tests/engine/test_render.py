"""Balancing and rendering (chapter section 4.2): baseline, illuminant-based, XYZ, bad input."""

import colour
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.camera import camera_preset
from camsim_core.datasets.sensors import gaussian_sensors
from camsim_core.errors import ParameterError
from camsim_core.rendering import white_xyz
from camsim_core.scene import macbeth_scene
from camsim_core.scene.synthetic import patch_centers
from camsim_core.spectra import Spectrum


@pytest.fixture(scope="module")
def monitor():
    return cs.load_monitor("simtoolbox-test")


@pytest.fixture(scope="module")
def macbeth():
    return macbeth_scene("A", patch_size=12, border=3, angular_resolution=(102.6, 102.6))  # the cameras' resolution: no resampling


def lab(xyz, monitor):
    wp = white_xyz(monitor)
    return colour.XYZ_to_Lab(xyz / wp[1], colour.XYZ_to_xy(wp))


def mean_de(a, b, monitor):
    return float(colour.delta_E(lab(cs.to_xyz(a, monitor), monitor), lab(cs.to_xyz(b, monitor), monitor), method="CIE 1976").mean())


def test_alpha0_both_renderings_equal_ideal(monitor):
    """Chapter section 5: the cone camera (alpha = 0), no noise, no mosaic: both methods give the ideal image."""
    scene = cs.load_scene("cacaphony290")
    cam = cs.load_camera("mixture-0").replace(mosaic=None, noise_sigma=0.0)
    ex = cs.auto_exposure(scene, cam)
    raw = cs.simulate(scene, cam, exposure=ex)
    ideal = cs.ideal_image(scene, cam, monitor, exposure=ex, reference="chapter")  # the chapter's: quantized as the camera
    assert ideal.data.max() > 150  # a real image, not a black one
    for method in ("baseline", "illuminant"):
        out = cs.render(raw, monitor, method=method)
        assert out.data.shape == ideal.data.shape
        assert np.abs(out.data - ideal.data).max() <= 1, method


def test_render_contract(monitor, macbeth):
    cam = camera_preset("kodak-dcs200")
    raw = cs.simulate(macbeth, cam, exposure=cs.auto_exposure(macbeth, cam))
    out = cs.render(cs.demosaic(raw), monitor)
    assert out.space == "monitor" and out.bits == 8 and out.quantized
    assert out.data.shape == raw.data.shape + (3,)
    assert np.array_equal(out.data, np.rint(out.data)) and out.data.min() >= 0 and out.data.max() <= 255
    assert out.history[-2:] == ("demosaic:bilinear", "render:baseline")


def test_baseline_reproduces_camera_responses(monitor, macbeth):
    """Eq. 1.3: the displayed light, seen by the camera, gives back the camera's responses (up to 8 bits)."""
    cam = camera_preset("kodak-dcs200", mosaic=None, bits=None, noise_sigma=0.0)
    raw = cs.simulate(macbeth, cam, exposure=cs.auto_exposure(macbeth, cam, target=0.5))
    out = cs.render(raw, monitor)
    lin = monitor.settings_to_linear(out.data / 255.0)
    seen = lin @ (raw.sensitivities @ monitor.primaries_on(raw.wavelengths)).T * out.extra["display_scale"]
    r = raw.data / raw.gain
    inside = np.all((lin > 0.02) & (lin < 0.98), axis=2)
    assert inside.sum() > 1000
    rel = np.abs(seen - r)[inside] / r[inside].max()
    assert rel.max() < 0.02


def test_exposure_does_not_change_rendering(monitor, macbeth):
    cam = camera_preset("kodak-dcs200", mosaic=None, bits=None, noise_sigma=0.0)
    ex = cs.auto_exposure(macbeth, cam, target=0.5)
    a = cs.render(cs.simulate(macbeth, cam, exposure=ex), monitor)
    b = cs.render(cs.simulate(macbeth, cam, exposure=ex / 3), monitor)
    assert np.abs(a.data - b.data).max() <= 1


def test_illuminant_based_beats_baseline_dcs200(monitor, macbeth):
    """Chapter Figure 1.14 at alpha = 1: the illuminant-based method is closer to the ideal image.

    Mean CIELAB dE over the whole (bilinear-demosaiced) image, and at the 24 patch centres
    where only colour rendering differs (measured: 10.3 baseline, 3.7 illuminant-based).
    """
    cam = camera_preset("kodak-dcs200", noise_sigma=0.0)
    ex = cs.auto_exposure(macbeth, cam)
    img = cs.demosaic(cs.simulate(macbeth, cam, exposure=ex))
    ideal = lab(cs.to_xyz(cs.ideal_image(macbeth, cam, monitor, exposure=ex), monitor), monitor)
    rows, cols = np.array(patch_centers(12, 3)).T
    de = {}
    for method in ("baseline", "illuminant"):
        d = colour.delta_E(lab(cs.to_xyz(cs.render(img, monitor, method), monitor), monitor), ideal, method="CIE 1976")
        de[method] = (d.mean(), d[rows, cols].mean())
    assert de["illuminant"][0] < de["baseline"][0]
    assert de["illuminant"][1] < 0.6 * de["baseline"][1]


def test_illuminant_estimates_are_close_to_known(monitor, macbeth):
    """Gray world and max-RGB recover the chromaticity of the light roughly (Macbeth chart under A)."""
    cam = camera_preset("kodak-dcs200", mosaic=None, noise_sigma=0.0)
    img = cs.simulate(macbeth, cam, exposure=cs.auto_exposure(macbeth, cam))
    true_xy = colour.XYZ_to_xy(colour.sd_to_XYZ(colour.SDS_ILLUMINANTS["A"]))
    for est in ("gray-world", "max-rgb"):
        spd = cs.render(img, monitor, "illuminant", illuminant=est).extra["illuminant"]
        sd = colour.SpectralDistribution(dict(zip(spd.wavelengths, spd.values)))
        xy = colour.XYZ_to_xy(colour.sd_to_XYZ(sd.align(colour.SpectralShape(400, 700, 10))))
        assert np.linalg.norm(xy - true_xy) < 0.05, est


def test_four_sensor_render_uses_pseudo_inverse(monitor, macbeth):
    """With four sensors, Eq. 1.4 is solved in the least-squares sense, and N_s defaults to 4."""
    cam = camera_preset("gaussian-4", mosaic=None)
    img = cs.simulate(macbeth, cam, exposure=cs.auto_exposure(macbeth, cam))
    ideal = cs.ideal_image(macbeth, cam, monitor, exposure=cs.auto_exposure(macbeth, cam))
    out = cs.render(img, monitor, "illuminant")
    assert out.extra["dimensions"] == 4
    assert mean_de(out, ideal, monitor) < 3.0
    assert mean_de(cs.render(img, monitor, "illuminant", dimensions=3), ideal, monitor) > mean_de(out, ideal, monitor)


def test_rerendering_under_d65_moves_white_towards_d65(monitor, macbeth):
    cam = camera_preset("human-cones")
    img = cs.simulate(macbeth, cam, exposure=cs.auto_exposure(macbeth, cam))
    white = patch_centers(12, 3)[18]  # the white patch
    xy_d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    xy = {}
    for name, kw in (("A", {}), ("D65", {"render_illuminant": "D65"})):
        x = cs.to_xyz(cs.render(img, monitor, "illuminant", **kw), monitor)[white]
        xy[name] = colour.XYZ_to_xy(x)
    assert np.linalg.norm(xy["D65"] - xy_d65) < 0.02
    assert np.linalg.norm(xy["A"] - xy_d65) > 0.1


def test_to_xyz_against_colour_science(monitor):
    """Full white on the monitor: XYZ equals colour-science's integration of the summed phosphor spectra."""
    img = cs.CameraImage(np.full((2, 2, 3), 255.0), np.zeros(0), space="monitor", bits=8, quantized=True)
    xyz = cs.to_xyz(img, monitor)[0, 0]
    sd = colour.SpectralDistribution(dict(zip(monitor.wavelengths, monitor.primaries.sum(axis=1) / 4.0)))
    ref = colour.sd_to_XYZ(sd, k=683.0, method="Integration", shape=colour.SpectralShape(380, 780, 4))
    assert np.allclose(xyz, ref, rtol=0.01)
    black = cs.to_xyz(img.replace(data=np.zeros((2, 2, 3))), monitor)
    assert np.allclose(black, 0.0)


# -- bad input ---------------------------------------------------------------------------------

def test_unknown_method_lists_valid(monitor, macbeth):
    img = cs.simulate(macbeth, camera_preset("human-cones"))
    with pytest.raises(ParameterError, match="baseline, illuminant"):
        cs.render(img, monitor, method="fancy")


def test_singular_camera_monitor_matrix(monitor):
    sens = gaussian_sensors([550, 550, 550], 30.0)
    raw = cs.raw_from_array(np.full((8, 8), 100, np.uint8), "GRBG", sensitivities=sens)
    with pytest.raises(ParameterError, match="singular"):
        cs.render(cs.demosaic(raw), monitor)


def test_render_needs_demosaiced_image(monitor):
    raw = cs.raw_from_array(np.full((8, 8), 100, np.uint8), "GRBG", sensitivities=camera_preset("kodak-dcs200").sensors)
    with pytest.raises(ParameterError, match="demosaic"):
        cs.render(raw, monitor)


def test_illuminant_method_without_illuminant(monitor):
    raw = cs.raw_from_array(np.full((8, 8), 100, np.uint8), "GRBG", sensitivities=camera_preset("kodak-dcs200").sensors)
    with pytest.raises(ParameterError, match="gray-world"):
        cs.render(cs.demosaic(raw), monitor, "illuminant")
    with pytest.raises(ParameterError, match="max-rgb"):
        cs.render(cs.demosaic(raw), monitor, "illuminant", illuminant="brightest")
    spd = Spectrum(np.arange(380, 781, 5.0), np.ones(81))
    out = cs.render(cs.demosaic(raw), monitor, "illuminant", illuminant=spd)
    assert out.data.shape == (8, 8, 3)


def test_rendered_image_writes_as_displayed_png(monitor, macbeth, tmp_path):
    from PIL import Image

    from camsim_core.io.output import write_image

    img = cs.simulate(macbeth, camera_preset("human-cones"))
    out = cs.render(img, monitor)
    write_image(out, tmp_path / "x.png")
    back = np.asarray(Image.open(tmp_path / "x.png"))
    assert back.dtype == np.uint8 and np.array_equal(back, out.data)


def _in_quanta(sensors):
    """The same sensors as quantum efficiencies: QE(lambda) = T(lambda) h c / lambda (photons counted, not energy)."""
    from camsim_core.datasets.sensors import Sensors
    from camsim_core.simulation.sensor import LIGHT_SPEED, PLANCK

    w = np.asarray(sensors.wavelengths, float)
    return Sensors(w, np.asarray(sensors.values, float) * (PLANCK * LIGHT_SPEED / (w * 1e-9))[None, :], sensors.names,
                   "Quanta", "cones in quanta")


def test_a_camera_counting_photons_renders_as_the_same_camera_in_energy(monitor):
    """Quantum efficiencies carry lambda / hc into the responses: rendering (Eq. 1.4) must invert the same
    sensitivities, so the cone camera in quanta renders what the cone camera in energy does (which is the ideal
    image, ``test_alpha0_both_renderings_equal_ideal``); before, its rendering was off by ~1e18 (saturated)."""
    scene = cs.load_scene("cacaphony290")
    cones = cs.load_camera("mixture-0").replace(mosaic=None, noise_sigma=0.0, bits=None)
    cam = cones.replace(sensors=_in_quanta(cones.sensors), pixel_size=(5e-6, 5e-6), electrons_per_dn=1.0)
    energy = cs.simulate(scene, cones, exposure=cs.auto_exposure(scene, cones))
    quanta = cs.simulate(scene, cam)
    for method in ("baseline", "illuminant"):
        expected = cs.render(energy, monitor, method=method).data
        assert expected.max() > 150  # a real image
        assert np.abs(cs.render(quanta, monitor, method=method).data - expected).max() <= 1, method


def test_analog_gain_scales_the_raw_but_not_the_rendering(monitor):
    """The electron-level sensor's analog gain multiplies the digital values like exposure does; the image's gain
    carries it, so the rendered image does not change (apart from the photon noise of the draw)."""
    scene = cs.load_scene("cacaphony290")
    cam = camera_preset("imx174").replace(mosaic=None, bits=None, read_noise=0.0, dark_current=0.0, dsnu=0.0, prnu=0.0,
                                         full_well=None, exposure=0.02, seed=3)
    one = cs.simulate(scene, cam)
    two = cs.simulate(scene, cam.replace(analog_gain=2.0))
    assert two.gain == pytest.approx(2 * one.gain, rel=1e-12)
    assert np.array_equal(two.data, 2 * one.data)  # the same draw (same seed), twice the digital values
    assert np.array_equal(cs.render(two, monitor).data, cs.render(one, monitor).data)


@pytest.mark.parametrize("method", ["baseline", "illuminant"])
def test_render_makes_no_full_size_float_temporary(monitor, method):
    """Float32 images 1200 and 3600 rows high (1200 wide) rendered: settings, display scale, clipping and gamma
    go by chunks of pixels, so the peak memory beyond the output (traced by tracemalloc, which numpy reports its
    arrays to) is the same for both; a full-size linear settings image would add 2 x 1200 x 1200 x 12 bytes."""
    import tracemalloc

    scene = cs.load_scene("cacaphony290")
    dem = cs.demosaic(cs.simulate(scene, cs.load_camera("kodak-dcs200-ir")), "bilinear")
    small = cs.render(dem.replace(data=dem.data.astype(np.float32)), monitor, method)  # tables, matrices: made once

    def transient(h):
        reps = (-(-h // dem.data.shape[0]), -(-1200 // dem.data.shape[1]), 1)
        big = dem.replace(data=np.ascontiguousarray(np.tile(dem.data.astype(np.float32), reps)[:h, :1200]))
        tracemalloc.start()
        try:
            out = cs.render(big, monitor, method)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert out.data.dtype == np.float32 and out.data.shape == (h, 1200, 3)
        # the chunks give the numbers of the whole: the small image repeats in the large one
        np.testing.assert_array_equal(out.data[: small.data.shape[0], : small.data.shape[1]], small.data.astype(np.float32))
        return peak - out.data.nbytes

    low, high = transient(1200), transient(3600)
    assert high - low < 4 * 2**20, f"{low / 2**20:.0f} MiB beyond the output at 1200 rows, {high / 2**20:.0f} at 3600"


def test_render_with_an_image_dependent_scale_by_chunks(monitor):
    """Without a scene illuminant the display scale is the 99.5th percentile of each pixel's largest linear
    setting, found by chunks: a tiled image has the percentile of its tile, so the same rendering."""
    scene = cs.load_scene("cacaphony290")
    cam = cs.load_camera("kodak-dcs200-ir")
    # an exposure at which nothing clips: clipped pixels are the display's white (known for the demosaiced data
    # only, not for data put in their place), which is not what this test is about
    raw = cs.simulate(scene, cam, exposure=cs.auto_exposure(scene, cam, target=0.5))
    dem = cs.demosaic(raw, "bilinear").replace(illuminant=None)
    small = cs.render(dem, monitor)
    big = cs.render(dem.replace(data=np.tile(dem.data, (4, 3, 1))), monitor)  # over one chunk of pixels
    assert small.extra["scale_source"] == big.extra["scale_source"] == "image 99.5th percentile"
    assert big.extra["display_scale"] == pytest.approx(small.extra["display_scale"], rel=1e-3)
    assert np.abs(big.data[: small.data.shape[0], : small.data.shape[1]] - small.data).max() <= 1


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_to_xyz_of_frame_buffer_values_by_its_table_and_otherwise(monitor, dtype):
    """Whole frame-buffer values go through the monitor's 256-entry table in one compiled pass; a value that is
    not one (a fraction, out of range, NaN) sends its chunk through the general path. Either way XYZ is
    683 cmf^T B_M w with w the monitor's own gamma inversion, computed here in float64 from the calibration."""
    from camsim_core.datasets.sensors import cie1931_xyz

    rng = np.random.default_rng(5)
    values = rng.integers(0, 256, size=(300, 400, 3)).astype(dtype)
    img = cs.CameraImage(data=values, wavelengths=monitor.wavelengths, space="monitor", bits=8)
    m = 683.0 * cie1931_xyz().on(monitor.wavelengths) @ monitor.primaries
    expect = monitor.settings_to_linear(values.astype(float) / 255.0) @ m.T
    tol = 2e-6 if dtype == np.float32 else 1e-12
    got = cs.to_xyz(img, monitor)
    assert got.dtype == dtype
    np.testing.assert_allclose(got, expect, rtol=tol, atol=tol * np.abs(expect).max())
    odd = values.copy()
    odd[7, 9] = (12.5, 300.0, 3.0)
    expect[7, 9] = monitor.settings_to_linear(np.clip(odd[7, 9].astype(float) / 255.0, 0, None)) @ m.T
    got = cs.to_xyz(img.replace(data=odd), monitor)
    np.testing.assert_allclose(got, expect, rtol=tol, atol=tol * np.abs(expect).max())
    odd[7, 9] = (-1.0, np.nan, 3.0)  # below the table, and NaN: the general path, NaN stays NaN
    got = cs.to_xyz(img.replace(data=odd), monitor)
    assert np.isnan(got[7, 9]).any() and np.isfinite(np.delete(got.reshape(-1, 3), 7 * 400 + 9, axis=0)).all()
    np.testing.assert_allclose(got[8:], expect[8:], rtol=tol, atol=tol * np.abs(expect).max())


def test_render_follows_its_formula_pixel_by_pixel(monitor):
    """The compiled rendering gives rint(255 x linear_to_settings(clip((T_C B_M)^-1 r / gain / s, 0, 1))), the
    formula evaluated here in float64 with numpy over every pixel (a NaN pixel stays NaN, its neighbours are
    unaffected); at most 1 DU apart, where rounding of the product puts a value on a step."""
    from camsim_core.rendering.baseline import baseline_matrix

    scene = cs.load_scene("cacaphony290")
    dem = cs.demosaic(cs.simulate(scene, cs.load_camera("kodak-dcs200-ir").replace(noise_sigma=3.0, seed=2)), "bilinear")
    data = dem.data.copy()
    data[5, 6, 1] = np.nan
    out = cs.render(dem.replace(data=data), monitor)
    m = baseline_matrix(dem.sensitivities, monitor.primaries_on(dem.wavelengths)) / dem.gain
    lin = np.clip(data @ m.T / out.extra["display_scale"], 0, 1)
    expect = np.rint(monitor.linear_to_settings(lin) * 255)
    assert np.all(np.isnan(out.data[5, 6])) and np.all(np.isnan(expect[5, 6]))
    ok = ~np.isnan(expect)
    diff = np.abs(out.data[ok] - expect[ok])
    assert diff.max() <= 1 and np.count_nonzero(diff) <= 1e-4 * diff.size
    assert np.isfinite(out.data[5, 7]).all() and np.isfinite(out.data[4, 6]).all()


@pytest.mark.parametrize("seed", [0, 1])
def test_pixels_saturated_at_the_full_well_render_alike_whatever_the_bits(seed):
    """imx174's full well (32,000 e-) sits 3 DN below its 12-bit top: pixels saturated at the well rendered white
    only where read noise took them to the ADC's top, so one design scored 7.5-8.4 at 12 bits (by the seed) and
    3.47 unquantized, with the same 1.6 % of pixels at the well. Clipped is clipped, by the well or the ADC."""
    from camsim_core.review import evaluate_design

    means = {bits: evaluate_design({"camera": "imx174", "bits": bits, "seed": seed}, "x", quality=False)
             .measures["cielab"]["mean"] for bits in (12, 16, 0)}
    assert max(means.values()) - min(means.values()) < 0.05, means
