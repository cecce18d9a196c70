"""The Macbeth chart picked in the explorer fills the frame like the other charts (issue 37).

Before, picking it left the shipped 84 x 124-sample chart (57.3 px/deg, 1 m away) at 45 x 67 pixels of the
DCS-200's 1012 x 1524 at 3.32 m, 10 % of full scale, flagged under-exposed. Checked here against the
geometry (the chart's angular size from its samples, their sampling and its distance), the chart's known
layout in the raw, and the name, which must make the same chart again (links, files, the report).
"""

import numpy as np
import pytest

import camsim_core as cs
from camsim_explorer.state import ExplorerState
from camsim_core.scene import macbeth_scene
from camsim_core.scene.charts import CHART_NAMES, chart, chart_shape, parse_chart


@pytest.fixture(scope="module")
def picked():
    state = ExplorerState(start=False)
    state.scene = "macbeth"
    return state


def test_the_macbeth_chart_is_a_chart_whose_default_is_the_shipped_scene():
    assert "macbeth" in CHART_NAMES and cs.SCENE_NAMES.count("macbeth") == 1
    shipped, made = cs.load_scene("macbeth"), chart("macbeth")
    np.testing.assert_array_equal(made.data, shipped.data)
    assert made.angular_resolution == shipped.angular_resolution and made.distance == shipped.distance
    assert chart_shape("macbeth:patch_size=32,border=8") == (8 + 4 * 40, 8 + 6 * 40, 31)


def test_picking_the_macbeth_chart_fills_the_frame_and_exposes_it(picked):
    state = picked
    assert state.message == "" and state.scene.startswith("macbeth:"), (state.scene, state.message)
    cam, raw, scene = state.camera_object(), state.result.raw, state.scene_object()
    h, w = raw.data.shape[:2]
    assert h >= 0.8 * cam.height and w >= 0.8 * cam.width, ((h, w), (cam.height, cam.width))
    # the chart's angular extent (samples / samples per degree) over the camera's degrees per pixel
    assert scene.distance == pytest.approx(cam.distance)
    assert h == pytest.approx(scene.data.shape[0] / scene.angular_resolution[1] * cam.angular_resolution[1], abs=1)
    assert w == pytest.approx(scene.data.shape[1] / scene.angular_resolution[0] * cam.angular_resolution[0], abs=1)
    top = np.percentile(np.asarray(raw.data, float) - cam.black_level, 99.5) / (cam.full_scale - cam.black_level)
    assert 0.5 <= top <= 0.9 and np.max(raw.data) < cam.full_scale
    assert state.result.exposure.flags == ()
    assert "Chart sized to the frame" in state.notice


def test_the_fitted_name_makes_the_same_chart_with_its_layout(picked):
    """The name reads back as the chart's options and loads the same chart; only the sampling and the distance
    change, so the 4 x 6 patches keep the layout the colour measure uses, scaled to the raw: each patch's
    centre in the raw is uniform, the white patch (19th) the brightest, the black gaps dark."""
    state = picked
    name, opts = parse_chart(state.scene)
    assert name == "macbeth" and set(opts) == {"angular_resolution", "distance"}
    again = cs.load_scene(state.scene)
    np.testing.assert_array_equal(again.data, state.scene_object().data)
    assert again.angular_resolution == state.scene_object().angular_resolution
    np.testing.assert_array_equal(np.asarray(again.data, float), macbeth_scene(distance=opts["distance"],
                                  angular_resolution=(opts["angular_resolution"],) * 2).data)
    raw = np.asarray(state.result.raw.data, float)
    g = raw[0::2, 1::2]  # one Bayer phase (one colour), half the resolution
    sy, sx = g.shape[0] / 84, g.shape[1] / 124  # layout: 4 px gaps, 16 px patches, 84 x 124 samples
    means = []
    for i in range(24):
        row, col = divmod(i, 6)
        y0, x0 = 4 + row * 20, 4 + col * 20
        box = g[int((y0 + 5) * sy): int((y0 + 11) * sy), int((x0 + 5) * sx): int((x0 + 11) * sx)]
        assert box.std() < 0.05 * box.mean() + 2  # one patch: uniform (noise-free camera, 8-bit steps)
        means.append(box.mean())
    assert int(np.argmax(means)) == 18
    gap = g[int(4 * sy): int(80 * sy), int(21 * sx): int(23 * sx)]  # the gap between the first two columns
    assert gap.mean() < 0.1 * max(means)
