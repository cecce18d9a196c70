"""A ColorChecker found in an image by colour-checker-detection: its patches where the chart's layout puts them."""

import dataclasses
import sys

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.cli import main
from camsim_core.errors import ParameterError
from camsim_core.metrics import chart_delta_e, macbeth_patch_boxes
from camsim_core.metrics.chart import find_macbeth_patches, macbeth_delta_e
from camsim_core.rendering import to_xyz, white_xyz
from camsim_core.scene import macbeth_scene

MONITOR = "simtoolbox-test"
AT = (100, 150)  # where the chart sits in a larger grey frame


@pytest.fixture(scope="module")
def chart():
    """The DCS-200's rendered Macbeth chart and its ideal image (monitor settings, 0-255), filling the image."""
    scene = macbeth_scene()
    cam = cs.load_camera("kodak-dcs200-ir").replace(distance=scene.distance, mosaic=None, noise_sigma=0.0)
    ex = cs.auto_exposure(scene, cam)
    return cs.render(cs.simulate(scene, cam, exposure=ex), MONITOR), cs.ideal_image(scene, cam, MONITOR, exposure=ex)


def framed(image, shape=(400, 500), grey=60.0):
    data = np.asarray(image.data, float)
    out = np.full(shape + (3,), grey)
    out[AT[0] : AT[0] + data.shape[0], AT[1] : AT[1] + data.shape[1]] = data
    return dataclasses.replace(image, data=out)


def assert_inside(found, patches):
    """Every found box is a non-empty box inside the same patch (whole patch, no margin) of the layout."""
    assert found is not None and len(found) == 24
    for i, ((y0, y1, x0, x1), (py0, py1, px0, px1)) in enumerate(zip(found, patches)):
        assert py0 <= y0 < y1 <= py1 and px0 <= x0 < x1 <= px1, f"patch {i + 1}: {(y0, y1, x0, x1)} outside {(py0, py1, px0, px1)}"


def test_a_chart_in_a_larger_frame_is_found_where_its_layout_puts_it(chart):
    rendered, _ = chart
    h, w = rendered.data.shape[:2]
    whole = [(y0 + AT[0], y1 + AT[0], x0 + AT[1], x1 + AT[1]) for y0, y1, x0, x1 in macbeth_patch_boxes((h, w), margin=0.0)]
    assert_inside(find_macbeth_patches(framed(rendered).data), whole)


def test_a_chart_turned_to_portrait_is_found_with_its_patches_in_chart_order(chart):
    """The image turned 90 degrees clockwise: (row r, column c) -> (c, H - 1 - r); dark skin is still patch 1."""
    rendered, _ = chart
    frame = framed(rendered).data
    big_h = frame.shape[0]
    turned = np.ascontiguousarray(np.rot90(frame, -1))
    h, w = rendered.data.shape[:2]
    whole = [(x0 + AT[1], x1 + AT[1], big_h - (y1 + AT[0]), big_h - (y0 + AT[0]))
             for y0, y1, x0, x1 in macbeth_patch_boxes((h, w), margin=0.0)]
    assert_inside(find_macbeth_patches(turned), whole)


def test_detected_patches_give_the_layouts_colour_errors(chart):
    """Per-patch CIEDE2000 of the framed chart from detected patches against the layout's boxes moved to
    the chart's place: the same patches, so the same errors (the boxes differ by a pixel or two)."""
    rendered, ideal = chart
    r, i = framed(rendered), framed(ideal)
    found = macbeth_delta_e(r, i, MONITOR, patches="detect")
    assert found["patches"] == "detected"
    h, w = rendered.data.shape[:2]
    boxes = [(y0 + AT[0], y1 + AT[0], x0 + AT[1], x1 + AT[1]) for y0, y1, x0, x1 in macbeth_patch_boxes((h, w))]
    from camsim_core import load_monitor

    mon = load_monitor(MONITOR)
    known = chart_delta_e(to_xyz(r, mon), to_xyz(i, mon), boxes, white=white_xyz(mon))
    assert known["mean"] > 1.0  # the DCS-200 is not colorimetric: there are errors to find again
    np.testing.assert_allclose(found["per_patch"], known["per_patch"], atol=0.5)
    assert abs(found["mean"] - known["mean"]) < 0.2


def test_no_chart_falls_back_on_the_layout_and_says_so(chart):
    _, ideal = chart
    grey = dataclasses.replace(ideal, data=np.full(ideal.data.shape, 120.0))
    assert find_macbeth_patches(grey.data) is None
    out = macbeth_delta_e(grey, grey, MONITOR, patches="detect")
    assert out["patches"] == "layout" and out["mean"] == 0.0


def test_without_the_detector_there_is_no_detection(chart, monkeypatch):
    monkeypatch.setitem(sys.modules, "colour_checker_detection", None)  # import fails as when not installed
    rendered, ideal = chart
    assert find_macbeth_patches(framed(rendered).data) is None
    assert macbeth_delta_e(rendered, ideal, MONITOR, patches="detect")["patches"] == "layout"


def test_bad_patch_source_and_image_are_refused(chart):
    rendered, ideal = chart
    with pytest.raises(ParameterError, match="patches"):
        macbeth_delta_e(rendered, ideal, MONITOR, patches="guess")
    with pytest.raises(ParameterError, match="rgb"):
        find_macbeth_patches(np.zeros((10, 10)))


def test_cli_measure_says_where_the_patches_came_from(capsys):
    """--patches detect finds the chart; the generated chart's own default is its layout."""
    assert main(["measure", "--scene", "macbeth", "--what", "color", "--patches", "detect"]) == 0
    assert "patches detected in the image" in capsys.readouterr().out
    assert main(["measure", "--scene", "macbeth", "--what", "color"]) == 0
    assert "patches from the chart's layout" in capsys.readouterr().out
