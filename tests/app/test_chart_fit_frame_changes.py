"""A chart fitted to the frame follows the frame (issue 37): after a new camera (another pixel count and field
of view) or a new distance, the chart picked in the scene list is fitted again; a chart whose options were
typed is left as they say.

The cover is measured on the raw against the new camera's frame, and from the chart's angular size (its
samples over their sampling, seen at its distance from the camera's distance) against the frame's.
"""

import numpy as np
import pytest

from camsim_explorer.state import ExplorerState


def cover(state):
    """(rows, columns) of the frame the chart covers, from the raw and, independently, from the geometry."""
    cam, scene, raw = state.camera_object(), state.scene_object(), state.result.raw
    h, w = raw.data.shape[:2]
    # the chart's extent in degrees, as seen from the camera (a chart at distance d seen from D: d / D of it)
    seen = scene.distance / cam.distance
    deg_h = scene.data.shape[0] / scene.angular_resolution[1] * seen
    deg_w = scene.data.shape[1] / scene.angular_resolution[0] * seen
    geo = (min(1.0, deg_h * cam.angular_resolution[1] / cam.height), min(1.0, deg_w * cam.angular_resolution[0] / cam.width))
    assert h / cam.height == pytest.approx(geo[0], abs=2 / cam.height)
    assert w / cam.width == pytest.approx(geo[1], abs=2 / cam.width)
    return h / cam.height, w / cam.width


@pytest.mark.parametrize("chart", ["slanted-edge", "munsell"])
def test_a_fitted_chart_is_fitted_again_to_a_new_camera(chart):
    state = ExplorerState(start=False)
    state.scene = chart
    assert min(cover(state)) >= 0.8
    before = state.scene
    state.camera = "imx174"  # 1200 x 1920 pixels at 35.9 px/deg (the DCS-200: 1012 x 1524 at 102.6)
    cam = state.camera_object()
    assert (cam.height, cam.width) == (1200, 1920) and state.message == "", state.message
    assert state.scene != before and state.scene.startswith(chart + ":")
    rows, cols = cover(state)
    assert rows >= 0.8 and cols >= 0.8, (rows, cols)
    # exposed again for the new sensor: its bright end at 50-90 % of full scale
    raw = np.asarray(state.result.raw.data, float) - cam.black_level
    top = np.percentile(raw, 99.5) / (state.result.raw.full_scale - cam.black_level)
    assert 0.5 <= top <= 0.9, top
    assert "Chart sized to the frame" in state.notice


def test_a_fitted_chart_is_fitted_again_at_a_new_distance_keeping_the_exposure():
    state = ExplorerState(start=False)
    state.scene = "zone-plate"
    exposure = state.exposure
    state.distance = 1.5
    assert state.camera_object().distance == 1.5 and state.scene_object().distance == pytest.approx(1.5)
    rows, cols = cover(state)
    assert rows >= 0.8 and cols >= 0.8, (rows, cols)
    assert state.exposure == exposure  # a chart's radiance does not change with the distance


def test_a_chart_of_typed_options_is_not_refitted():
    state = ExplorerState(start=False)
    state.scene = "uniform"
    assert state.set_chart("size=64x96, distance=3.32")
    typed = state.scene
    state.distance = 2.0
    assert state.scene == typed  # as its options say: 64 x 96 samples at 3.32 m
    rows, cols = cover(state)
    assert rows < 0.8 and cols < 0.8
