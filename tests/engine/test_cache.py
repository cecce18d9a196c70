"""The explorer's incremental pipeline (camsim_core.cache): what re-runs, and exact equality with a fresh run."""


import numpy as np
import pytest

import camsim_core as cc
from camsim_core.cache import Pipeline, Processing, fingerprint
from camsim_core.simulation import BAYER, FOUR_SENSOR_GRID

CIELAB = Processing(metrics=("cielab",))
OUTPUTS = ("raw", "demosaiced", "rendered", "ideal", "xyz", "ideal_xyz", "delta_e", "scielab")


@pytest.fixture(scope="module")
def scene():
    return cc.load_scene("cacaphony290")


@pytest.fixture(scope="module")
def camera():
    return cc.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0, seed=0)


def _array(x):
    return None if x is None else np.asarray(getattr(x, "data", x))


def test_noise_change_reruns_only_noise_and_later_steps(scene, camera):
    p = Pipeline()
    first = p.run(scene, camera, CIELAB)
    assert first.errors == {}
    assert first.ran_steps[:5] == ["stage:sensor_responses", "stage:resample", "stage:mosaic", "stage:noise", "stage:digitize"]
    r = p.run(scene, camera.replace(noise_sigma=2.0), CIELAB)
    # the ideal image is noiseless: it is not recomputed either
    assert r.ran_steps == ["stage:noise", "stage:digitize", "demosaic", "render", "xyz", "delta_e"]
    r = p.run(scene, camera.replace(noise_sigma=2.0, seed=5), CIELAB)
    assert r.ran_steps == ["stage:noise", "stage:digitize", "demosaic", "render", "xyz", "delta_e"]


def test_exposure_change_reruns_from_the_sensor_stage(scene, camera):
    p = Pipeline()
    p.run(scene, camera, CIELAB)
    r = p.run(scene, camera.replace(exposure=0.12), CIELAB)
    # the scene's ideal image does not depend on the exposure: it is not recomputed
    assert r.ran_steps == ["stage:sensor_responses", "stage:resample", "stage:mosaic", "stage:noise", "stage:digitize",
                           "demosaic", "render", "xyz", "delta_e"]
    # the chapter's reference (the cone camera at the camera's exposure) is
    chapter = Processing(metrics=("cielab",), reference="chapter")
    p.run(scene, camera, chapter)
    r = p.run(scene, camera.replace(exposure=0.14), chapter)
    assert r.ran_steps == ["stage:sensor_responses", "stage:resample", "stage:mosaic", "stage:noise", "stage:digitize",
                           "demosaic", "render", "ideal", "xyz", "ideal_xyz", "delta_e"]


@pytest.mark.parametrize("reference", ["scene", "chapter"])
def test_exposure_and_f_stop_moves_rescale_the_kept_sums_with_the_numbers_of_a_fresh_run(scene, camera, monkeypatch,
                                                                                          reference):
    """The sensor stage is made in two parts: its sums over the scene's planes (the camera's and the ideal
    image's cones) are kept while the sensors stay, so an exposure or f-stop move sums the cube zero times.
    The outputs are those of the whole stage: simulate(), ideal_image() and a serial pipeline's fresh run.
    The scene's ideal image is not recomputed at all; the chapter's is, beside the camera's side."""
    from camsim_core import cache
    from camsim_core.simulation import sensor

    sums = []
    real_weighted_sum = sensor.weighted_sum

    def counted(data, weights):
        sums.append(weights.shape)
        return real_weighted_sum(data, weights)

    monkeypatch.setattr(sensor, "weighted_sum", counted)
    # the ideal side, when it runs beside (in a pool's thread), waits until the camera image's side has come to
    # its L*a*b*: the case of a large scene, whose ideal side is the longer. (A 50 ms sleep made that depend on
    # the machine's load: the camera side came after the ideal one once, in a loaded run.)
    import threading

    from camsim_core.rendering import ideal as ideal_module

    real_render_ideal, real_camera_lab, early = ideal_module.render_ideal, Pipeline._camera_lab, []
    camera_side_there = threading.Event()

    def slow_render_ideal(*args, **kw):
        if threading.current_thread() is not threading.main_thread():
            camera_side_there.wait(timeout=30)
            camera_side_there.clear()
        return real_render_ideal(*args, **kw)

    def camera_lab(self, *args):
        camera_side_there.set()
        early.append(real_camera_lab(self, *args))
        return early[-1]

    monkeypatch.setattr(ideal_module, "render_ideal", slow_render_ideal)
    monkeypatch.setattr(Pipeline, "_camera_lab", camera_lab)
    both = Processing(metrics=("cielab", "scielab"), reference=reference)
    p = Pipeline()
    p.run(scene, camera, both)
    assert len(sums) == 2  # the camera's sensors and the ideal image's cones, once each
    for moved in (camera.replace(exposure=0.13), camera.replace(exposure=0.13, f_stop=8.0)):
        sums.clear()
        r = p.run(scene, moved, both)
        assert sums == [] and r.errors == {}
        assert r.ran_steps[:2] == ["stage:sensor_responses", "stage:resample"]
        assert ("ideal" in r.ran_steps) == (reference == "chapter")
        assert np.array_equal(_array(r.raw), _array(cc.simulate(scene, moved)))
        monitor = cc.load_monitor(both.monitor)
        assert np.array_equal(_array(r.ideal), _array(cc.ideal_image(scene, moved, monitor, reference=reference)))
        with monkeypatch.context() as serial:  # one core: no ideal side beside, the error maps made at the join
            serial.setattr(cache, "CORES", 1)
            fresh = Pipeline().run(scene, moved, both)
        for name in OUTPUTS:
            assert np.array_equal(_array(getattr(r, name)), _array(getattr(fresh, name))), name
        # a linear sensor: response proportional to exposure time and aperture area
        expected_gain = moved.exposure / moved.cal_exposure * (moved.cal_f_stop / moved.f_stop) ** 2
        assert r.raw.gain == fresh.raw.gain == pytest.approx(expected_gain, rel=1e-15)
    if cache.CORES > 1 and reference == "chapter":  # the moves' error maps: the camera's L*a*b* made beside the ideal side
        assert len(early) >= 2 and all(set(e) == {"cielab", "scielab"} for e in early[-2:])
    # other sensors: the camera's sums are made again, the ideal image's cones are still at hand
    sums.clear()
    p.run(scene, camera.replace(exposure=0.13, f_stop=8.0, sensors=cc.load_camera("gaussian-4").sensors), both)
    assert len(sums) == 1 and sums[0][1] == 4


def test_a_stage_in_two_parts_names_fields_it_reads():
    from camsim_core.simulation._stage import stage

    def first(camera, image):
        return image

    def finish(camera, prepared, reuse=False):
        return prepared

    with pytest.raises(ValueError, match="among the stage's uses"):
        stage("exposure", prepare=(first, ("sensors",), finish))
    marked = stage("sensors", "exposure", prepare=(first, ("sensors",), finish))(lambda camera, image: image)
    assert marked.prepare == (first, ("sensors",), finish) and marked.uses == ("sensors", "exposure")


def test_mosaic_and_processing_changes_rerun_only_downstream(scene, camera):
    p = Pipeline()
    p.run(scene, camera, CIELAB)
    assert p.run(scene, camera.replace(mosaic=BAYER["RGGB"]), CIELAB).ran_steps == [
        "stage:mosaic", "stage:noise", "stage:digitize", "demosaic", "render", "xyz", "delta_e"]
    cam = camera.replace(mosaic=BAYER["RGGB"])
    assert p.run(scene, cam, Processing(render="illuminant", metrics=("cielab",))).ran_steps == ["render", "xyz", "delta_e"]
    # S-CIELAB added: only the new map is computed
    assert p.run(scene, cam, Processing(render="illuminant", metrics=("cielab", "scielab"))).ran_steps == ["scielab"]


def test_nothing_reruns_when_nothing_changed(scene, camera):
    p = Pipeline()
    p.run(scene, camera, CIELAB)
    # an equal camera built anew (equal arrays, new objects) is recognised by content
    same = cc.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0, seed=0)
    assert p.run(scene, same, CIELAB).ran == []


def test_results_equal_a_fresh_full_run(scene, camera):
    gauss4 = cc.load_camera("gaussian-4").replace(distance=3.32, exposure=0.1, f_stop=11.0)
    sequence = [
        (camera, CIELAB),
        (camera.replace(noise_sigma=3.0, seed=2), CIELAB),
        (camera.replace(noise_sigma=3.0, seed=3, bits=10), Processing(metrics=("cielab", "scielab"))),
        (camera.replace(noise_sigma=3.0, seed=3, mosaic=BAYER["BGGR"]), Processing(render="illuminant", illuminant="gray-world")),
        (camera.replace(noise_sigma=1.0, exposure=0.08, distance=3.0), Processing(monitor="brainard-crt")),
        (gauss4.replace(noise_sigma=2.0), Processing(demosaic="bilinear", render="illuminant")),
        (camera, CIELAB),
    ]
    p = Pipeline()
    for cam, proc in sequence:
        cached = p.run(scene, cam, proc)
        fresh = Pipeline().run(scene, cam, proc)
        assert cached.errors == fresh.errors == {}
        for name in OUTPUTS:
            a, b = _array(getattr(cached, name)), _array(getattr(fresh, name))
            assert (a is None) == (b is None), name
            if a is not None:
                assert np.array_equal(a, b), f"{name} differs from a fresh run"
    # the last camera equals the first: the cache did not simply return the first result by accident
    assert cached.raw.tile is not None and np.array_equal(cached.raw.tile, BAYER["GRBG"])


def test_shared_scene_is_not_modified(scene, camera):
    before = fingerprint(np.asarray(scene.data))
    p = Pipeline()
    p.run(scene, camera.replace(noise_sigma=5.0), Processing(metrics=("cielab", "scielab")))
    p.run(scene, camera.replace(exposure=0.2), CIELAB)
    assert fingerprint(np.asarray(scene.data)) == before


def test_a_refused_step_is_reported_and_its_dependents_skipped(scene, camera):
    gauss4 = cc.load_camera("gaussian-4").replace(distance=3.32, exposure=0.1, f_stop=11.0)
    assert np.array_equal(gauss4.mosaic, FOUR_SENSOR_GRID)
    p = Pipeline()
    r = p.run(scene, gauss4, Processing(demosaic="no-such-method", metrics=("cielab",)))
    assert set(r.errors) == {"demosaic"} and "no-such-method" in r.errors["demosaic"]
    assert r.raw is not None and r.ideal is not None
    assert r.demosaiced is None and r.rendered is None and r.delta_e is None
    assert not {"render", "xyz", "delta_e"} & set(r.ran_steps)
    # the failure is not cached: the same request fails again, and a good one then succeeds
    assert "demosaic" in p.run(scene, gauss4, Processing(demosaic="no-such-method", metrics=("cielab",))).errors
    ok = p.run(scene, gauss4, Processing(demosaic="bilinear", metrics=("cielab",)))
    assert ok.errors == {} and ok.delta_e is not None
    assert ok.ran_steps == ["demosaic", "render", "xyz", "delta_e"]


def test_fingerprint_compares_arrays_by_content():
    a = np.arange(6.0).reshape(2, 3)
    assert fingerprint(a) == fingerprint(a.copy())
    b = a.copy()
    b[1, 2] += 1e-12
    assert fingerprint(a) != fingerprint(b)
    assert fingerprint(a) != fingerprint(a.reshape(3, 2))


@pytest.mark.parametrize("name", ["human-cones", "stockman-sharpe", "cie1931", "kodak-dcs200-ir"])
def test_a_full_colour_image_is_processed_without_demosaicing(scene, name):
    """A camera without a mosaic records every sensor at every pixel: nothing to demosaic."""
    cam = cc.load_camera(name).replace(mosaic=None, distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0)
    p = Pipeline()
    r = p.run(scene, cam, CIELAB)
    assert r.errors == {}, r.errors
    assert "demosaic" not in r.ran_steps and "not mosaiced" in r.skipped["demosaic"]
    assert r.demosaiced is r.raw and r.raw.data.ndim == 3
    assert np.array_equal(_array(r.rendered), _array(cc.render(r.raw, cc.load_monitor("simtoolbox-test"))))
    # the demosaicing method is irrelevant: changing it re-runs nothing
    again = p.run(scene, cam, Processing(demosaic="freeman", metrics=("cielab",)))
    assert again.ran_steps == [] and again.errors == {}
    # and a mosaiced camera afterwards is demosaiced again
    mosaiced = p.run(scene, cam.replace(mosaic=BAYER["GRBG"]), CIELAB)
    assert "demosaic" in mosaiced.ran_steps and mosaiced.skipped == {}


def test_the_ideal_camera_itself_scores_zero(scene):
    """The chapter's ideal image's own camera (cones, no mosaic, no noise, 8 bits, baseline) has dE 0 exactly
    against the chapter's reference."""
    from camsim_core.rendering import ideal_camera

    cam = cc.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0)
    r = Pipeline().run(scene, ideal_camera(cam), Processing(metrics=("cielab",), reference="chapter"))
    assert r.errors == {} and "demosaic" in r.skipped
    assert np.array_equal(_array(r.rendered), _array(r.ideal))
    assert float(np.max(r.delta_e)) == 0.0


def test_a_pipeline_started_from_anothers_snapshot_reruns_only_what_differs(scene, camera):
    first = Pipeline()
    a = first.run(scene, camera, CIELAB)
    second = Pipeline()
    second.start_from(first.snapshot())
    same = second.run(scene, camera, CIELAB)
    assert same.ran_steps == []  # everything was at hand
    for name in OUTPUTS:
        ref, got = _array(getattr(a, name)), _array(getattr(same, name))
        assert (ref is None and got is None) or np.array_equal(ref, got)
    noisy = second.run(scene, camera.replace(noise_sigma=2.0), CIELAB)
    assert noisy.ran_steps == ["stage:noise", "stage:digitize", "demosaic", "render", "xyz", "delta_e"]
    # the first pipeline is unaffected by what the second computed
    again = first.run(scene, camera, CIELAB)
    assert again.ran_steps == [] and np.array_equal(_array(again.rendered), _array(a.rendered))
    fresh = Pipeline().run(scene, camera.replace(noise_sigma=2.0), CIELAB)
    assert np.array_equal(_array(noisy.rendered), _array(fresh.rendered))


def test_the_ideal_side_runs_beside_the_camera_side_with_the_same_numbers(scene, camera, monkeypatch):
    """A distance move recomputes the ideal image on a thread of its own (the camera's side keeps the
    calling thread); the steps are listed as a serial run lists them, and the outputs equal a serial run's."""
    import threading

    from camsim_core import cache

    from camsim_core.rendering import ideal as ideal_module

    threads = {}
    real_render_ideal, real_demosaic = ideal_module.render_scene_ideal, cc.demosaic

    def render_ideal(*args, **kw):  # the last of the ideal image's steps
        threads["ideal"] = threading.current_thread().name
        return real_render_ideal(*args, **kw)

    def demosaic(*args, **kw):
        threads["demosaic"] = threading.current_thread().name
        return real_demosaic(*args, **kw)

    monkeypatch.setattr(ideal_module, "render_scene_ideal", render_ideal)
    monkeypatch.setattr(cc, "demosaic", demosaic)
    p = Pipeline()
    p.run(scene, camera, Processing())
    r = p.run(scene, camera.replace(distance=3.0), Processing())
    here = threading.current_thread().name
    assert threads["demosaic"] == here
    assert threads["ideal"] != here and threads["ideal"].startswith("camsim-ideal")
    assert r.ran_steps == ["stage:resample", "stage:mosaic", "stage:noise", "stage:digitize",
                           "demosaic", "render", "ideal", "xyz", "ideal_xyz", "delta_e", "scielab"]
    assert 0 < r.elapsed
    # one core: everything in the calling thread, the same numbers
    monkeypatch.setattr(cache, "CORES", 1)
    serial = Pipeline()
    serial.run(scene, camera, Processing())
    s = serial.run(scene, camera.replace(distance=3.0), Processing())
    assert threads["ideal"] == here
    assert s.ran_steps == r.ran_steps
    for name in OUTPUTS:
        assert np.array_equal(_array(getattr(r, name)), _array(getattr(s, name))), name


def test_a_failed_stage_still_reports_the_ideal_side(scene, camera):
    """A stage that fails stops the camera's side; the ideal image (which does not need it) is still
    computed and reported, and the failure is not cached."""
    p = Pipeline()
    p.run(scene, camera, CIELAB)

    def broken(cam, image):  # refuses the camera, not its ideal counterpart (which has no mosaic)
        if cam.mosaic is not None:
            raise cc.ParameterError("broken", "refused on purpose")
        return image

    bad = camera.replace(distance=3.0, architecture=camera.architecture[:2] + (broken,) + camera.architecture[3:])
    r = p.run(scene, bad, CIELAB)
    assert set(r.errors) == {"stage:broken"} and "refused on purpose" in r.errors["stage:broken"]
    assert r.raw is None and r.rendered is None and r.delta_e is None
    assert r.ideal is not None and "ideal" in r.ran_steps
    assert r.ran_steps.index("stage:broken") < r.ran_steps.index("ideal")


def test_an_unexpected_error_waits_for_the_ideal_side(scene, camera, monkeypatch):
    """An error the pipeline does not report as a step's (here a MemoryError in the demosaicing) leaves
    ``run`` only after the ideal side running beside it has ended: nothing of that run keeps writing to
    the pipeline afterwards."""
    import threading
    import time as _time

    from camsim_core.rendering import ideal as ideal_module

    real_render_ideal = ideal_module.render_scene_ideal
    ended = threading.Event()

    def slow_render_ideal(*args, **kw):  # the last of the ideal image's steps
        _time.sleep(0.3)
        out = real_render_ideal(*args, **kw)
        ended.set()
        return out

    def no_memory(*args, **kw):
        raise MemoryError("no memory on purpose")

    p = Pipeline()
    p.run(scene, camera, CIELAB)
    monkeypatch.setattr(ideal_module, "render_scene_ideal", slow_render_ideal)
    monkeypatch.setattr(cc, "demosaic", no_memory)
    with pytest.raises(MemoryError):
        p.run(scene, camera.replace(distance=3.0), CIELAB)
    assert ended.is_set()


def test_the_scene_ideal_is_computed_only_when_the_scene_grid_or_monitor_moves(scene, camera, monkeypatch):
    """The scene's ideal image depends on the scene, the camera's pixel grid and the monitor only: a move of
    exposure, f-number, bits, noise, seed, pedestal, sensors, mosaic or optics computes it zero times (the
    same object is returned), a distance move re-renders the kept cone responses without summing the cube,
    and a new scene (a light level) or monitor computes it again. Counted at the ideal module's functions."""
    from camsim_core.rendering import ideal as ideal_module

    counts = {"cones": 0, "render": 0}
    real_cones, real_render = ideal_module.scene_cones, ideal_module.render_scene_ideal

    def cones(*args, **kw):
        counts["cones"] += 1
        return real_cones(*args, **kw)

    def render(*args, **kw):
        counts["render"] += 1
        return real_render(*args, **kw)

    monkeypatch.setattr(ideal_module, "scene_cones", cones)
    monkeypatch.setattr(ideal_module, "render_scene_ideal", render)
    p = Pipeline()
    first = p.run(scene, camera, CIELAB)
    assert counts == {"cones": 1, "render": 1} and first.errors == {}
    kept = first.ideal
    moves = [camera.replace(exposure=1.6), camera.replace(f_stop=4.0), camera.replace(bits=12),
             camera.replace(bits=None), camera.replace(noise_sigma=5.0, seed=3), camera.replace(black_level=16.0),
             camera.replace(sensors=cc.load_camera("gaussian-4").sensors, mosaic=FOUR_SENSOR_GRID),
             camera.replace(mosaic=BAYER["RGGB"]), camera.replace(optics="diffraction", relative_illumination=True)]
    for moved in moves:
        r = p.run(scene, moved, CIELAB)
        assert r.errors == {}, r.errors
        assert counts == {"cones": 1, "render": 1} and "ideal" not in r.ran_steps
        assert r.ideal is kept and "ideal_xyz" not in r.ran_steps
    r = p.run(scene, camera.replace(distance=3.0), CIELAB)
    assert counts == {"cones": 1, "render": 2} and "ideal" in r.ran_steps  # resampled and rendered, not summed
    assert not np.array_equal(_array(r.ideal), _array(kept))
    r = p.run(scene, camera.replace(distance=3.0), Processing(metrics=("cielab",), monitor="brainard-crt"))
    assert counts == {"cones": 1, "render": 3}
    brighter = cc.scene.scale_light(scene, 2.0)
    r = p.run(brighter, camera.replace(distance=3.0), CIELAB)
    assert counts == {"cones": 2, "render": 4} and r.errors == {}
