"""The explorer's session state and downloads, without a browser (app.state, app.views)."""

import io
import html
import json
import zipfile

import numpy as np
import pytest
import tifffile
from PIL import Image

import camsim_core as cc
from camsim_core.datasets import SIMTOOLBOX
from camsim_core.scene import macbeth_scene, save_npz_scene

from camsim_explorer.state import ExplorerState  # noqa: E402
from camsim_explorer.views import ResultsView  # noqa: E402


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


def test_a_plain_watcher_sees_the_state_normalised_and_a_param_depends_one_before_it(state):
    """Why the views that follow the state's parameters use ``param.watch`` (docs/design/explorer-sessions.md):
    a watcher registered after the state's own runs once the state has put in a new Gaussian camera's centres; one
    made by ``param.depends(..., watch=True)`` runs first (param's precedence -1) and sees the old camera's. Fails if
    param changes that order, and the note with it."""
    import param

    from camsim_core.review.design import GAUSSIAN_DEFAULTS

    seen = []

    class Follower(param.Parameterized):
        state = param.ClassSelector(class_=ExplorerState)

        @param.depends("state.camera", watch=True)
        def _on_camera(self):
            seen.append(("param.depends", self.state.gaussian_centers))

    state.camera = "gaussian-3"
    three = state.gaussian_centers
    follower = Follower(state=state)
    state.param.watch(lambda event: seen.append(("param.watch", state.gaussian_centers)), "camera")
    state.camera = "gaussian-4"
    four = GAUSSIAN_DEFAULTS["gaussian-4"][0]
    assert len(three.split(",")) == 3 and len(four.split(",")) == 4
    assert seen == [("param.depends", three), ("param.watch", four)]
    assert follower.state is state and state.result.camera.sensors.values.shape[0] == 4


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


def _npz_bytes(cube):
    buf = io.BytesIO()
    np.savez(buf, data=cube, wavelengths=np.arange(400, 701, 10.0))
    return buf.getvalue()


def test_an_upload_with_negative_radiance_loads_clipped_and_says_so(state):
    """A dark-subtracted cube dips below zero by its noise: loaded with those values at 0, and the page says how
    many and the lowest (it was refused, with advice to pass ``negative='clip'``, which a page cannot)."""
    cube = np.full((40, 60, 31), 0.1)
    cube[5, 7, :4] = -0.0031
    assert state.add_upload("dark.npz", _npz_bytes(cube)), state.message
    assert state.scene == "upload:dark" and state.message == ""
    assert state.scene_object().data.min() == 0.0 and state.result.scene is state.scene_object()
    assert "4 negative radiance values clipped to 0 (the lowest -0.0031)" in state.notice
    assert state.notice.startswith("Loaded dark: ")
    state.noise_sigma = 1.0  # said once, with the upload's own result
    assert "negative" not in state.notice
    nan = cube.copy()
    nan[0, 0, 0] = np.nan
    assert not state.add_upload("nan.npz", _npz_bytes(nan)) and "NaN" in state.message  # still refused
    after_chart = ExplorerState()
    after_chart.scene = "macbeth"  # a chart: fitted and auto-exposed; its exposure put back when the upload is picked
    assert after_chart.add_upload("dark.npz", _npz_bytes(cube)), after_chart.message
    assert "Exposure 0.1 s again" in after_chart.notice and "4 negative radiance values" in after_chart.notice


def test_a_file_uploaded_again_under_its_name_is_computed_anew(state):
    """A student edits a scene and uploads it again under the same name: the page computes the new content
    (the scene list's value did not change, and the result of the old content stayed)."""
    assert state.add_upload("mine.npz", _npz_bytes(np.full((40, 60, 31), 0.05))), state.message
    first = state.result
    assert state.add_upload("mine.npz", _npz_bytes(np.full((40, 60, 31), 0.15))), state.message
    assert state.result is not first and state.result.scene is state.scene_object()
    assert float(state.scene_object().data.max()) == pytest.approx(0.15)
    assert state.result.raw.data.mean() > 2 * first.raw.data.mean()


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
    s = view.status_data
    assert json.loads(html.unescape(view.status.object.removeprefix("<pre>").removesuffix("</pre>"))) == s
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


@pytest.fixture
def cold_state(monkeypatch):
    """A session that starts from nothing computed: not from the pipeline memory another session of the
    process left for the shipped scene (``_WARM``), which holds whatever maps that session made."""
    import camsim_explorer.state as state_module

    monkeypatch.setattr(state_module, "_WARM", {})
    return ExplorerState()


def test_each_metric_makes_only_the_map_it_shows(cold_state):
    """S-CIELAB shown: its map is made and the hidden CIELAB map is not (on a megapixel image that was a
    tenth of an exposure move); a move then re-makes only S-CIELAB; CIELAB again makes its own map.
    (A session warmed by another's memory found S-CIELAB made already when a test before, in the same
    process, had shown it.)"""
    state = cold_state
    assert state.result.delta_e is not None and state.result.scielab is None
    state.metric = "S-CIELAB"
    assert state.result.scielab is not None and state.result.delta_e is None
    assert state.result.ran_steps == ["scielab"]
    state.exposure = state.exposure * 1.2
    assert "scielab" in state.result.ran_steps and "delta_e" not in state.result.ran_steps
    assert state.result.delta_e is None
    state.metric = "CIELAB"
    assert state.result.ran_steps == ["delta_e"] and state.result.delta_e is not None


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


# -- background computation, refusals, warnings ---------------------------------
import contextlib  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402

from camsim_explorer.state import Runner, exposure_warnings, mean_level  # noqa: E402
from camsim_explorer.views import de_range, histogram, rgba32  # noqa: E402


def test_runner_computes_only_the_newest_request():
    release, started = threading.Event(), threading.Event()
    computed, delivered = [], []

    def compute(job):
        computed.append(job)
        if job == 1:
            started.set()
            release.wait(10)
        return job * 10

    runner = Runner(compute, lambda job, out: delivered.append((job, out)))
    runner.submit(1)
    assert started.wait(10)
    runner.submit(2)  # queued behind 1 ...
    runner.submit(3)  # ... and superseded by 3
    release.set()
    for _ in range(200):
        if not runner.busy:
            break
        time.sleep(0.01)
    assert computed == [1, 3]  # 2 never computed
    assert delivered == [(3, 30)]  # 1's outcome was obsolete when it finished


def test_sessions_compute_at_most_one_per_core_at_once_and_each_gets_its_result():
    """Ten sessions changing at once queue for the server's cores (``COMPUTE_SLOTS``) instead of running ten
    threads on two cores, and each still gets its own newest result."""
    from camsim_explorer.state import COMPUTE_SLOT_COUNT as slots
    from overlap import Overlap

    running = Overlap()
    delivered = []

    def compute(job):
        with running:
            time.sleep(0.05)
        return job

    runners = [Runner(compute, lambda job, out: delivered.append(out)) for _ in range(slots + 4)]
    for k, runner in enumerate(runners):
        runner.submit(k)
    deadline = time.monotonic() + 30
    while any(r.busy for r in runners) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert sorted(delivered) == list(range(len(runners)))
    assert running.most == slots


@contextlib.contextmanager
def _threads_started():
    """The names of the threads started in the block (a list, filled as they start)."""
    started = []
    real_start = threading.Thread.start

    def spy(self):
        started.append(self.name)
        return real_start(self)

    threading.Thread.start = spy
    try:
        yield started
    finally:
        threading.Thread.start = real_start


def test_a_submit_starts_no_thread_once_the_sessions_threads_exist():
    """``submit`` runs on the event loop: starting a thread there waits for the thread to run, which needs the
    GIL that computing threads hold (243 ms in the hostile load test). The sessions' threads are kept."""
    done = threading.Event()
    runner = Runner(lambda job: job, lambda job, out: done.set())
    runner.submit(0)  # the pool may grow here, once
    assert done.wait(10)
    while runner.busy:
        time.sleep(0.01)
    with _threads_started() as started:
        for k in range(20):
            done.clear()
            runner.submit(k)
            assert done.wait(10)
            while runner.busy:
                time.sleep(0.01)
    assert started == []


def test_a_server_starts_the_threads_its_sessions_and_uploads_use_before_it_serves():
    """``camsim serve`` calls ``start_session_threads``: afterwards as many sessions computing, and uploads
    read, at once as the pools hold start no thread (a start on the event loop waits for the GIL)."""
    from camsim_explorer import state as module

    assert module.start_session_threads() == module.SESSION_THREAD_COUNT + module.UPLOAD_THREAD_COUNT
    with _threads_started() as started:
        for pool, count in ((module.SESSION_THREADS, module.SESSION_THREAD_COUNT),
                            (module.UPLOAD_THREADS, module.UPLOAD_THREAD_COUNT)):
            gate = threading.Barrier(count, timeout=10)  # all of them busy at once
            for w in [pool.submit(gate.wait) for _ in range(count)]:
                w.result()
    assert started == []


def test_a_computation_that_raises_leaves_the_session_able_to_compute(caplog):
    outcomes = []

    def compute(job):
        if job == "bad":
            raise RuntimeError("a bug")
        return job

    runner = Runner(compute, lambda job, out: outcomes.append(out))
    runner.submit("bad")
    deadline = time.monotonic() + 10
    while runner.busy and time.monotonic() < deadline:
        time.sleep(0.01)
    runner.submit("good")
    while "good" not in outcomes and time.monotonic() < deadline:
        time.sleep(0.01)
    assert outcomes == ["good"]
    assert any("computation failed" in r.getMessage() for r in caplog.records)


def _background_state():
    state = ExplorerState(start=False)
    state.set_runner(Runner(state._compute, state._apply))  # deliver in the worker: no event loop here
    state.recompute()
    _wait_idle(state)
    return state


def _wait_idle(state, timeout=120):
    t0 = time.monotonic()
    while (state.computing or state.runner.busy) and time.monotonic() - t0 < timeout:
        time.sleep(0.02)
    assert not state.computing


def test_a_change_during_a_computation_supersedes_it():
    state = _background_state()
    state.distance = 0.5  # a long computation
    assert state.computing  # the page can show "computing" at once
    state.noise_sigma = 7.0
    state.seed = 3
    _wait_idle(state)
    assert state.result.params["distance"] == 0.5 and state.result.params["noise_sigma"] == 7.0
    assert state.result.params["seed"] == 3 and state.shown == state.design_params()
    assert state.result.camera.noise_sigma == 7.0 and state.result.camera.distance == 0.5


@pytest.mark.parametrize("name, value, words", [
    ("noise_sigma", 80, "noise sigma 80"), ("exposure", 100, "exposure (s) 100"), ("f_stop", 40, "f-stop 40"),
    ("distance", -1, "distance (m) -1"), ("seed", -5, "seed -5"), ("light", 5000, "light level (x the scene's) 5000"),
])
def test_an_out_of_range_value_is_refused_with_a_message(state, name, value, words):
    before, good = getattr(state, name), state.result
    assert state.set_value(name, value) == before
    assert state.message.startswith("Refused:") and words in state.message and "kept" in state.message
    assert getattr(state, name) == before and state.result is good


def test_a_seed_is_taken_up_to_the_largest_whole_number_a_browser_keeps_exactly(state):
    """Past 2**53 - 1 (JavaScript's Number.MAX_SAFE_INTEGER, 9007199254740991) a browser rounds a whole number:
    2**53 + 1 typed in the box reaches the server as 2**53, and a link's exact seed shows rounded in the box."""
    assert float(2**53 + 1) == 2**53  # what a double (the browser's number) does to it
    assert state.set_value("seed", 2**53) == 0
    assert "seed 9007199254740992 must lie in [0, 9007199254740991]" in state.message, state.message
    assert state.apply_valid({"seed": 10**20, "noise_sigma": 1.0}) == {"seed": 10**20}
    assert (state.seed, state.noise_sigma) == (0, 1.0)
    assert state.set_value("seed", float(2**53 - 1)) == 2**53 - 1 and state.seed == 9007199254740991


def test_a_combination_refused_by_the_engine_puts_the_parameters_back(state):
    state.demosaic_method = "malvar2004"  # fine on the DCS-200's Bayer tile
    good = state.result
    state.camera = "gaussian-4"  # its 2 x 2 four-sensor grid is not a Bayer tile
    assert "malvar2004" in state.message and "Bayer" in state.message
    assert state.camera == "kodak-dcs200-ir" and state.result is good
    assert state.design_params() == state.shown


@pytest.mark.parametrize("camera, mosaic", [("human-cones", "preset"), ("stockman-sharpe", "preset"),
                                            ("cie1931", "preset"), ("kodak-dcs200-ir", "none"),
                                            ("gaussian-4", "none")])
def test_full_colour_cameras_run(state, camera, mosaic):
    view = ResultsView(state)
    assert "Raw mosaic" in view.labels["raw"].object
    state.param.update(camera=camera, mosaic=mosaic)
    assert state.message == "" and state.camera == camera and state.mosaic == mosaic
    assert state.result.raw.mosaiced is False and "demosaic" in state.result.skipped
    view.update()  # the raw view's title says what it shows: every sensor at every pixel, no mosaic
    assert "no mosaic" in view.labels["raw"].object and "Raw mosaic" not in view.labels["raw"].object
    assert "no demosaicing" in view.labels["demosaiced"].object
    state.param.update(camera="kodak-dcs200-ir", mosaic="GRBG")
    view.update()
    assert "Raw mosaic" in view.labels["raw"].object


def test_gaussian_sensors_are_named_by_their_peak(state):
    state.camera = "gaussian-4"
    assert state.result.camera.sensors.names == ("460 nm", "520 nm", "580 nm", "640 nm")
    state.camera = "gaussian-3"
    assert state.result.camera.sensors.names == ("R", "G", "B")  # 640, 520, 460 nm: red, green, blue
    state.gaussian_centers = "600, 450, 700"
    assert state.result.camera.sensors.names == ("600 nm", "450 nm", "700 nm")


def test_exposure_warnings_count_clipped_and_dark_pixels(state):
    raw = state.result.raw
    data = np.zeros(raw.data.shape)
    data.flat[: data.size // 4] = 255  # a quarter at full scale
    data.flat[data.size // 4: data.size // 2] = 128  # a quarter mid-range, the rest at 0
    clipped, dark = exposure_warnings(raw.replace(data=data))
    assert clipped == pytest.approx(0.25, abs=1e-6) and dark == pytest.approx(0.5, abs=1e-6)
    assert mean_level(raw.replace(data=data)) == pytest.approx((0.25 * 255 + 0.25 * 128) / raw.full_scale)


def test_raw_and_demosaiced_views_are_display_encoded_so_a_fifth_of_full_scale_is_not_black(state):
    from camsim_explorer.views import planes_rgb, raw_rgb

    raw = state.result.raw
    fifth = raw.replace(data=np.full(raw.data.shape, 0.2 * raw.full_scale))
    shown = raw_rgb(fifth)
    brightest = shown.max(axis=-1)  # each pixel shows its sensor's colour at the encoded value
    np.testing.assert_allclose(brightest, 0.2 ** (1 / 2.2), rtol=1e-6)
    assert brightest.min() > 0.45  # linear display would show 0.2: near black
    assert planes_rgb(state.result.demosaiced).max() <= 1.0


def test_raw_view_by_table_is_the_per_pixel_colouring(state):
    """The raw view's table (every sensor's every digital value) gives the per-pixel arithmetic's bytes."""
    from camsim_explorer.views import raw_rgb, raw_rgba

    raw = state.result.raw
    assert raw.bits == 8 and np.array_equal(raw.data, np.rint(raw.data))  # the table's case
    np.testing.assert_array_equal(raw_rgba(raw), rgba32(raw_rgb(raw)))
    ten = raw.replace(data=np.random.default_rng(4).integers(0, 1024, raw.data.shape).astype(np.float32),
                      bits=10)
    np.testing.assert_array_equal(raw_rgba(ten), rgba32(raw_rgb(ten)))
    between = raw.replace(data=raw.data + np.float32(0.25))  # not whole values: the arithmetic itself
    np.testing.assert_array_equal(raw_rgba(between), rgba32(raw_rgb(between)))


def test_auto_exposure_says_what_it_aims_at(state):
    state.auto_expose()
    assert "90 % of full scale" in state.notice and "brightest 0.5 %" in state.notice


def test_views_refit_to_a_new_image_size_and_reshape_only_for_a_new_aspect_ratio(state):
    from app_helpers import shows_whole_image  # tests/ is on sys.path (tests/conftest.py)

    view = ResultsView(state)
    start = [fig.aspect_ratio for fig in view.figures.values()]

    def ranges():
        return {"x": [view.x_range.start, view.x_range.end], "y": [view.y_range.start, view.y_range.end]}

    state.distance = 0.5  # the sensor crops the scene: 1012 x 1524, aspect 1.506 against the frames' 1.597
    h, w = state.result.raw.data.shape[:2]
    assert (h, w) == (1012, 1524)
    assert [fig.aspect_ratio for fig in view.figures.values()] == start  # no relayout of the page
    assert shows_whole_image(ranges(), w, h) and ranges()["y"] == [0, h] and ranges()["x"][0] < 0
    state.scene = "bfgb128"  # a square scene: the frames take its shape
    h, w = state.result.raw.data.shape[:2]
    assert all(fig.aspect_ratio == pytest.approx(w / h) for fig in view.figures.values())
    assert ranges() == {"x": [0, w], "y": [0, h]}


def test_rgba32_packs_bytes_for_bokeh_bottom_row_first():
    rgb = np.zeros((2, 3, 3), np.uint8)
    rgb[0, 0] = (10, 20, 30)  # top-left pixel
    packed = rgba32(rgb)
    assert packed.dtype == np.uint32 and packed.shape == (2, 3)
    assert packed[1, 0] == 10 + (20 << 8) + (30 << 16) + (255 << 24)  # Bokeh draws row 0 at the bottom
    assert packed[0, 0] == 255 << 24


def test_histogram_refits_to_the_data():
    small = histogram(np.full(100, 0.3))
    big = histogram(np.r_[np.linspace(0, 60, 1000), [np.nan, 500.0]])
    assert small[2] == 1.0 and big[2] == 60.0  # the range follows the data (99.5th percentile)
    assert small[1].sum() == 100 and big[1].sum() == 1001  # every finite value counted, the outlier in the last bin
    assert de_range(np.linspace(0, 40, 1001), "data") == pytest.approx((0.0, 39.8))
    assert de_range(np.linspace(0, 40, 1001), "fixed 0-20") == (0.0, 20.0)


def test_a_new_session_starts_from_an_earlier_sessions_result_but_never_from_an_upload(tmp_path, monkeypatch):
    from camsim_explorer import state as state_module
    from camsim_core.scene import macbeth_scene, save_npz_scene

    monkeypatch.setattr(state_module, "_WARM", {})
    first = ExplorerState()
    assert "stage:sensor_responses" in first.result.ran_steps
    second = ExplorerState()
    assert second.result.ran_steps == []  # the first session's steps were at hand
    np.testing.assert_array_equal(second.result.rendered.data, first.result.rendered.data)
    second.noise_sigma = 2.0  # and its own changes re-run as usual, leaving the first session's result alone
    assert second.result.ran_steps[0] == "stage:noise"
    assert first.result.params["noise_sigma"] == 0.0
    save_npz_scene(macbeth_scene(patch_size=4, border=1), tmp_path / "mine.npz")
    assert second.add_upload("mine.npz", (tmp_path / "mine.npz").read_bytes()), second.message
    assert not any(":" in name for name in state_module._WARM)


def test_the_servers_warm_up_leaves_the_first_page_nothing_to_compute(monkeypatch):
    from camsim_explorer import main
    from camsim_explorer import state as state_module

    monkeypatch.setattr(state_module, "_WARM", {})
    monkeypatch.setitem(main._options, "scene", None)
    assert main.warm_up() > 0
    assert list(state_module._WARM) == [main.DEFAULT_SCENE]
    page = ExplorerState(scene=main.DEFAULT_SCENE)
    assert page.result.ran_steps == []
    assert page.result.rendered is not None and np.nanmean(page.result.delta_e) > 0


def test_chart_options_make_a_chart_that_links_and_files_reproduce():
    import json

    state = ExplorerState(scene="slanted-edge")
    assert state.set_chart("angle=10; contrast=2, size=64x96"), state.message
    assert state.scene == "slanted-edge:angle=10,contrast=2,size=64x96"
    assert state.result.scene.data.shape == (64, 96, 31)
    expected = cc.load_scene(state.scene)  # the name alone makes the same chart (links, files, the report)
    np.testing.assert_array_equal(state.result.scene.data, expected.data)
    other = ExplorerState()
    assert other.from_json(json.dumps({"scene": state.scene})), other.message
    assert other.scene == state.scene and other.result.scene.data.shape == (64, 96, 31)
    assert state.set_chart("") and state.scene == "slanted-edge"


@pytest.mark.parametrize("options, message", [
    ("size=100000", "more than the"), ("bogus=1", "no option bogus"), ("wavelengths=5", "keep their wavelengths"),
    ("angle", "must be key=value"), ("x" * 300, "longer than")])
def test_bad_chart_options_are_refused_with_a_message_and_the_chart_stays(options, message):
    state = ExplorerState(scene="slanted-edge")
    shown = state.result
    assert not state.set_chart(options)
    assert message in state.message and state.scene == "slanted-edge" and state.result is shown


def test_chart_options_need_a_chart_and_files_name_only_real_scenes():
    import json

    state = ExplorerState()
    assert not state.set_chart("angle=10") and "apply to a test chart" in state.message
    assert not state.from_json(json.dumps({"scene": "upload:elsewhere"}))
    assert "neither one of this session's scenes nor a chart" in state.message and state.scene == "cacaphony290"


def test_light_level_scales_the_raw_and_a_later_move_reruns_only_its_own_steps(state):
    base = np.asarray(state.result.raw.data, float)  # 8 bits, no noise: the raw's mean is linear in the light
    state.light = 0.5
    ran = [name for name, _ in state.result.ran]
    assert ran[0] == "stage:sensor_responses" and state.result.params["light"] == 0.5
    dim = np.asarray(state.result.raw.data, float)
    assert dim.mean() == pytest.approx(base.mean() / 2, rel=0.01)  # rounding to whole digital values only
    state.noise_sigma = 1.0  # the scene under the new light is the same object: the sensor responses are kept
    assert [name for name, _ in state.result.ran][0] == "stage:noise"


def test_diffraction_optics_from_the_explorer_blurs_the_raw(state):
    state.f_stop = 32.0  # the smallest aperture offered: the widest diffraction blur
    sharp = np.asarray(state.result.raw.data, float)
    state.optics = "diffraction"
    assert state.result.camera.optics == "diffraction" and "stage:lens_sensor_responses" in [n for n, _ in state.result.ran]
    blurred = np.asarray(state.result.raw.data, float)

    def detail(a):  # energy of the differences between neighbours of the same sensor (a 2 x 2 tile apart)
        return float(np.mean(np.abs(np.diff(a[:, ::2], axis=1))))

    assert detail(blurred) < detail(sharp)


def test_a_callback_for_the_event_loop_runs_once_and_lets_go_of_its_arguments():
    import gc
    import weakref

    from camsim_explorer.views import once

    class Big:  # stands for a result's arrays
        pass

    calls = []
    big = Big()
    ref = weakref.ref(big)
    call = once(lambda x: calls.append(x) or "shown", big)
    cycle = [call]
    cycle.append(cycle)  # like Bokeh's one-shot callbacks: held in a reference cycle after running
    del big
    assert call() == "shown" and call() is None and len(calls) == 1
    calls.clear()
    assert ref() is None  # freed at once, not at the next full garbage collection
    never = once(lambda x: None, Big())
    never.drop()  # a session closed before its callback ran
    assert never() is None
    gc.collect()


def test_sensor_fields_reach_the_camera_and_a_new_camera_starts_from_its_sheet():
    state = ExplorerState(camera="imx174")
    assert state.sensor_fields()["full_well_e"] == 32000.0 and state.sensor == ""
    assert state.set_sensor_field("read_noise_e", 2.5) == 2.5
    assert state.sensor == "read_noise_e=2.5" and state.result.camera.read_noise == 2.5
    assert state.set_sensor_field("pixel_pitch_um", 11.72) == 11.72
    assert state.result.camera.full_well == pytest.approx(128000.0)  # four times the area, four times the well
    # refused: the message names the field, nothing changes
    assert state.set_sensor_field("full_well_e", 1.0) == pytest.approx(128000.0)
    assert state.message.startswith("Refused: full_well_e") and state.sensor == "pixel_pitch_um=11.72, read_noise_e=2.5"
    # the sheet's own value (or a cleared field) drops the change
    assert state.set_sensor_field("read_noise_e", 7.0) == 7.0 and state.sensor == "pixel_pitch_um=11.72"
    assert state.set_sensor_field("pixel_pitch_um", None) == 5.86 and state.sensor == ""
    state.set_sensor_field("dsnu_e", 4.0)
    saved = json.loads(state.to_json())
    assert saved["sensor"] == "dsnu_e=4"
    again = ExplorerState()
    assert again.from_json(json.dumps(saved)) and again.result.camera.dsnu == 4.0  # camera and sensor in one file
    state.camera = "phone-1.4um"
    assert state.sensor == "" and state.result.camera.dsnu == 1.0  # the phone's own sheet
    state.camera = "kodak-dcs200-ir"
    assert state.sensor_fields() is None and state.set_sensor_field("dsnu_e", 2.0) is None
    assert "electron-level cameras" in state.message


def test_changes_panel_queued_and_no_task_will_send_are_sent(monkeypatch):
    """Panel's race: a write task that finishes clears the write block after a newer change queued its
    message, and the newer task then returns without sending. The session's check re-arms both."""
    from bokeh.document import Document
    from panel.io import document as pdoc

    from camsim_explorer.main import flush_stranded_writes

    doc = Document()
    calls = []
    monkeypatch.setattr(pdoc, "_dispatch_write_task", lambda d, fn, *args: calls.append((d, fn, args)))
    try:
        assert not flush_stranded_writes(doc) and calls == []  # nothing queued
        pdoc._WRITE_MSGS[doc] = {"connection": ["PATCH-DOC"]}
        pdoc._WRITE_BLOCK[doc] = True
        assert not flush_stranded_writes(doc) and calls == []  # queued, and a task holds the block: it sends
        del pdoc._WRITE_BLOCK[doc]
        assert flush_stranded_writes(doc)  # queued, block cleared: stranded
        assert pdoc._WRITE_BLOCK.get(doc) is True and calls == [(doc, pdoc._dispatch_msgs, (doc,))]
    finally:
        pdoc._WRITE_MSGS.pop(doc, None)
        pdoc._WRITE_BLOCK.pop(doc, None)


def test_a_camera_comes_with_its_own_lens_unless_another_is_chosen():
    state = ExplorerState()
    assert state.optics == "preset" and state.result.camera.optics == "none"  # the chapter's five stages
    state.camera = "imx174"  # the sheet's lens: diffraction at the f-number
    assert state.result.camera.optics == "diffraction" and state.result.ran_steps[0] == "stage:lens_sensor_responses"
    state.optics = "none"  # chosen: kept across cameras, in the link and the parameters file
    assert state.result.camera.optics == "none"
    state.camera = "phone-1.4um"
    assert state.result.camera.optics == "none" and json.loads(state.to_json())["optics"] == "none"
    state.param.update(camera="kodak-dcs200-ir", optics="diffraction")
    assert state.result.camera.optics == "diffraction"


def test_diagnostics_show_only_while_their_box_is_ticked():
    import panel as pn

    from camsim_explorer.main import _release, create_app

    template = create_app()
    try:
        found = [o for root in [*template.main, *template.sidebar] for o in root.select()]
        box = next(o for o in found if isinstance(o, pn.widgets.Checkbox) and "w-diagnostics" in o.css_classes)
        shown = next(o.object for o in found if "camsim-status" in (getattr(getattr(o, "object", None), "css_classes", None) or []))
        assert box.value is False and shown.visible is False  # the status's own model
        box.value = True
        assert shown.visible is True
        box.value = False
        assert shown.visible is False
    finally:
        _release(template.state, template.body, template)


def test_sessions_share_a_chart_by_name_and_each_checks_it_against_the_limit():
    """A chart's name says everything it is made from: two sessions offering it hold one scene (a class opening
    a link to a fitted chart made it once per page), released once none holds it; a chart held under a looser
    limit is still refused under a stricter one."""
    import gc

    import pytest

    from camsim_core.errors import CamsimError
    from camsim_explorer import state as state_module

    name = "macbeth:patch_size=9"
    a, b = ExplorerState(start=False), ExplorerState(start=False)
    assert a.offer_chart(name) and b.offer_chart(name)
    assert a._uploads[name] is b._uploads[name]
    shared = state_module._SHARED_CHARTS.get(name)
    assert shared is not None and shared is state_module.shared_chart(name, shared.data.size)
    with pytest.raises(CamsimError):
        state_module.shared_chart(name, shared.data.size - 1)
    del a, b, shared
    gc.collect()
    assert state_module._SHARED_CHARTS.get(name) is None


def test_a_page_makes_no_panel_callback():
    """A Panel ``Callback`` (``jscallback``, ``jslink``) makes Panel install a hook that, every time part of a page
    is rendered anew (each tab switch), selects every Panel object of the page and every Bokeh model of the part
    to look for links: 16 % of the server's work at a tab switch. The page has none: presentation mode's class on
    the body is set by a component (camsim_explorer.body_class)."""
    import panel as pn
    from panel.links import Callback

    from camsim_explorer.main import _release, create_app

    template = create_app()
    try:
        tabs = next(t for t in template.body.select(pn.Tabs))
        for index in range(len(tabs)):  # every tab built (Panel's DiscreteSlider, the Scene tab's once, made one)
            tabs.active = index
        found = [o for root in [*template.main, *template.sidebar, *template.header] for o in root.select()]
        assert len(found) > 150 and any("w-wavelength" in o.css_classes for o in found if hasattr(o, "css_classes"))
        assert [type(o).__name__ for o in found if o in Callback.registry] == []
    finally:
        _release(template.state, template.body, template)


def test_one_refused_value_of_a_link_leaves_the_others_applied_and_computed(state):
    """Param refuses a batch of values as a whole, setting those before the first bad one without telling the
    watchers: a link "seed=-3&noise_sigma=1&distance=5" had noise and distance refused with the seed."""
    assert state.apply_valid({"seed": -3, "noise_sigma": 1.0, "distance": 5.0, "tab": "camera"}) == {"seed": -3}
    assert (state.seed, state.noise_sigma, state.distance, state.tab) == (0, 1.0, 5.0, "camera")
    assert state.shown["noise_sigma"] == 1.0 and state.shown["distance"] == 5.0  # computed, not only set
    assert state.result.camera.distance == 5.0
    # the camera and its sensor in one link: one change, so the camera does not clear the sensor sheet after it
    assert state.apply_valid({"sensor": "", "camera": "gaussian-3", "bits": "eight"}) == {"bits": "eight"}
    assert state.shown["camera"] == "gaussian-3"
    # a text the engine cannot read is refused with the others, not accepted and then refused with the whole link
    texts = {"gaussian_centers": "abc", "custom_tile": "x", "viewing": "far", "sensor": "well=1", "noise_sigma": 3.0}
    assert set(state.apply_valid(texts)) == {"gaussian_centers", "custom_tile", "viewing", "sensor"}
    assert state.shown["noise_sigma"] == 3.0 and state.message == ""


def test_a_custom_tile_given_with_the_custom_mosaic_is_the_users(state):
    """A link or a file setting the mosaic to custom and its tile: the tile is used, or refused by name. It was
    replaced without a word by the tile shown (what picking "custom" in the list does)."""
    state.param.update(mosaic="custom", custom_tile="0 5")
    assert "tile names sensor index 5" in state.message and state.shown["mosaic"] == "preset"
    state.param.update(mosaic="custom", custom_tile="2 1; 1 0")
    assert state.message == "" and state.shown["custom_tile"] == "2 1; 1 0"
    np.testing.assert_array_equal(state.result.raw.tile, [[2, 1], [1, 0]])


def test_a_custom_tile_that_misses_a_sensor_of_a_new_camera_gives_way_to_its_mosaic(state):
    """A custom tile "0 1 2" on a camera of three sensors made every camera of four refused ("tile never samples
    sensor class(es) [3]") until the mosaic was put back by hand."""
    state.camera = "gaussian-3"
    state.param.update(mosaic="custom", custom_tile="0 1 2")
    assert state.shown["custom_tile"] == "0 1 2" and state.message == ""
    state.camera = "gaussian-4"
    assert state.message == "" and state.shown["camera"] == "gaussian-4" and state.mosaic == "preset"
    assert "Mosaic back to the camera's own: the custom tile 0 1 2" in state.notice
    state.camera = "gaussian-3"
    state.param.update(mosaic="custom", custom_tile="0 1 2")
    state.camera = "kodak-dcs200"  # a tile that still fits (three sensors) is kept
    assert state.mosaic == "custom" and state.shown["custom_tile"] == "0 1 2"


def test_an_unquantized_electron_level_raw_is_measured_against_its_full_well():
    """imx174 at 0 bits, 0.05 s on the uniform field (brightest pixel 341 of a full well at about 4092): the
    Results line read "35.5 % of pixels are clipped" and, at 0.52 s, a mean level of 934 % of full scale (255
    taken as full scale); the engine's signal read 89.5 % of the range."""
    import camsim_core as cc
    from camsim_core.metrics.exposure import saturation_level
    from camsim_explorer.state import exposure_warnings, full_scale, mean_level

    state = ExplorerState(start=False)
    state.param.update(camera="imx174", bits=0)
    state.scene = "uniform"
    state.exposure = 0.05
    raw, cam = state.result.raw, state.result.camera
    assert raw.full_scale is None and float(raw.data.max()) < 400
    well = float(np.max(raw.black_level)) + saturation_level(cam)
    assert full_scale(raw, cam) == pytest.approx(well) and well > 4000
    assert exposure_warnings(raw, cam)[0] == 0.0
    assert mean_level(raw, cam) == pytest.approx(float(np.mean(raw.data)) / well)
    assert state.result.exposure.signal == pytest.approx((float(np.mean(raw.data)) - float(np.mean(raw.black_level)))
                                                         / saturation_level(cam), rel=1e-3)
    dcs = cc.simulate(cc.load_scene("cacaphony290"), cc.load_camera("kodak-dcs200-ir").replace(bits=None))
    assert full_scale(dcs) == 255.0  # the chapter's cameras keep the display convention


def test_an_upload_of_fewer_than_three_bands_is_refused_in_words(state):
    """A one-band scene was accepted, then refused by the rendering: "camera-monitor matrix T_C B_M ... singular
    (rank 1, needs 3)"; the page now says how many bands the file has and how many colour takes."""
    buf = io.BytesIO()
    np.savez(buf, data=np.full((8, 8, 1), 0.5), wavelengths=np.array([550.0]))
    assert state.add_upload("oneband.npz", buf.getvalue()) is False
    assert state.message.startswith("Upload refused: oneband.npz: 1 wavelength band; rendering its colours takes "
                                    "at least 3"), state.message
    assert state.scene == "cacaphony290"
    buf = io.BytesIO()
    np.savez(buf, data=np.full((8, 8, 3), 0.5), wavelengths=np.array([450.0, 550.0, 650.0]))
    assert state.add_upload("three.npz", buf.getvalue()) is True  # three bands render


def test_the_exposure_line_claims_no_clipping_where_nothing_clips_and_no_under_exposure_after_auto_exposure():
    """The DCS-200 unquantized at 4x its auto exposure: "100 % of pixels are clipped: lower the exposure", where
    nothing clips (255 is the display's convention; the dE equals the auto exposure's). The Macbeth chart right
    after Auto exposure: "38 % of pixels ... under-exposed (try Auto exposure)" for its black surround."""
    import camsim_core as cs

    scene, cam = cs.load_scene("uniform"), cs.load_camera("kodak-dcs200-ir").replace(bits=None)
    auto = cs.auto_exposure(scene, cam)
    raw = cs.simulate(scene, cam, exposure=4 * auto, seed=0)
    assert float(np.mean(np.asarray(raw.data) > 255)) > 0.99  # above the display's 255 almost everywhere
    assert exposure_warnings(raw, cam)[0] == 0.0
    state = ExplorerState(scene="uniform", bits=0)
    view = ResultsView(state)
    state.exposure = 4 * state.exposure  # anything: unquantized, nothing clips
    assert "clipped (" not in view.warnings.object
    state.light = 1000.0  # "mean level 25018 % of full scale": there is none; said in digital units
    assert "% of full scale" not in view.warnings.object and "no full scale" in view.warnings.object
    raw_mean = float(np.mean(np.asarray(state.result.raw.data, float)))
    assert f"mean level {raw_mean:.4g} DU" in view.warnings.object
    state.light = 0.001  # a thousandth of the light, noiseless and unquantized: the same dE, nothing under-exposed
    assert "under-exposed" not in view.stats.object and "under-exposed" not in view.warnings.object
    state = ExplorerState(scene="macbeth")
    view = ResultsView(state)
    state.auto_expose()
    assert "under-exposed" not in view.warnings.object, view.warnings.object
    dark = float(view.warnings.object.split("in the lowest 2 % of levels ")[1].split(" %")[0])
    assert dark > 25  # the surround: dark content, not a dark frame
    state.exposure = state.exposure / 20  # now the frame is dim
    assert "under-exposed (try Auto exposure)" in view.warnings.object


def test_auto_exposure_past_its_limit_says_where_the_limit_puts_the_bright_end():
    """16 bits on the DCS-200 ask 35 s for 90 % of full scale; the exposure stops at 10 s, and the notice said
    "10 s puts the scene's brightest 0.5 % at 90 % of full scale" (it puts them at about a quarter)."""
    state = ExplorerState(bits=16)
    state.auto_expose()
    assert state.exposure == state.param.exposure.bounds[1]
    said = float(state.notice.split(" puts it at ")[1].split(" %")[0])
    raw = state.result.raw
    data = np.asarray(raw.data, float)
    brightest = max(np.percentile(data[i::2, j::2], 99.5) for i in (0, 1) for j in (0, 1))  # per sensor class
    assert said == pytest.approx(100 * brightest / raw.full_scale, abs=2.0)
    assert "at 90 % of full scale;" in state.notice and "would put" in state.notice


def test_an_alpha_past_three_decimals_is_taken_as_the_mixture_that_runs():
    """Mixtures are made in steps of 0.001: alpha 0.1234 ran as mixture-0.123 while the page, the parameters file and
    the report listed 0.1234. The value shown and listed is the one that ran, and the page says so."""
    from camsim_core.review.design import check_params

    state = ExplorerState(camera="mixture")
    state.alpha = 0.1234
    assert state.alpha == 0.123 and state.result.params["alpha"] == 0.123
    assert "Alpha 0.1234 taken as 0.123" in state.notice
    assert check_params({"alpha": 0.1234})["alpha"] == 0.123
    assert cc.review.evaluate_design({"camera": "mixture", "alpha": 0.1234}, "x", quality=False).params["alpha"] == 0.123


def test_a_camera_whose_adc_has_other_bits_says_so_and_keeps_the_raws():
    """imx174's sheet gives its ADC 12 bits; the page keeps the raw at the bits chosen (8 by default) and says
    so when the camera is picked, instead of leaving an engineer to believe the camera's own depth ran."""
    state = ExplorerState()
    state.camera = "imx174"
    assert state.result.params["bits"] == 8 and state.result.raw.bits == 8
    assert "imx174's sheet gives its ADC 12 bits; the raw is kept at 8 bits" in state.notice
    state.bits = 12
    state.camera = "kodak-dcs200-ir"  # its sheet's 8 bits against the 12 chosen
    assert "kodak-dcs200-ir's sheet gives its ADC 8 bits; the raw is kept at 12 bits" in state.notice
    state.param.update(camera="imx174", bits=12)  # a camera with its own depth (a link, a file): nothing to say
    assert "sheet gives" not in state.notice
    state.param.update(camera="kodak-dcs200-ir", bits=8)
    state.bits = 0
    state.camera = "imx174"  # unquantized: no depth to compare
    assert "sheet gives" not in state.notice
