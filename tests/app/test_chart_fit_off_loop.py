"""A chart picked in a served explorer is made in the session's computing thread, not on the event loop, and
its notice survives its own result (issue 37).

Making a frame-sized chart takes about a second and 138-276 MB; in the param watcher it held the server's
event loop (every page) meanwhile. Here the "event loop" is the test's thread: the state gets a runner whose
outcomes are queued and applied on this thread, as the page's next-tick callback does; which thread made the
chart and its exposure is recorded by wrapping the engine's functions.
"""

import threading

import numpy as np
import pytest

import camsim_core as cc
import camsim_core.scene.charts as charts
from camsim_explorer.state import ExplorerState, Runner
from served_state import served, settle


@pytest.fixture
def calls(monkeypatch):
    """Threads that made a chart or an auto exposure: [(what, thread id)]."""
    seen = []
    make, expose = charts.chart, cc.auto_exposure

    def chart(*a, **k):
        seen.append(("chart", threading.get_ident()))
        return make(*a, **k)

    def auto_exposure(*a, **k):
        seen.append(("auto_exposure", threading.get_ident()))
        return expose(*a, **k)

    monkeypatch.setattr(charts, "chart", chart)
    monkeypatch.setattr(cc, "auto_exposure", auto_exposure)
    # no chart another test's session still holds (sessions share charts by name): each chart here is made
    import weakref

    import camsim_explorer.state as state_module

    monkeypatch.setattr(state_module, "_SHARED_CHARTS", weakref.WeakValueDictionary())
    return seen


def test_a_picked_chart_is_made_in_the_computing_thread(calls):
    loop = threading.get_ident()
    state = ExplorerState(start=False)
    outcomes = served(state)
    state.recompute()
    settle(state, outcomes)
    default_exposure = state.exposure
    calls.clear()
    state.scene = "slanted-edge"
    # the watcher returned without making the chart or exposing it: nothing of it ran on the loop
    assert not any(t == loop for _, t in calls), calls
    assert state.computing and "Sizing chart" in state.notice
    settle(state, outcomes)
    assert {w for w, _ in calls} == {"chart", "auto_exposure"} and all(t != loop for _, t in calls), calls
    # shown once its result arrives: the fitted chart selected, exposed, and the result made from them
    cam, raw = state.camera_object(), state.result.raw
    assert state.scene.startswith("slanted-edge:") and state.scene in state.param.scene.objects
    assert state.shown["scene"] == state.scene and state.shown["exposure"] == state.exposure != default_exposure
    assert raw.data.shape[0] >= 0.8 * cam.height and raw.data.shape[1] >= 0.8 * cam.width
    top = np.percentile(np.asarray(raw.data, float), 99.5) / raw.full_scale
    assert 0.5 <= top <= 0.9
    assert state.result.camera.exposure == state.exposure
    assert "Chart sized to the frame" in state.notice and state.message == ""
    # the scene the views ask for is the one computed, held by the session: nothing is made on the loop
    calls.clear()
    assert state.scene_object() is state.result.scene
    assert calls == []


def test_a_change_while_the_chart_is_made_keeps_the_fit(calls):
    """A slider moved before the chart's result arrives supersedes that job; the newer one still fits the
    chart, made once (and the user's own exposure, set meanwhile, is kept)."""
    state = ExplorerState(start=False)
    outcomes = served(state)
    state.scene = "uniform"
    state.noise_sigma = 1.0
    state.exposure = 0.05
    settle(state, outcomes)
    assert state.scene.startswith("uniform:") and state.shown["noise_sigma"] == 1.0
    assert state.exposure == 0.05 and state.result.camera.exposure == 0.05
    assert state.result.raw.data.shape[0] >= 0.8 * state.camera_object().height
    assert [w for w, _ in calls].count("chart") == 1, calls


def test_without_a_runner_the_chart_is_made_at_once(calls):
    loop = threading.get_ident()
    state = ExplorerState(start=False)
    state.scene = "uniform"
    assert calls and all(t == loop for _, t in calls)
    assert state.scene.startswith("uniform:") and state.result.scene is state.scene_object()


def test_the_chart_notice_survives_its_own_result():
    """fit_chart's notice, then the result computed for it (no runner): the notice still says so."""
    state = ExplorerState(start=False)
    notice = state.fit_chart("uniform")
    assert notice.startswith("Chart sized")
    state.recompute()
    assert state.result is not None and state.shown["scene"] == state.scene
    assert state.notice.startswith("Chart sized")


def test_the_chart_notice_survives_its_result_from_the_computing_thread():
    """A runner delivering in its own thread (as test_app_state's): the notice once the result is applied."""
    state = ExplorerState(start=False)
    state.set_runner(Runner(state._compute, state._apply))
    state.scene = "zone-plate"
    done = threading.Event()

    def wait():
        while state.computing or state.runner.busy:
            threading.Event().wait(0.05)
        done.set()

    threading.Thread(target=wait, daemon=True).start()
    assert done.wait(120)
    assert state.scene.startswith("zone-plate:") and "Chart sized to the frame" in state.notice


def test_a_new_camera_refits_the_chart_in_the_computing_thread(calls):
    loop = threading.get_ident()
    state = ExplorerState(start=False)
    outcomes = served(state)
    state.scene = "munsell"
    settle(state, outcomes)
    fitted = state.scene
    calls.clear()
    state.camera = "imx174"
    assert not any(t == loop for _, t in calls), calls
    settle(state, outcomes)
    assert calls and all(t != loop for _, t in calls)
    cam, raw = state.camera_object(), state.result.raw
    assert state.scene != fitted and state.scene.startswith("munsell:") and state.shown["camera"] == "imx174"
    assert raw.data.shape[0] >= 0.8 * cam.height and raw.data.shape[1] >= 0.8 * cam.width, raw.data.shape
    assert "Chart sized to the frame" in state.notice


def test_a_refused_fit_shows_the_chart_at_its_default_size_made_off_the_loop(monkeypatch):
    """A fit refused in the computing thread falls back to the chart at its default size, made there too: the
    job no longer makes it on the event loop in case the fit fails (a process's first pick of a chart held
    every page's loop 230-330 ms for it)."""
    from camsim_core.errors import CamsimError

    loop = threading.get_ident()
    state = ExplorerState(start=False)
    outcomes = served(state)
    state.recompute()
    settle(state, outcomes)
    loaded, load = [], cc.load_scene

    def load_scene(name, *a, **k):
        loaded.append((str(name), threading.get_ident()))
        return load(name, *a, **k)

    def refuse(*a, **k):
        raise CamsimError("the frame is too large for this chart")

    monkeypatch.setattr(cc, "load_scene", load_scene)
    monkeypatch.setattr(state, "_make_fitted", refuse)
    state.scene = "zone-plate"
    assert ("zone-plate", loop) not in loaded, loaded
    settle(state, outcomes)
    assert state.message == "Chart zone-plate kept at its default size: the frame is too large for this chart"
    assert state.result.scene.shape == load("zone-plate").shape and state.shown["scene"] == "zone-plate"
    assert ("zone-plate", loop) not in loaded and any(n == "zone-plate" and t != loop for n, t in loaded), loaded
