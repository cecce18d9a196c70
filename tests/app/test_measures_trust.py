"""Measures a design review can trust (issue 37): more light never renders darker, a black or clipped frame is
flagged and never scores better, processing keeps the signed values the sensor measured.

Each check is against physics or a computation written here (the monitor's calibration, CIELAB by
colour-science, a plain numpy dilation, the EMVA 1288 noise model), not against the code under test.
"""

import colour
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.cache import Pipeline, Processing
from camsim_core.camera import camera_preset
from camsim_core.datasets.sensors import cie1931_xyz
from camsim_core.scene import Scene

#: Exposure multiples of the chapter's 0.1 s.
STEPS = (1, 2, 4, 8, 16, 32)


@pytest.fixture(scope="module")
def monitor():
    return cs.load_monitor("simtoolbox-test")


@pytest.fixture(scope="module")
def chapter_camera():
    """The chapter's setting: the DCS-200 with its IR filter at 3.32 m, 0.1 s, f/11 (the explorer's default)."""
    return camera_preset("kodak-dcs200-ir", distance=3.32, exposure=0.1, f_stop=11.0)


def luminance(fb, monitor):
    """Y (cd/m^2) of frame-buffer values from the monitor's calibration: 683 y-bar . B_M . gamma^-1(fb / 255)."""
    lin = monitor.settings_to_linear(np.asarray(fb, float) / 255.0)
    y = 683.0 * cie1931_xyz().on(monitor.wavelengths)[1] @ monitor.primaries  # (3,): Y per unit linear setting
    return lin @ y


def lab(fb, monitor):
    """CIELAB of frame-buffer values (colour-science), with the monitor's white."""
    lin = monitor.settings_to_linear(np.asarray(fb, float) / 255.0)
    m = 683.0 * cie1931_xyz().on(monitor.wavelengths) @ monitor.primaries  # (3, 3): XYZ per unit linear setting
    xyz = lin @ m.T
    white = m.sum(axis=1)
    return colour.XYZ_to_Lab(xyz / white[1], colour.XYZ_to_xy(white / white[1]))


def dilate(mask, ry, rx):
    """A boolean mask widened by (ry, rx) pixels, by shifts (plain numpy)."""
    h, w = mask.shape
    padded = np.pad(mask, ((ry, ry), (rx, rx)))
    out = np.zeros_like(mask)
    for dy in range(2 * ry + 1):
        for dx in range(2 * rx + 1):
            out |= padded[dy : dy + h, dx : dx + w]
    return out


@pytest.fixture(scope="module")
def ladder(cacaphony, chapter_camera, monitor):
    """The chapter's setting at exposure x1 .. x32: raw, rendered frame buffer and its luminance per step."""
    out = []
    for k in STEPS:
        raw = cs.simulate(cacaphony, chapter_camera.replace(exposure=0.1 * k))
        rendered = cs.render(cs.demosaic(raw, "bilinear"), monitor)
        out.append((k, raw, rendered, luminance(rendered.data, monitor)))
    return out


def test_rendered_luminance_never_falls_as_the_exposure_grows(ladder, monitor):
    """x1 .. x32 of the chapter's 0.1 s: the mean luminance never falls (it fell 22.3 -> 2.4 cd/m^2 before), and a
    fully clipped raw is the display's white, not a dark purple."""
    means = [float(y.mean()) for _, _, _, y in ladder]
    assert all(b >= a for a, b in zip(means, means[1:])), means
    white_y = float(luminance(np.full(3, 255.0), monitor))
    k, raw, rendered, y = ladder[-1]
    assert np.mean(raw.data >= 255) > 0.98  # x32: nearly every raw value clipped
    assert means[-1] > 0.97 * white_y and means[-1] > 5 * means[0]


def test_a_clipped_pixel_is_at_least_as_bright_as_at_any_lower_exposure(ladder):
    """Each pixel whose raw clipped (its 3 x 3 neighbourhood, bilinear's reach, holds a value at 255) renders at
    least as bright as it did at every lower exposure of the ladder; the others change only by quantization."""
    for i in range(1, len(ladder)):
        _, raw, _, y = ladder[i]
        clipped = dilate(raw.data >= 255, 1, 1)
        assert clipped.any()
        for _, _, _, y_low in ladder[:i]:
            assert np.all(y[clipped] >= y_low[clipped] - 1e-9)
    # unclipped pixels: the exposure is divided out, so the same image within the raw's 8-bit steps
    (_, raw1, _, y1), (_, raw2, _, y2) = ladder[0], ladder[1]
    free = ~dilate(raw2.data >= 255, 1, 1)
    assert np.median(np.abs(y2[free] - y1[free]) / np.maximum(y1[free], 1e-3)) < 0.02


def test_mean_de_grows_once_any_raw_value_clips(cacaphony, chapter_camera, ladder, monitor):
    """Against the engine's ideal image of the chapter's camera (made once, so whichever reference the engine
    gives - the scene's, or the chapter's at 0.1 s - it is the same for every step), the mean CIELAB dE grows
    from the last unclipped exposure on."""
    ideal = lab(cs.ideal_image(cacaphony, chapter_camera, monitor).data, monitor)
    de = [float(colour.delta_E(lab(r.data, monitor), ideal, method="CIE 1976").mean()) for _, _, r, _ in ladder]
    clipped = [bool(np.any(raw.data >= 255)) for _, raw, _, _ in ladder]
    assert not clipped[0] and all(clipped[1:])
    assert all(b >= a for a, b in zip(de, de[1:])), de
    assert de[1] > de[0] + 1 and de[-1] > 3 * de[0]


def test_a_black_frame_is_flagged_and_never_scores_better(cacaphony, chapter_camera, monitor):
    """Exposure 1e-4 s: every raw value 0. The result says so (black frame), and its dE against the ideal image
    is larger than the chapter's exposure's (it scored 0.00 against a reference as black as itself)."""
    pipe = Pipeline()
    proc = Processing(metrics=("cielab",))
    good = pipe.run(cacaphony, chapter_camera, proc)
    black = pipe.run(cacaphony, chapter_camera.replace(exposure=1e-4), proc)
    assert np.all(black.raw.data == 0)
    flags = black.exposure.flags
    assert any(f.startswith("black frame: 100 % of pixels at the black level") for f in flags), flags
    assert good.exposure.flags == ()
    # not presented as better: against the ideal image of the chapter's exposure (fixed whatever the reference)
    ideal = lab(cs.ideal_image(cacaphony, chapter_camera, monitor).data, monitor)
    de_good = float(colour.delta_E(lab(good.rendered.data, monitor), ideal, method="CIE 1976").mean())
    de_black = float(colour.delta_E(lab(black.rendered.data, monitor), ideal, method="CIE 1976").mean())
    assert de_black > de_good + 10
    # and the explorer's own error map, whichever reference it uses, is either larger or flagged (both, today)
    assert float(np.mean(black.delta_e)) > float(np.mean(good.delta_e)) or flags


def test_clipped_frames_are_flagged(cacaphony, chapter_camera):
    pipe = Pipeline()
    proc = Processing(metrics=("cielab",))
    x2 = pipe.run(cacaphony, chapter_camera.replace(exposure=0.2), proc).exposure
    share = float(np.mean(cs.simulate(cacaphony, chapter_camera.replace(exposure=0.2)).data >= 255))
    assert x2.clipped == pytest.approx(share) and x2.flags == (f"clipped: {100 * share:.1f} % of pixels at full scale",)
    x32 = pipe.run(cacaphony, chapter_camera.replace(exposure=3.2), proc).exposure
    assert any(f.startswith("fully clipped:") for f in x32.flags)


def test_a_full_colour_camera_renders_its_clipped_pixels_white(cacaphony, chapter_camera, monitor):
    cam = chapter_camera.replace(mosaic=None, exposure=0.4)
    raw = cs.simulate(cacaphony, cam)
    out = cs.render(raw, monitor)
    clipped = np.any(raw.data >= 255, axis=2)
    assert 0.05 < clipped.mean() < 0.95
    assert np.all(out.data[clipped] == 255)
    assert out.extra["clipped_fraction"] == pytest.approx(clipped.mean())


@pytest.mark.parametrize("method", ["bilinear", "freeman", "malvar2004", "menon2007"])
def test_the_clipped_mask_holds_every_pixel_a_clipped_sample_changes(method):
    """One raw sample at full scale: every demosaiced pixel it moves (by more than 1e-9 DN) lies in the mask the
    demosaiced image carries to rendering, found by demosaicing with and without the clipped sample."""
    sens = camera_preset("kodak-dcs200").sensors
    rng = np.random.default_rng(7)
    base = rng.integers(40, 160, (48, 48)).astype(np.uint8)
    for y, x in ((20, 20), (20, 21), (21, 20), (21, 21)):
        hot = base.copy()
        hot[y, x] = 255
        a = cs.demosaic(cs.raw_from_array(base, "GRBG", sensitivities=sens), method)
        b = cs.demosaic(cs.raw_from_array(hot, "GRBG", sensitivities=sens), method)
        moved = np.abs(b.data - a.data).max(axis=2) > 1e-9
        mask = b.extra["clipped"]
        assert a.extra["clipped"] is None and mask[y, x] and moved.any()
        assert not np.any(moved & ~mask), np.argwhere(moved & ~mask)


def _dark_frame(size=256):
    scene = Scene(np.zeros((size, size, 31)), np.arange(400, 701, 10.0))
    cam = camera_preset("kodak-dcs200-ir", noise_sigma=8.0, black_level=64, seed=11)
    return cs.simulate(scene, cam)


@pytest.mark.parametrize("method", ["bilinear", "freeman", "bayesian", "bayesian-original", "malvar2004", "menon2007"])
def test_a_demosaiced_dark_frame_with_a_pedestal_has_a_mean_of_zero(method):
    """64 DN pedestal, 8 DN Gaussian noise, no light: the demosaiced mean is the raw's own mean less 64, within
    0.5 DN of 0 (it was +3.1 DN when values below the pedestal were clipped at 0)."""
    raw = _dark_frame()
    assert np.mean(raw.data == 0) == 0  # the ADC clipped nothing: 64 DN is 8 sigma
    out = cs.demosaic(raw, method)
    assert abs(float(out.data.mean())) < 0.5
    assert float(out.data.mean()) == pytest.approx(float(raw.data.mean()) - 64.0, abs=0.05)
    assert np.mean(out.data < 0) > 0.3  # signed: the noise's lower half is kept


def test_the_dark_frames_samples_keep_the_noise_sigma():
    """Bilinear keeps each sampled value: at the samples the standard deviation is the noise's (8 DN and the
    8-bit step's 1/12 DN^2); a green estimate between samples, the mean of four, has half of it."""
    raw = _dark_frame()
    out = cs.demosaic(raw, "bilinear")
    from camsim_core.simulation import tile_index_map

    idx = tile_index_map(raw.tile, raw.data.shape)
    inner = np.zeros(raw.data.shape, bool)
    inner[2:-2, 2:-2] = True
    expected = np.sqrt(8.0**2 + 1 / 12)
    for k in range(3):
        at = (idx == k) & inner
        np.testing.assert_array_equal(out.data[..., k][at], raw.data[at] - 64.0)
        assert out.data[..., k][at].std() == pytest.approx(expected, rel=0.03)
    g = raw.sensor_names.index("G") if "G" in raw.sensor_names else 1
    between = (idx != g) & inner
    assert out.data[..., g][between].std() == pytest.approx(expected / 2, rel=0.05)
    stats = cs.metrics.region_snr(raw)
    for name in raw.sensor_names:
        assert abs(stats[name]["mean"]) < 0.3 and stats[name]["sigma"] == pytest.approx(expected, rel=0.03)


def test_pixel_size_snr_at_5_lux_follows_the_emva_1288_model():
    """The 1 um pixel at 5 lux (64 x gain, read noise about 51 DN): the grey field's green SNR is the EMVA 1288
    linear model's within 0.5 dB (it read -0.45 dB for the model's -5 dB when the ADC and the black-level
    subtraction clipped at 0), and the ADC clips no green pixel at 0.

    The model, in electrons: signal mu_e + mu_d (the photo-electrons from the noiseless sensor stage, and the dark
    signal, which stays above the pedestal), noise sqrt(sigma_read^2 + mu_d + DSNU^2 + mu_e + (PRNU mu_e)^2 +
    sigma_q^2 / K^2) with sigma_q^2 = 1/12 DN^2 and K the system gain in DN/e-.
    """
    from camsim_core.experiments import pixel_size as ps
    from camsim_core.image import image_from_scene
    from camsim_core.scene.charts import uniform_scene
    from camsim_core.simulation import run_stages, simulate, tile_index_map

    lux = 5.0
    cam, _ = ps.operating_point(1.0, lux, 0)
    cam = cam.replace(optics="none")
    k_gain = cam.analog_gain / cam.electrons_per_dn
    assert cam.analog_gain == 64.0 and cam.read_noise * k_gain == pytest.approx(50.6, abs=0.5)
    grey = uniform_scene(cam.height, luminance=0.18 * lux / np.pi, distance=ps.DISTANCE_M,
                         angular_resolution=cam.angular_resolution)
    mean_stages = [s for s in cam.architecture if s.__name__ in ("sensor_responses", "resample", "mosaic")]
    mean = run_stages(cam, image_from_scene(grey), mean_stages)
    idx = tile_index_map(cam.mosaic, mean.data.shape)
    g = list(cam.sensors.names).index("G")
    mu_e = float(np.mean(mean.data[idx == g])) * cam.electrons_per_dn
    mu_d = cam.dark_current * cam.exposure
    var = cam.read_noise**2 + mu_d + cam.dsnu**2 + mu_e + (cam.prnu * mu_e) ** 2 + 1 / 12 / k_gain**2
    model = 20 * np.log10((mu_e + mu_d) / np.sqrt(var))
    measured = [ps.grey_snr(cam.replace(seed=s), lux) for s in range(3)]
    assert abs(np.mean(measured) - model) < 0.5, (measured, model)
    assert -6.5 < model < -3.5
    raw = simulate(grey, cam)
    assert np.mean(raw.data[idx == g] == 0) < 0.005


def _saturating_imx174(gain, luminance, size=(64, 96)):
    """The IMX174 (12 bits, full well 32,000 e-, 7 e- read noise, 2 e- DSNU) at analog ``gain`` on a uniform field
    of ``luminance`` cd/m^2 filling its (small) frame: (camera, raw, the pipeline's result)."""
    from camsim_core.scene.charts import uniform_scene

    cam = camera_preset("imx174").replace(analog_gain=gain, height=size[0], width=size[1])
    scene = uniform_scene(size, luminance=luminance, distance=cam.distance or 3.32,
                          angular_resolution=cam.angular_resolution)
    res = Pipeline().run(scene, cam, Processing(metrics=("cielab",)))
    return cam, res.raw, res


def test_pixels_at_the_full_well_below_full_scale_are_clipped():
    """Gain 0.5: the full well (32,000 e-) times the system gain K = 0.5 / electrons_per_dn is half the ADC's
    4095 DN. A uniform field bright enough to fill the well 100 times over saturates every pixel in the sensor:
    its raw sits at K x full well (within the read-out noise), far below full scale, where the ADC clips
    nothing. Each pixel is clipped all the same (its value says only that the light was at least this much):
    the clipped share is ~1 and the frame is flagged, here and in the explorer's flags."""
    from camsim_explorer.views import _exposure_flags
    from camsim_core.metrics.exposure import exposure_measures

    cam, raw, res = _saturating_imx174(0.5, 1e5)
    k = cam.analog_gain / cam.electrons_per_dn
    well_dn = cam.black_level + cam.full_well * k  # 2047.5 DN: the saturated value, from the EMVA 1288 model
    data = np.asarray(raw.data, float)
    assert well_dn < 0.6 * raw.full_scale
    # every pixel saturated in the sensor: at the well's value within the read-out noise (7 e-, 2 e- DSNU) and
    # the ADC's rounding, and none at full scale (the old measure counted only those: 0 %)
    sigma_dn = np.hypot(cam.read_noise, cam.dsnu) * k
    assert np.all(np.abs(data - well_dn) <= 5 * sigma_dn + 0.5)
    assert not np.any(data >= raw.full_scale - 0.5)
    m = exposure_measures(raw, cam)
    assert m.clipped > 0.999
    assert any(f.startswith("fully clipped:") and "full well" in f for f in m.flags), m.flags
    assert any(f.startswith("fully clipped:") for f in _exposure_flags(res))
    # the same for the result's own measure (the CLI's and the report's) and the explorer's stats line
    from camsim_explorer.state import exposure_warnings

    assert res.exposure.clipped > 0.999
    assert exposure_warnings(raw, cam)[0] > 0.999


def test_a_frame_below_the_full_well_is_not_clipped_and_a_partial_one_is_counted():
    """The same camera on a field whose brightest pixel holds about 40 % of the well (found from a field at
    100 cd/m^2, where the sensor is linear: electrons proportional to the light): no pixel is near the well,
    nothing is clipped. Half the frame from the saturating field and half from this one: the clipped share is
    the saturated half's, 0.5."""
    from camsim_core.metrics.exposure import exposure_measures

    cam, saturated, _ = _saturating_imx174(0.5, 1e5)
    k = cam.analog_gain / cam.electrons_per_dn
    _, linear, _ = _saturating_imx174(0.5, 100.0)
    brightest = float(np.max(np.asarray(linear.data, float) - cam.black_level)) / k  # e- at 100 cd/m^2
    assert brightest < 0.3 * cam.full_well  # linear there: far below the well
    _, dim, _ = _saturating_imx174(0.5, 100.0 * 0.4 * cam.full_well / brightest)
    top = float(np.max(np.asarray(dim.data, float) - cam.black_level)) / k / cam.full_well
    assert 0.35 < top < 0.5
    assert exposure_measures(dim, cam).clipped == 0.0 and exposure_measures(dim, cam).flags == ()
    w = dim.data.shape[1] // 2
    half = dim.replace(data=np.concatenate([np.asarray(saturated.data)[:, :w], np.asarray(dim.data)[:, w:]], axis=1))
    assert exposure_measures(half, cam).clipped == pytest.approx(0.5)
