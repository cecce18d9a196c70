"""S-CIELAB viewing geometry: samples per degree from how the rendered image is viewed."""

import math

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.cache import Pipeline, Processing
from camsim_core.errors import ParameterError
from camsim_core.metrics import Viewing, display_samples_per_degree, filter_opponent, parse_viewing, scielab
from camsim_core.scene import macbeth_scene


def test_parse_viewing_forms(dcs200_ir):
    assert parse_viewing(None).spec == "camera" and parse_viewing(None).rate(dcs200_ir) == pytest.approx(102.6)
    assert parse_viewing("camera/10").rate(dcs200_ir) == pytest.approx(10.26)
    assert parse_viewing("10.26").rate() == parse_viewing(10.26).rate() == parse_viewing("spd:10.26").rate() == 10.26
    d = parse_viewing("display:0.25mm@0.6m")
    assert d == parse_viewing("0.25@0.6") and d.spec == "display:0.25mm@0.6m"
    # one 0.25 mm pixel at 0.6 m subtends 2 atan(0.125 / 600) rad
    assert d.rate() == pytest.approx(1 / math.degrees(2 * math.atan(0.125e-3 / 0.6)))
    for v in ("camera", "camera/10", "spd:3", "display:0.3mm@1m"):
        assert parse_viewing(parse_viewing(v).spec) == parse_viewing(v)  # the spec round-trips
    assert "10.26 samples/deg" in parse_viewing("camera/10").describe(dcs200_ir)
    assert "original" in parse_viewing("camera/10").describe(dcs200_ir)


@pytest.mark.parametrize("bad", ["", "camera/0", "camera/x", "spd:-1", "0", "display:0mm@1m", "display:1mm@", "far away", -3.0])
def test_bad_viewing_is_a_clear_error(bad):
    with pytest.raises(ParameterError, match="viewing|samples_per_degree|pixel_pitch|viewing_distance|divisor"):
        parse_viewing(bad)


def test_camera_viewing_needs_the_image():
    with pytest.raises(ParameterError, match="angular resolution"):
        Viewing("camera").rate()


def test_viewing_distance_scales_the_filters_as_their_widths_predict():
    """Doubling the viewing distance doubles the samples per degree; every S-CIELAB Gaussian is
    fixed in degrees, so it becomes twice as wide in samples and its 2-D impulse response's peak
    falls by four (widths scale with the rate, peak ~ 1 / width^2)."""
    pitch = 0.25e-3
    s1 = parse_viewing("display:0.25mm@1m").rate()
    s2 = parse_viewing("display:0.25mm@2m").rate()
    assert s1 == pytest.approx(display_samples_per_degree(pitch, 1.0))
    assert s2 / s1 == pytest.approx(2.0, rel=1e-6)  # small angles: tan is linear to 1e-8 here
    impulse = np.zeros((301, 301, 3))
    impulse[150, 150, :] = 1.0
    p1 = filter_opponent(impulse, s1)[150, 150]
    p2 = filter_opponent(impulse, s2)[150, 150]
    # red-green and blue-yellow: two resolved Gaussians each
    np.testing.assert_allclose(p1[1:] / p2[1:], (s2 / s1) ** 2, rtol=0.05)
    # the S-CIELAB map of a faint grey impulse on grey: dE ~ linear in the filtered difference
    grey = np.full((201, 201, 3), 20.0)
    spot = grey.copy()
    spot[100, 100] += 5.0
    white = np.array([95.05, 100.0, 108.9])
    m1 = scielab(spot, grey, s1, white)
    m2 = scielab(spot, grey, s2, white)
    assert m1.max() / m2.max() == pytest.approx((s2 / s1) ** 2, rel=0.15)
    assert (m2 > 0.01 * m2.max()).sum() > 3 * (m1 > 0.01 * m1.max()).sum()  # spread over ~4x the area


def test_pipeline_takes_the_viewing():
    scene = macbeth_scene(patch_size=12, border=2)
    # cone sensors: the only errors against the ideal image are the noise and the mosaic's
    cam = cs.load_camera("human-cones").replace(noise_sigma=3.0, distance=scene.distance, mosaic=cs.simulation.bayer())
    cam = cam.replace(exposure=cs.auto_exposure(scene, cam))  # nothing clips (the preset's 1 s clips a fifth of the raw)
    pipe = Pipeline()
    a = pipe.run(scene, cam, Processing(viewing="camera"))
    b = pipe.run(scene, cam, Processing(viewing="camera/10"))
    assert a.samples_per_degree == pytest.approx(102.6) and b.samples_per_degree == pytest.approx(10.26)
    assert "scielab" in b.ran_steps and "render" not in b.ran_steps  # only the metric re-ran
    # seen ten times larger, the eye blurs away less of the noise and mosaic artifacts: the error grows
    assert b.scielab.mean() > 1.5 * a.scielab.mean()
    c = pipe.run(scene, cam, Processing(viewing="nonsense"))
    assert "scielab" in c.errors and "viewing" in c.errors["scielab"]


def test_scielab_takes_a_viewing_instead_of_a_number():
    rng = np.random.default_rng(0)
    a = rng.uniform(10, 50, (40, 40, 3))
    b = a + rng.normal(0, 1, a.shape)
    white = np.array([95.05, 100.0, 108.9])
    s = parse_viewing("display:0.25mm@0.6m").rate()
    np.testing.assert_array_equal(scielab(a, b, "display:0.25mm@0.6m", white), scielab(a, b, s, white))
    np.testing.assert_array_equal(scielab(a, b, Viewing("samples", samples_per_degree=12.0), white), scielab(a, b, 12.0, white))
    with pytest.raises(ParameterError, match="angular resolution"):
        scielab(a, b, "camera", white)  # needs the camera: use Viewing.rate(image)
