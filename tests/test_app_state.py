"""The explorer's session state and downloads, without a browser (app.state, app.views)."""

import io
import json
import zipfile

import numpy as np
import pytest
import tifffile
from PIL import Image

import camsim_core as cc
from camsim_core.datasets import SIMTOOLBOX
from camsim_core.scene import macbeth_scene, save_npz_scene

from app.state import ExplorerState  # noqa: E402
from app.views import ResultsView  # noqa: E402


@pytest.fixture
def state():
    return ExplorerState()


def test_default_state_is_the_chapter_setting(state):
    r = state.result
    assert r is not None and r.errors == {}
    assert r.raw.data.shape == (233, 372)  # cacaphony290 through the DCS-200 at 3.32 m
    assert r.camera.name == "kodak-dcs200-ir" and (r.camera.exposure, r.camera.f_stop) == (0.1, 11.0)
    assert np.array_equal(r.raw.tile, [[1, 0], [2, 1]])
    assert state.message == ""


def test_noise_change_reruns_only_downstream_steps(state):
    state.noise_sigma = 4.0
    assert [n for n, _ in state.result.ran][:2] == ["stage:noise", "stage:digitize"]
    assert not any(n in ("stage:sensor_responses", "stage:resample") for n, _ in state.result.ran)


def test_tile_naming_a_missing_sensor_keeps_the_last_good_result(state):
    state.mosaic = "custom"  # the default custom tile is the GRBG Bayer tile
    good = state.result
    state.custom_tile = "0 1; 2 7"
    assert "sensor index 7" in state.message and "3 sensors" in state.message
    assert state.result is good
    state.custom_tile = "0 1; 1 2"
    assert state.message == ""
    assert np.array_equal(state.result.raw.tile, [[0, 1], [1, 2]])


def test_gaussian_sensor_edits_reach_the_camera(state):
    state.camera = "gaussian-3"
    state.gaussian_centers = "600, 500, 430"
    state.gaussian_widths = "20, 25, 30"
    sens = state.result.camera.sensors
    peaks = sens.wavelengths[np.argmax(sens.values, axis=1)]
    assert np.allclose(peaks, [600, 500, 430])
    state.gaussian_widths = "20, 25"  # neither one width nor one per sensor
    assert "gaussian_widths" in state.message
    assert state.result.camera.sensors is sens


def test_mixture_alpha_builds_the_engine_mixture(state):
    from camsim_core.datasets.sensors import mixture

    state.camera = "mixture"
    state.alpha = 0.3
    assert np.allclose(state.result.camera.sensors.values, mixture(0.3).values)


def test_four_sensor_grid_on_four_gaussians(state):
    state.camera = "gaussian-4"
    state.mosaic = "4-sensor grid"
    assert state.message == ""
    assert np.array_equal(state.result.raw.tile, [[0, 1], [2, 3]])


def test_good_npz_upload_is_selected(state, tmp_path):
    scene = macbeth_scene(patch_size=8, border=2)
    path = tmp_path / "small.npz"
    save_npz_scene(scene, path)
    assert state.add_upload("small.npz", path.read_bytes())
    assert state.scene == "upload:small" and state.message == ""
    assert np.array_equal(state.scene_object().data, scene.data)
    assert state.result.scene is state.scene_object()


def test_simg_zip_upload(state, tmp_path):
    buf = io.BytesIO()
    folder = SIMTOOLBOX / "BFGB_128"
    with zipfile.ZipFile(buf, "w") as z:
        for f in folder.iterdir():
            if f.name == "BFGB_128.Simg" or f.name.isdigit():
                z.write(f, f"BFGB_128/{f.name}")
    assert state.add_upload("bfgb.zip", buf.getvalue()), state.message
    assert np.array_equal(state.scene_object().data, cc.load_scene("bfgb128").data)


@pytest.mark.parametrize("name, content, expected", [
    ("bad.npz", b"this is not a zip archive", ".npz"),
    ("empty.zip", None, "no .Simg header"),
    ("scene.txt", b"x", "upload a scene as .npz"),
    ("broken.zip", b"PK\x03\x04 truncated", "not a readable zip"),
])
def test_failed_uploads_show_a_message_and_keep_the_scene(state, name, content, expected):
    if content is None:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as z:
            z.writestr("readme.txt", "no scene here")
        content = buf.getvalue()
    good = state.result
    assert not state.add_upload(name, content)
    assert state.message.startswith(f"Upload refused: {name}: ") and expected in state.message
    assert "/tmp" not in state.message
    assert state.scene == "cacaphony290" and state.result is good


def test_parameters_round_trip_through_json(state):
    state.param.update(noise_sigma=3.0, render_method="illuminant", mosaic="RGGB", seed=4)
    text = state.to_json()
    other = ExplorerState()
    assert other.from_json(text)
    assert other.to_dict() == state.to_dict()
    assert np.array_equal(other.result.rendered.data, state.result.rendered.data)


def test_bad_parameters_file_is_refused(state):
    before = state.to_dict()
    assert not state.from_json("{not json")
    assert "not JSON" in state.message
    assert not state.from_json(json.dumps({"noise_sigma": 2, "warp_factor": 9}))
    assert "warp_factor" in state.message
    assert not state.from_json(json.dumps({"noise_sigma": -5}))
    assert "noise_sigma" in state.message
    assert state.to_dict() == before


def test_downloads_hold_the_displayed_data(state):
    state.noise_sigma = 2.0
    view = ResultsView(state)
    res = state.result
    png = np.asarray(Image.open(view.rendered_png()))
    assert np.array_equal(png, res.rendered.data.astype(np.uint8))
    raw = tifffile.imread(view.raw_tiff())
    assert raw.dtype == np.uint16 and np.array_equal(raw, res.raw.data)
    de = np.loadtxt(view.de_csv(), delimiter=",")
    assert de.shape == res.delta_e.shape and np.allclose(de, res.delta_e, atol=5e-5)


def test_status_reports_the_mean_and_median(state):
    view = ResultsView(state)
    s = json.loads(view.status.object)
    assert s["mean_de"] == pytest.approx(float(np.mean(state.result.delta_e)), abs=1e-4)
    assert s["median_de"] == pytest.approx(float(np.median(state.result.delta_e)), abs=1e-4)
    assert f"{s['mean_de']:.2f}" in view.stats.object


def test_auto_exposure_uses_the_engine_rule(state):
    expected = cc.auto_exposure(state.scene_object(), state.camera_object())
    state.auto_expose()
    assert state.exposure == pytest.approx(expected)
    raw = np.asarray(state.result.raw.data)
    assert np.mean(raw >= 255) < 0.01  # the bright end sits below full scale
    assert np.percentile(raw, 99.9) > 0.5 * 255  # and the range is used


def test_a_refused_processing_step_keeps_the_last_good_result(state):
    state.camera = "gaussian-4"
    state.mosaic = "4-sensor grid"
    good = state.result
    state.demosaic_method = "malvar2004"  # Bayer tiles only
    assert "malvar2004" in state.message and "Bayer" in state.message
    assert state.result is good
    state.demosaic_method = "bayesian"
    assert state.message == "" and state.result is not good
    assert state.result.demosaiced.extra.get("demosaic") == "bayesian"


def test_sessions_share_nothing_but_read_only_data(tmp_path):
    a, b = ExplorerState(), ExplorerState()
    assert a.scene_object() is b.scene_object()  # the shipped scene is loaded once and shared
    path = tmp_path / "mine.npz"
    save_npz_scene(macbeth_scene(patch_size=8, border=2), path)
    assert a.add_upload("mine.npz", path.read_bytes())
    assert "upload:mine" in a.param.scene.objects and "upload:mine" not in b.param.scene.objects
    b_before = b.result
    a.noise_sigma = 5.0
    assert b.result is b_before and b.noise_sigma == 0.0
    assert a.pipeline is not b.pipeline


def test_viewing_is_a_state_parameter_that_sets_scielab_samples_per_degree(state):
    state.metric = "S-CIELAB"
    assert state.result.samples_per_degree == pytest.approx(102.6)  # the chapter's default
    chapter_mean = float(state.result.scielab.mean())
    state.viewing = "camera/10"
    assert state.result.samples_per_degree == pytest.approx(10.26)
    assert "render" not in state.result.ran_steps  # only the metric re-ran
    assert float(state.result.scielab.mean()) != chapter_mean
    assert state.to_dict()["viewing"] == "camera/10"  # carried by the URL and the parameter file
    state.viewing = "sideways"
    assert "viewing" in state.message
