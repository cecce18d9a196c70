"""Design review engine (camsim_core.review) and ``camsim report`` without a browser."""

import dataclasses
import json
import re

import numpy as np
import pytest

import camsim_core as cc
from camsim_core.cli import main
from camsim_core.errors import CamsimError, ParameterError
from camsim_core.review import (DESIGN_DEFAULTS, camera_from_params, design_at, differing_parameters, evaluate_design,
                                iter_sweep, read_design_file, run_sweep)
from camsim_core.review.difference import ab_difference
from camsim_core.review.report import colour_map, report_html, shared_scale

DCS = {"camera": "kodak-dcs200-ir"}
CONES = {"camera": "human-cones", "bits": 0}  # unquantized: differs from the scene's ideal image by the display's rounding


@pytest.fixture(scope="module")
def dcs():
    return evaluate_design(DCS, "dcs")


@pytest.fixture(scope="module")
def cones():
    return evaluate_design(CONES, "cones")


def test_design_defaults_are_the_explorers_file_format():
    from camsim_explorer.state import URL_PARAMETERS, ExplorerState

    saved = json.loads(ExplorerState().to_json())
    assert {k: saved[k] for k in URL_PARAMETERS} == DESIGN_DEFAULTS


def test_camera_from_params_builds_the_engine_objects():
    from camsim_core.datasets.sensors import mixture

    cam = camera_from_params({"camera": "mixture", "alpha": 0.3, "mosaic": "none", "bits": 0, "noise_sigma": 2.5})
    assert np.allclose(cam.sensors.values, mixture(0.3).values)
    assert cam.mosaic is None and cam.bits is None and cam.noise_sigma == 2.5
    g = camera_from_params({"camera": "gaussian-4", "gaussian_centers": "450, 500, 600, 650", "mosaic": "4-sensor grid"})
    assert np.allclose(g.sensors.wavelengths[np.argmax(g.sensors.values, axis=1)], [450, 500, 600, 650])
    assert np.array_equal(g.mosaic, [[0, 1], [2, 3]])
    d = camera_from_params({"distance": 5.0, "exposure": 0.2, "f_stop": 8})
    assert (d.distance, d.exposure, d.f_stop, d.bits) == (5.0, 0.2, 8.0, 8)


def test_cones_design_is_the_ideal_image_and_dcs200_is_not(dcs, cones):
    # the ideal image is the scene through the cones, unquantized: the unquantized, noiseless cones camera's
    # rendering is it rounded to the monitor's integer values (half a step, and float32 rounding, at most)
    assert np.abs(cones.rendered - cones.ideal).max() <= 0.5 + 1e-3
    assert cones.measures["cielab"]["mean"] < 0.5 and cones.measures["cielab"]["p95"] < 1.0
    assert dcs.measures["cielab"]["mean"] > 5 and dcs.measures["scielab"]["mean"] > 5


def test_measures_match_a_direct_run_of_the_engine(dcs):
    # an independent path: the public stage functions, without the cache
    scene = cc.load_scene("cacaphony290")
    cam = cc.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0, noise_mean=0.0)
    mon = cc.load_monitor("simtoolbox-test")
    rendered = cc.render(cc.demosaic(cc.simulate(scene, cam), "bilinear"), mon, method="baseline")
    ideal = cc.ideal_image(scene, cam, mon)
    from camsim_core.rendering import white_xyz

    de = cc.metrics.delta_e(np.asarray(cc.to_xyz(rendered, mon).data), np.asarray(cc.to_xyz(ideal, mon).data),
                            np.asarray(white_xyz(mon), float))
    assert np.array_equal(dcs.rendered, rendered.data)
    assert np.array_equal(dcs.ideal, ideal.data)
    # the pipeline takes the unquantized ideal image to XYZ in float64 (rendering.ideal.ideal_xyz), to_xyz in
    # float32: the same to float32 rounding
    # float32 rounding of L*a*b* values up to 100 is ~1e-5 a value, a few of them in one dE: the two maps agree
    # pixel by pixel within 1e-4 dE (9e-5 measured with numpy 2.4), so do their order statistics (a quantile moves
    # no more than the most any value moves); the mean averages the rounding out
    de = np.asarray(de, float)
    assert np.nanmax(np.abs(de - dcs.delta_e)) < 1e-4
    assert dcs.measures["cielab"]["mean"] == pytest.approx(float(np.mean(de)), rel=1e-6)
    assert dcs.measures["cielab"]["median"] == pytest.approx(float(np.median(de)), abs=1e-4)
    assert dcs.measures["cielab"]["p95"] == pytest.approx(float(np.percentile(de, 95)), abs=1e-4)


def test_ab_difference_against_the_ideal_design_is_the_error_map(dcs, cones):
    # the cones design renders the ideal image to the display's rounding, so dE(dcs, cones) is dcs's own error
    # map within the cones' (dE*ab is a distance in L*a*b*: the triangle inequality, to float32 rounding)
    ab = ab_difference(dcs, cones)
    assert np.all(np.abs(ab["delta_e"] - dcs.delta_e) <= cones.delta_e + 5e-4)
    assert ab["b_wins_fraction"] == pytest.approx(float(np.mean(dcs.delta_e > cones.delta_e)))
    assert ab["b_wins_fraction"] > 0.99
    assert ab["a_wins_fraction"] < 0.01
    same = ab_difference(dcs, dcs)
    assert np.all(same["delta_e"] == 0) and same["a_wins_fraction"] == same["b_wins_fraction"] == 0.0
    far = evaluate_design({"distance": 6.0}, "far", metrics=("cielab",))
    with pytest.raises(ParameterError, match="same geometry"):
        ab_difference(dcs, far)


def test_sweep_points_equal_each_configuration_run_alone():
    designs = [("dcs", DCS), ("cones", CONES)]
    values = [0.0, 3.0, 6.0]
    arrived = list(iter_sweep(designs, "noise_sigma", values, metrics=("cielab",)))
    assert sorted((p.name, p.value) for p in arrived) == sorted((n, v) for n, _ in designs for v in values)
    for p in arrived:
        alone = evaluate_design({**dict(designs)[p.name], "noise_sigma": p.value}, p.name, metrics=("cielab",))
        assert p.error is None and p.measures == alone.measures
    by = {(p.name, p.value): p.measure() for p in arrived}
    assert by[("cones", 0.0)] < 0.5 and by[("cones", 0.0)] < by[("cones", 3.0)] < by[("cones", 6.0)]  # grows with noise
    assert by[("dcs", 0.0)] < by[("dcs", 3.0)] < by[("dcs", 6.0)]


def test_sweep_of_a_gaussian_centre_changes_only_that_sensor():
    p = design_at({"camera": "gaussian-3"}, "gaussian_center_2", 500)
    assert p["gaussian_centers"] == "640, 500, 460"
    pts = run_sweep([("g3", {"camera": "gaussian-3"})], "gaussian_center_2", [500, 560], metrics=("cielab",))
    assert [p.value for p in pts] == [500, 560] and pts[0].measure() != pts[1].measure()


@pytest.mark.parametrize("designs, parameter, values, match", [
    ([("dcs", DCS)], "alpha", [0, 1], "mixture camera only"),
    ([("dcs", DCS)], "gaussian_center_1", [500], "Gaussian cameras only"),
    ([("dcs", DCS)], "noise_sigma", list(range(26)), "at most 25 values"),
    ([("dcs", DCS)], "noise_sigma", [-1], "noise_sigma"),
    ([("dcs", DCS)], "warp", [1], "expected one of"),
    ([(str(i), DCS) for i in range(6)], "noise_sigma", [1], "at most 5 designs"),
])
def test_bad_sweeps_are_refused_before_running(designs, parameter, values, match):
    with pytest.raises(ParameterError, match=match):
        run_sweep(designs, parameter, values)


def test_sweep_values_typed_as_text_have_the_sweeps_limit():
    """The Compare tab's values box is text: it was read with the Gaussian centres' limit (16 numbers, "at most 16
    sensors are allowed"), so 17-25 values were refused, and 26 with a message naming sensors."""
    from camsim_core.review import MAX_SWEEP_VALUES
    from camsim_core.review.sweep import check_sweep

    typed = ", ".join(str(v) for v in range(MAX_SWEEP_VALUES))
    assert check_sweep({"parameter": "noise_sigma", "values": typed})["values"] == [float(v) for v in range(25)]
    with pytest.raises(ParameterError, match="26 numbers given; at most 25 values are allowed"):
        check_sweep({"parameter": "noise_sigma", "values": typed + ", 25"})


def test_design_file_with_pinned_designs_and_a_sweep(tmp_path):
    from camsim_explorer.state import ExplorerState

    state = ExplorerState(camera="human-cones", noise_sigma=2.0)
    saved = json.loads(state.to_json())
    saved["pinned"] = [{"name": "DCS-200", "params": {"camera": "kodak-dcs200-ir"}},
                       {"name": "cones", "params": {"camera": "human-cones", "noise_sigma": 2.0}}]
    saved["sweep"] = {"parameter": "noise_sigma", "values": [0, 1]}
    path = tmp_path / "review.json"
    path.write_text(json.dumps(saved))
    designs, sweep = read_design_file(path)
    # the file's own design equals the pinned "cones": listed once
    assert [n for n, _ in designs] == ["DCS-200", "cones"]
    assert designs[1][1]["noise_sigma"] == 2.0 and designs[0][1]["scene"] == "cacaphony290"
    assert sweep == {"parameter": "noise_sigma", "values": [0.0, 1.0]}
    assert differing_parameters([p for _, p in designs]) == ["camera", "noise_sigma"]
    # the explorer's view settings are read beside the design, and a bad one is refused by name
    assert saved["de_scale"] == "data"
    path.write_text(json.dumps(dict(saved, de_scale="upside down")))
    with pytest.raises(ParameterError, match="de_scale"):
        read_design_file(path)


def test_report_html_holds_the_numbers_and_only_embedded_images(dcs, cones):
    text = report_html([dcs, cones])
    for r in (dcs, cones):
        assert f'data-value="{r.measures["cielab"]["mean"]!r}"' in text
        assert f'data-value="{r.measures["cielab"]["median"]!r}"' in text
    srcs = [s.split('"', 1)[0] for s in text.split('src="')[1:]]
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    assert "http://" not in text and "https://" not in text
    assert f"camsim {cc.__version__}" in text and "cacaphony290" in text


def test_parameters_a_camera_does_not_use_are_not_listed_as_differences(dcs, cones):
    """Gaussian centres a student left set after visiting gaussian-4 travel with every later design; the
    comparison listed them as a difference between the DCS-200 and the cones. The engine ignores them for
    those cameras: the same camera is built with or without them."""
    import dataclasses

    left = {"gaussian_centers": "460, 520, 580, 640", "gaussian_widths": "30", "alpha": 0.2, "custom_tile": "0 1 2"}
    assert camera_from_params(dict(DCS, **left)).sensors == camera_from_params(DCS).sensors  # ignored indeed
    assert differing_parameters([dict(DCS, **left), CONES]) == ["camera", "bits"]
    g3, g4 = {"camera": "gaussian-3"}, {"camera": "gaussian-4", "gaussian_centers": "460, 520, 580, 640"}
    assert "gaussian_centers" in differing_parameters([g3, g4, dict(DCS, **left)])
    leftover = dataclasses.replace(dcs, params=dict(dcs.params, **left))
    g4_result = dataclasses.replace(cones, name="g4", params=dict(cones.params, **g4))
    text = report_html([leftover, g4_result])
    differ = text.split('id="differ"', 1)[1].split("</table>", 1)[0]
    assert "<th>gaussian_centers</th><td>\u2014</td><td>460, 520, 580, 640</td>" in differ
    assert "<th>alpha</th>" not in differ and "<th>custom_tile</th>" not in differ


def test_shared_colour_scale_covers_every_map():
    a, b = np.full((4, 4), 3.0), np.full((4, 4), 17.0)
    assert shared_scale([a, b]) == 20.0
    top = colour_map(np.array([[0.0, 20.0, 40.0]]), 20.0)
    assert np.array_equal(top[0, 1], top[0, 2])  # clipped at the top of the scale


# -- the command line: bad input -------------------------------------------------------------
def _run(capsys, *argv):
    code = main(["report", *map(str, argv)])
    return code, capsys.readouterr()


@pytest.mark.parametrize("content, expected", [
    (None, "no such file"),
    ("{not json", "not a JSON parameters file"),
    ('["a list"]', "expected a JSON object"),
    ('{"scene": "moon"}', "unknown scene 'moon'"),
    ('{"camera": "pinhole"}', "camera: expected one of"),
    ('{"noise_sigma": -3}', "noise_sigma: must lie in"),
    ('{"warp_factor": 9}', "unknown parameter(s) warp_factor"),
    ('{"pinned": [{"name": "x", "params": {"bits": "many"}}]}', "x: bits: expected a number"),
    ('{"sweep": {"parameter": "noise_sigma", "values": []}}', "sweep: values"),
])
def test_bad_design_file_one_line_exit_2_no_output(tmp_path, capsys, content, expected):
    path = tmp_path / "design.json"
    if content is not None:
        path.write_text(content)
    out = tmp_path / "report.html"
    code, io = _run(capsys, path, "--out", out)
    assert code == 2
    lines = io.err.strip().splitlines()
    assert len(lines) == 1 and "design.json" in lines[0] and expected in lines[0], io.err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ([] if content is None else ["design.json"])


def test_bad_command_line_options(tmp_path, capsys):
    good = tmp_path / "a.json"
    good.write_text("{}")
    code, io = _run(capsys, good, "--out", tmp_path / "report.pdf")
    assert code == 2 and "expected an .html file name" in io.err
    code, io = _run(capsys, good, "--out", tmp_path / "missing" / "r.html")
    assert code == 2 and "does not exist" in io.err
    code, io = _run(capsys, good, "--out", tmp_path / "r.html", "--sweep", "noise_sigma")
    assert code == 2 and "PARAM=V1,V2" in io.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_engine_refusal_names_the_design(tmp_path, capsys):
    path = tmp_path / "grid.json"
    path.write_text(json.dumps({"mosaic": "4-sensor grid"}))  # the DCS-200 has 3 sensors
    code, io = _run(capsys, path, "--out", tmp_path / "r.html")
    assert code == 2 and io.err.count("\n") == 1 and "grid" in io.err and "sensor" in io.err
    assert not (tmp_path / "r.html").exists()
    with pytest.raises(CamsimError):
        evaluate_design({"mosaic": "4-sensor grid"}, "grid")


def test_quality_measures_follow_the_scene_and_match_independent_references():
    from skimage.metrics import peak_signal_noise_ratio

    edge = evaluate_design({"scene": "slanted-edge"})
    chart = evaluate_design({"scene": "macbeth"})
    photo = evaluate_design({"scene": "cacaphony290"})
    assert set(edge.quality) == {"psnr_db", "ssim", "mtf50"} and 0 < edge.quality["mtf50"] <= 0.5
    assert set(chart.quality) == {"psnr_db", "ssim", "macbeth_de2000"} and chart.quality["macbeth_de2000"] > 0
    assert set(photo.quality) == {"psnr_db", "ssim"} and 0 < photo.quality["ssim"] < 1
    # PSNR of the rendered image against the ideal one, as scikit-image computes it (8-bit monitor settings)
    expected = peak_signal_noise_ratio(np.asarray(photo.ideal, float), np.asarray(photo.rendered, float), data_range=255)
    assert photo.quality["psnr_db"] == pytest.approx(expected, rel=1e-9)


def test_raw_snr_on_a_uniform_field_drops_by_the_noise_ratio():
    """Additive noise sigma 2 -> 8 DU (8-bit, quantization step variance 1/12): SNR falls by
    20 log10(sqrt(64 + 1/12) / sqrt(4 + 1/12)) = 11.96 dB; a noiseless field has an unbounded SNR.
    The exposure puts the field near 100 DU, so that no noise is clipped at 0 or at full scale."""
    low, high, none = (evaluate_design({"scene": "uniform", "noise_sigma": s, "bits": 8, "exposure": 0.5})
                       for s in (2.0, 8.0, 0.0))
    drop = low.quality["snr_db"] - high.quality["snr_db"]
    assert drop == pytest.approx(20 * np.log10(np.sqrt(64 + 1 / 12) / np.sqrt(4 + 1 / 12)), abs=0.5)
    assert none.quality["snr_db"] == np.inf


def test_sweeps_leave_the_quality_measures_out_and_tables_show_them(dcs, monkeypatch):
    from camsim_core.review import design

    def refuse(*args):
        raise AssertionError("a sweep point computed the image-quality measures")

    with monkeypatch.context() as m:
        m.setattr(design, "quality_measures", refuse)
        points = run_sweep([("dcs", {"scene": "macbeth"})], "noise_sigma", [0.0, 1.0])
    assert [p.error for p in points] == [None, None]
    chart = evaluate_design({"scene": "macbeth"}, "chart")
    page = report_html([chart, dcs])
    assert "Macbeth chart, mean CIEDE2000" in page and f"{chart.quality['macbeth_de2000']:.2f}" in page
    assert page.count("<td>n/a</td>") >= 1  # the photo allows no chart measure


def test_a_design_carries_optics_and_a_light_level():
    from camsim_core.review.design import check_params, scene_from_params

    cam = camera_from_params({"optics": "diffraction"})
    assert cam.optics == "diffraction" and camera_from_params({}).optics == "none"
    # "preset" (the default): the camera's own lens, diffraction for an electron-level sheet
    assert camera_from_params({"camera": "imx174"}).optics == "diffraction"
    assert camera_from_params({"camera": "imx174", "optics": "none"}).optics == "none"
    base = scene_from_params({})
    lit = scene_from_params({"light": 2.0})
    np.testing.assert_allclose(lit.data, 2.0 * base.data)
    with pytest.raises(ParameterError, match="optics"):
        check_params({"optics": "pinhole"})
    with pytest.raises(ParameterError, match="light"):
        check_params({"light": 0.0})


def test_a_noise_sweep_leaves_out_an_electron_level_camera_saying_why():
    """Issue 38 defect 7: imx174 draws its own shot and read noise; a noise-sigma sweep drew it as a flat line."""
    designs = [("dcs", DCS), ("imx", {"camera": "imx174"})]
    points = list(iter_sweep(designs, "noise_sigma", [0.0, 4.0], metrics=("cielab",)))
    imx = [p for p in points if p.name == "imx"]
    assert len(imx) == 2 and all(p.measures is None for p in imx)
    assert all("imx174" in p.error and "electron-level" in p.error and "not swept" in p.error for p in imx)
    dcs = sorted((p.value, p.measure()) for p in points if p.name == "dcs")
    assert [v for v, _ in dcs] == [0.0, 4.0] and dcs[0][1] < dcs[1][1]


def _png_colours(uri):
    import base64
    import io

    from PIL import Image

    pixels = np.asarray(Image.open(io.BytesIO(base64.b64decode(uri.split(",", 1)[1]))).convert("RGB")).reshape(-1, 3)
    return {"#%02x%02x%02x" % tuple(c) for c in np.unique(pixels, axis=0)}


def test_a_design_has_one_colour_in_the_reports_histogram_and_sweep_plot(dcs, cones):
    """Issue 38 defect 7: with the live design first in the report, a pinned design's sweep curve took the
    colour the histogram gives the live design."""
    from camsim_core.review.report import DESIGN_COLOURS
    from camsim_core.review.sweep import SweepPoint

    live = dataclasses.replace(cones, name="live")
    # the sweep ran over the pinned design only: its index there is 0, its place in the report 1
    points = [SweepPoint(0, "dcs", v, dict(DCS), measures=dcs.measures) for v in (0.0, 2.0)]
    text = report_html([live, dcs], sweep={"parameter": "noise_sigma", "values": [0.0, 2.0]}, points=points)
    uris = {alt: src for src, alt in re.findall(r'<img class="plot" src="([^"]+)" alt="([^"]+)"', text)}
    hist, sweep = _png_colours(uris["CIELAB dE histograms"]), _png_colours(uris["sweep plot"])
    live_colour, dcs_colour = DESIGN_COLOURS[0], DESIGN_COLOURS[1]
    assert {live_colour, dcs_colour} <= hist
    assert dcs_colour in sweep and live_colour not in sweep
    assert f"border-left: 6px solid {dcs_colour}\">dcs" in text


def test_report_writes_a_number_one_way_whatever_its_type(dcs, cones):
    """Issue 38 defect 11: the report printed noise sigma 0 for one design and 0.0 for another."""
    a = dataclasses.replace(dcs, params={**dcs.params, "noise_sigma": 0})
    b = dataclasses.replace(cones, params={**cones.params, "noise_sigma": 0.0})
    text = report_html([a, b])
    row = re.search(r"<tr><th>noise_sigma</th>(.*?)</tr>", text).group(1)
    assert row == "<td>0</td><td>0</td>", row
