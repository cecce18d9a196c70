"""Test charts: geometry and radiometry against their definitions."""

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.datasets.illuminants import illuminant
from camsim_core.datasets.sensors import cie1931_xyz
from camsim_core.datasets.surfaces import munsell
from camsim_core.errors import ParameterError
from camsim_core.scene import munsell_scene, slanted_edge_scene, uniform_scene, zone_plate_scene
from camsim_core.spectra import resample


def _luminance(scene, pixel):
    return 683.0 * cie1931_xyz().on(scene.wavelengths)[1] @ scene.data[pixel]


@pytest.mark.parametrize("name", ["slanted-edge", "zone-plate", "uniform", "munsell"])
def test_charts_by_name_at_default_settings(name):
    scene = cs.load_scene(name)
    assert scene.data.ndim == 3 and scene.wavelengths.size == 31 and scene.illuminant is not None
    assert scene.name == name


def test_slanted_edge_position_and_contrast():
    h, w, angle = 64, 80, 7.0
    s = slanted_edge_scene((h, w), angle=angle, contrast=4.0, light=0.8)
    refl = s.data[:, :, 15] / s.illuminant.values[15]
    # the dark area in each row is where the line crosses the row's middle (exact for a straight edge)
    dark_width = (0.8 - refl).sum(axis=1) / (0.8 - 0.2)
    expected = w / 2 + (np.arange(h) + 0.5 - h / 2) * np.tan(np.radians(angle))
    np.testing.assert_allclose(dark_width, expected, atol=1e-3)
    assert refl[:, -1].mean() / refl[:, 0].mean() == pytest.approx(4.0)
    assert _luminance(s, (0, w - 1)) == pytest.approx(0.8 * 100.0, rel=1e-3)


def test_zone_plate_reaches_its_maximum_frequency():
    s = zone_plate_scene(256, max_frequency=0.4, mean=0.5, amplitude=0.4)
    row = s.data[128, 128:, 10] / s.illuminant.values[10] - 0.5  # centre to right edge
    crossings = np.count_nonzero(np.diff(np.sign(row)) != 0)
    # phase pi k r^2 with k = 0.4 / 128: (0.4 * 128 / 2) = 25.6 cycles -> about 51 zero crossings
    assert abs(crossings - 51) <= 2
    assert row.max() <= 0.4 + 1e-12 and row.min() >= -0.4 - 1e-12


def test_uniform_field_has_its_luminance_under_any_illuminant():
    d65 = uniform_scene(16, luminance=37.0)
    a = uniform_scene(16, luminance=37.0, illuminant="A")
    assert _luminance(d65, (3, 4)) == pytest.approx(37.0, rel=1e-6)
    assert _luminance(a, (3, 4)) == pytest.approx(37.0, rel=1e-6)
    ratio = a.data[0, 0] / d65.data[0, 0]
    spd_ratio = illuminant("A").on(a.wavelengths) / illuminant("D65").on(a.wavelengths)
    np.testing.assert_allclose(ratio / ratio[15], spd_ratio / spd_ratio[15], rtol=1e-6)
    assert np.ptp(d65.data, axis=(0, 1)).max() == 0


def test_munsell_grid_patches_are_the_chips():
    s = munsell_scene(2, 3, patch_size=10, border=2, chips=[0, 100, 200, 300, 400, 500])
    mw, refl = munsell()
    chips = resample(mw, refl[[0, 100, 200, 300, 400, 500]], s.wavelengths)
    for i in range(6):
        r, c = divmod(i, 3)
        y, x = 2 + r * 12 + 5, 2 + c * 12 + 5
        np.testing.assert_allclose(s.data[y, x] / s.illuminant.values, chips[i], rtol=1e-12)
    assert s.data[0, 0].max() == 0  # black gaps


def test_chart_parameters_are_checked():
    with pytest.raises(ParameterError, match="angle"):
        slanted_edge_scene(64, angle=0.0)
    with pytest.raises(ParameterError, match="contrast"):
        slanted_edge_scene(64, contrast=0.5)
    with pytest.raises(ParameterError, match="max_frequency"):
        zone_plate_scene(64, max_frequency=0.9)
    with pytest.raises(ParameterError, match="luminance"):
        uniform_scene(16, luminance=-1)
    with pytest.raises(ParameterError, match="chart"):
        cs.scene.chart("siemens-star")


def test_charts_with_options_by_name():
    s = cs.load_scene("slanted-edge:angle=10,contrast=2,size=64x96,illuminant=A")
    assert s.shape[:2] == (64, 96) and s.illuminant.name == "CIE A" and "10 deg, contrast 2:1" in s.comments
    u = cs.load_scene("uniform:luminance=12.5,size=16")
    assert _luminance(u, (0, 0)) == pytest.approx(12.5, rel=1e-6)
    with pytest.raises(ParameterError, match="no option angel"):
        cs.load_scene("slanted-edge:angel=10")
    with pytest.raises(ParameterError, match="key=value"):
        cs.load_scene("zone-plate:0.4")


@pytest.mark.parametrize("name", ["slanted-edge:size=40x56,angle=10", "zone-plate:size=48", "uniform:size=16",
                                  "munsell:rows=2,cols=3,patch_size=5,border=2"])
def test_chart_shape_is_the_shape_of_the_chart_made(name):
    from camsim_core.scene.charts import chart, chart_shape

    assert chart_shape(name) == chart(name).data.shape


def test_a_chart_too_large_is_refused_before_anything_is_allocated():
    import tracemalloc

    from camsim_core.scene.charts import MAX_CHART_VALUES, chart

    tracemalloc.start()
    try:
        with pytest.raises(ParameterError, match="size: 100000 x 100000 pixels x 31 wavelengths"):
            chart("slanted-edge:size=100000")
        with pytest.raises(ParameterError, match="more than the 1,000 values"):
            chart("uniform:size=16", max_values=1000)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1e6  # bytes: nothing of the chart's size was made
    assert MAX_CHART_VALUES == 2048 * 2048 * 31
    with pytest.raises(ParameterError, match="whole numbers"):
        chart("munsell:rows=2.5")


@pytest.mark.parametrize("options", [{}, {"angle": 10.5, "contrast": 2}, {"size": (64, 96), "illuminant": "A"}])
def test_chart_name_is_read_back_by_parse_chart(options):
    from camsim_core.scene.charts import chart_name, parse_chart

    assert parse_chart(chart_name("slanted-edge", options)) == ("slanted-edge", options)
