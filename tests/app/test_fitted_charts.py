"""Charts picked in the explorer fill the frame and are exposed (issue 37).

At the explorer's default camera (the DCS-200 at 3.32 m) the default charts
were postage stamps (the slanted edge 39 x 39 pixels, the uniform field
10 x 10) near 1 % of full scale. Picking one now sizes it to the camera's
field of view and exposes it. Measured on the simulated raw: its extent
against the camera's frame (and against the chart's angular size, from its
samples, sampling and distance), its level above the pedestal against full
scale, the slanted edge's rows, the uniform field's pixels per channel, and
the zone plate's highest local frequency in the chart itself.
"""

import numpy as np
import pytest

from camsim_explorer.state import ExplorerState
from camsim_core.scene.charts import CHART_NAMES, chart, fitted_chart_options, parse_chart


@pytest.fixture(scope="module")
def picked():
    """Each chart picked in one explorer session at its defaults: (scene name, raw, camera, chart scene)."""
    state = ExplorerState()
    out = {}
    for name in CHART_NAMES:
        state.scene = name
        assert state.message == "", state.message
        assert state.scene.startswith(name + ":")
        out[name] = (state.scene, state.result.raw, state.camera_object(), state.scene_object(), state.notice)
    return out


@pytest.mark.parametrize("name", CHART_NAMES)
def test_a_picked_chart_fills_at_least_80_percent_of_the_frame(picked, name):
    key, raw, cam, scene, notice = picked[name]
    h, w = raw.data.shape[:2]
    assert h >= 0.8 * cam.height and w >= 0.8 * cam.width, (name, (h, w), (cam.height, cam.width))
    # the same extent from the chart's angular size: N samples at Phi px/deg, at the camera's distance
    big_h, big_w = scene.data.shape[:2]
    phi_x, phi_y = cam.angular_resolution
    assert scene.distance == pytest.approx(cam.distance)
    assert h == pytest.approx(big_h / scene.angular_resolution[1] * phi_y, abs=1.0)
    assert w == pytest.approx(big_w / scene.angular_resolution[0] * phi_x, abs=1.0)
    assert "Chart sized to the frame" in notice


@pytest.mark.parametrize("name", CHART_NAMES)
def test_a_picked_chart_is_exposed_to_50_90_percent_of_full_scale(picked, name):
    _, raw, cam, _, _ = picked[name]
    signal = np.asarray(raw.data, float) - float(cam.black_level)
    top = np.percentile(signal, 99.5) / (cam.full_scale - cam.black_level)
    assert 0.5 <= top <= 0.9, (name, top)
    assert np.max(raw.data) < cam.full_scale  # nothing clipped


def test_the_slanted_edge_crosses_at_least_100_rows(picked):
    _, raw, cam, _, _ = picked["slanted-edge"]
    a = np.asarray(raw.data, float)
    g = a[0::2, 1::2]  # one Bayer phase: one colour, no mosaic pattern in the differences
    rise = np.median(g[:, -20:]) - np.median(g[:, :20])
    crossing = np.abs(np.diff(g, axis=1)).max(axis=1) > 0.2 * rise
    assert rise > 0 and 2 * crossing.sum() >= 100


def test_the_uniform_field_gives_10000_pixels_per_channel(picked):
    _, raw, cam, _, _ = picked["uniform"]
    h, w = raw.data.shape[:2]
    tile = np.asarray(cam.mosaic)
    th, tw = tile.shape[:2]
    labels = np.tile(tile, (h // th + 1, w // tw + 1))[:h, :w]
    for k in range(len(cam.sensors.names)):
        assert (labels == k).sum() >= 10_000


def test_the_zone_plate_reaches_nyquist_without_aliasing_in_the_chart(picked):
    key, raw, cam, scene, _ = picked["zone-plate"]
    _, opts = parse_chart(key)
    h, w = scene.data.shape[:2]
    # reflectance mean + amplitude cos(pi k r^2): local frequency k r cycles per sample, k = max_frequency / (min/2)
    k = opts["max_frequency"] / (min(h, w) / 2)
    highest = k * np.hypot((h - 1) / 2, (w - 1) / 2)
    assert 0.49 <= highest <= 0.5
    # one chart sample per camera pixel: the chart's Nyquist is the camera's
    assert scene.angular_resolution[0] == pytest.approx(cam.angular_resolution[0], rel=1e-5)
    # and in the samples themselves: the phase advances by at most pi between neighbours (no aliasing)
    y, x = np.mgrid[0:h, 0:w]
    phase = np.pi * k * ((x - (w - 1) / 2) ** 2 + (y - (h - 1) / 2) ** 2)
    assert np.abs(np.diff(phase, axis=0)).max() <= np.pi * (1 + 1e-9)
    assert np.abs(np.diff(phase, axis=1)).max() <= np.pi * (1 + 1e-9)


def test_fitted_options_name_the_chart_they_make_and_a_large_camera_is_bounded():
    opts = fitted_chart_options("slanted-edge", (1012, 1524), (102.6, 102.6), 3.32)
    assert opts["size"] == (860, 1295) and opts["angular_resolution"] == 102.6 and opts["distance"] == 3.32
    big = fitted_chart_options("slanted-edge", (1944, 2592), (30.0, 30.0), 3.32, max_values=10_000_000)
    assert big["size"][0] * big["size"][1] * 31 <= 10_000_000 * 1.01
    # at the camera's own sampling, covering less of the frame: a coarser chart would be what the MTF measures
    assert big["angular_resolution"] == 30.0
    cover = np.array(big["size"]) / np.array([1944, 2592])
    assert cover == pytest.approx(np.sqrt(10_000_000 / (0.85**2 * 1944 * 2592 * 31)) * 0.85, rel=0.01)
    # a uniform field (no detail to measure) still covers 85 % of the frame, in coarser samples
    flat = fitted_chart_options("uniform", (1944, 2592), (30.0, 30.0), 3.32, max_values=1_000_000)
    assert flat["size"][0] / flat["angular_resolution"] == pytest.approx(0.85 * 1944 / 30.0, rel=0.01)
    assert flat["angular_resolution"] < 30.0 / 8
    given = fitted_chart_options("slanted-edge", (1012, 1524), (102.6, 102.6), 3.32, size=(64, 96), angle=10.0)
    s = chart("slanted-edge", **given)
    assert s.data.shape[:2] == (64, 96)
    # the side that fills its share of the frame first (here the height, 64 / 1012 > 96 / 1524) spans 85 %
    extent = np.array([64, 96]) / s.angular_resolution[0] * 102.6
    assert max(extent / (0.85 * np.array([1012, 1524]))) == pytest.approx(1.0, rel=1e-4)


@pytest.mark.parametrize("camera", ["kodak-dcs200", "imx174", "phone-1.4um"])
def test_every_shipped_camera_sees_the_edge_at_its_own_sampling(camera):
    # the MTF the quality tab shows is the camera's only if the chart is sampled as the camera samples: on a
    # chart 1.54 px per sample (phone-1.4um's, cut to the explorer's chart limit) MTF50 at f/2 read 0.17
    # cycles/px, against 0.25 for the same camera on a chart at its own sampling
    from camsim_core import load_camera
    from camsim_explorer.state import LIMITS

    cam = load_camera(camera)
    for name in ("slanted-edge", "zone-plate"):
        opts = fitted_chart_options(name, (cam.height, cam.width), cam.angular_resolution, 3.32,
                                    max_values=LIMITS.max_chart_values)
        assert opts["angular_resolution"] == pytest.approx(cam.angular_resolution[0], rel=1e-5), (name, opts)
        assert opts["size"][0] * opts["size"][1] * 31 <= LIMITS.max_chart_values
