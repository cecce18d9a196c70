"""The Compare designs tab without a browser (app.compare on an ExplorerState)."""

import json

import numpy as np
import pytest

from camsim_explorer.compare import CompareView
from camsim_explorer.state import ExplorerState
from camsim_core.review import evaluate_design
from camsim_core.review.design import MAX_PINNED


@pytest.fixture(scope="module")
def engine():
    """The engine's results for each design alone."""
    return {name: evaluate_design({"camera": cam}, name) for name, cam in
            (("DCS-200", "kodak-dcs200-ir"), ("cones", "human-cones"))}


@pytest.fixture
def compared():
    state = ExplorerState()
    view = CompareView(state)
    view.pin("DCS-200")
    state.camera = "human-cones"
    view.pin("cones")
    return state, view


def test_pinned_designs_show_the_engines_numbers(compared, engine):
    state, view = compared
    status = json.loads(view.status.object)
    # the live design equals the pinned "cones": two designs, not three
    assert [d["name"] for d in status["designs"]] == ["DCS-200", "cones"]
    assert status["differ"] == ["camera"] and status["hist_curves"] == 2
    for d in status["designs"]:
        assert d["measures"] == engine[d["name"]].measures
    assert status["designs"][0]["measures"]["cielab"]["mean"] != status["designs"][1]["measures"]["cielab"]["mean"]
    for name, r in engine.items():
        assert f'data-value="{r.measures["cielab"]["mean"]!r}"' in view.table.object
    assert "kodak-dcs200-ir" in view.table.object and "human-cones" in view.table.object
    assert [slot.visible for slot in view.slots] == [True, True, False, False, False]
    # and the image-quality measures the scene allows, as the engine computes them for each design alone
    for name, r in engine.items():
        assert set(r.quality) == {"psnr_db", "ssim"}
        assert f'data-value="{r.quality["psnr_db"]!r}"' in view.table.object
    assert 'data-measure="ssim"' in view.table.object and 'data-measure="mtf50"' not in view.table.object


def test_each_pinned_design_is_computed_once(compared, monkeypatch):
    state, view = compared
    import camsim_explorer.compare as module

    calls = []
    real = module.evaluate_design
    busy = []  # what the page shows while a design is computed

    def spy(*a, **k):
        calls.append(a[1])
        busy.append((view.progress.max, view.message.object, json.loads(view.status.object or "{}").get("busy")))
        return real(*a, **k)

    monkeypatch.setattr(module, "evaluate_design", spy)
    state.noise_sigma = 3.0  # the live design changes; the pinned ones are not recomputed
    def images():  # design name -> the image its slot holds
        return {v.figure.title.text.rpartition(":")[0]: v.source.data["image"][0]
                for v, slot in zip(view.render_views, view.slots) if slot.visible}

    sent = images()
    state.noise_sigma = 4.0  # another live move re-sends the live design's images only
    now = images()
    assert set(now) == {"live", "DCS-200", "cones"}
    assert now["live"] is not sent["live"] and not np.array_equal(now["live"], sent["live"])
    assert now["DCS-200"] is sent["DCS-200"] and now["cones"] is sent["cones"]
    view.rename("cones", "human cones")
    assert calls == []
    # each design where it was shown: the live design after the two pinned from it
    assert [d["name"] for d in json.loads(view.status.object)["designs"]] == ["DCS-200", "human cones", "live"]
    state.scene = "bfgb128"  # a shared setting: every pinned design is recomputed, once
    assert sorted(calls) == ["DCS-200", "human cones"]
    assert all(total == 2 and "Computing 2 pinned design(s) on bfgb128" in text for total, text, _ in busy)
    # the bar empty again (always shown: a change of its visibility lays the whole tab out again in the browser)
    assert view.progress.value == 0 and view.progress.visible and json.loads(view.status.object)["busy"] is False
    assert all(d["shape"] == json.loads(view.status.object)["designs"][0]["shape"]
               for d in json.loads(view.status.object)["designs"])


def test_pin_cap_shows_a_message(compared):
    state, view = compared
    for i in range(MAX_PINNED - 2):
        state.noise_sigma = float(i + 1)
        assert view.pin()
    assert len(state.pinned) == MAX_PINNED
    assert not view.pin("one too many")
    assert len(state.pinned) == MAX_PINNED and "At most 4 pinned designs" in view.message.object
    view.unpin("DCS-200")
    assert [p["name"] for p in state.pinned][0] == "cones"


def test_ab_difference_against_the_ideal_design(compared, engine):
    state, view = compared
    status = json.loads(view.status.object)
    assert status["ab"]["a"] == "DCS-200" and status["ab"]["b"] == "cones"
    # the cones render the scene's ideal image up to their own quantization: the A/B map is DCS-200's error map
    # within the cones' (dE*ab is a distance: the triangle inequality, pixel by pixel and so for the means)
    dcs, cones = (engine[k].measures["cielab"]["mean"] for k in ("DCS-200", "cones"))
    assert abs(status["ab"]["mean"] - dcs) <= cones < 0.1 * dcs
    assert status["ab"]["a_wins"] < 0.01


def test_sweep_points_equal_the_engine_and_a_click_loads_one(compared):
    state, view = compared
    assert view.request_sweep("noise_sigma", "0, 2, 4, 6, 8")
    status = json.loads(view.status.object)
    points = status["sweep"]["points"]
    assert len(points) == 10 and sorted({p["design"] for p in points}) == ["DCS-200", "cones"]
    cams = {"DCS-200": "kodak-dcs200-ir", "cones": "human-cones"}
    for p in points[::3]:  # a few checked against the engine alone (each takes a second)
        alone = evaluate_design({"camera": cams[p["design"]], "noise_sigma": p["value"]}, p["design"],
                                metrics=("cielab",))  # the sweep computes the error it plots
        assert p["measures"] == alone.measures
    target = next(p for p in view.points if p.name == "DCS-200" and p.value == 6.0)
    view.on_tap(6.1, target.measure() + 0.1)
    assert state.camera == "kodak-dcs200-ir" and state.noise_sigma == 6.0
    assert np.mean(state.result.delta_e, dtype=np.float64) == pytest.approx(target.measure(), rel=1e-12)


def test_bad_sweeps_and_names_are_refused_with_a_message(compared):
    state, view = compared
    assert not view.request_sweep("noise_sigma", "0, lots")
    assert "Refused" in view.sweep_message.object
    view.request_sweep("alpha", "0, 1")
    assert "mixture camera only" in view.sweep_message.object
    assert not view.rename("cones", "DCS-200")
    assert "unique" in view.message.object


def test_state_json_reproduces_the_comparison(compared):
    state, view = compared
    view.request_sweep("noise_sigma", "0, 4")
    text = state.to_json()
    other = ExplorerState()
    assert other.from_json(text), other.message
    again = CompareView(other)
    a, b = json.loads(view.status.object), json.loads(again.status.object)
    assert a["designs"] == b["designs"] and a["sweep"]["points"] == b["sweep"]["points"]


def test_bad_pinned_entries_in_a_file_are_refused(compared):
    state, _ = compared
    other = ExplorerState()
    bad = json.loads(state.to_json())
    bad["pinned"] = [{"name": "x", "params": {"camera": "pinhole"}}]
    assert not other.from_json(json.dumps(bad))
    assert "pinhole" in other.message and other.pinned == []


def test_report_download_is_self_contained(compared):
    state, view = compared
    html = view.report_bytes().getvalue().decode()
    srcs = [s.split('"', 1)[0] for s in html.split('src="')[1:]]
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    assert "DCS-200" in html and "A/B difference" in html
    assert np.isfinite(json.loads(view.status.object)["store"]["megabytes"])


def test_the_live_design_skips_the_quality_measures_but_its_report_has_them():
    state = ExplorerState()
    view = CompareView(state)
    view.pin("DCS-200")
    state.noise_sigma = 4.0  # the live design now differs from the pinned one
    live = view.live_result()
    assert live.quality == {}  # on every move: none of their ~45 ms
    assert "pin the live design to measure it" in view.table.object
    page = view.report_bytes().getvalue().decode()
    alone = evaluate_design(state.design_params(), "live")
    assert f'data-value="{alone.quality["psnr_db"]!r}"' in page and f'data-value="{alone.quality["ssim"]!r}"' in page


def test_the_histogram_changes_in_one_held_batch(monkeypatch):
    """The histogram is a Bokeh figure changed in place. On a server, a change made outside ``pn.io.hold`` goes
    to the page at once while Panel may still queue the message that brings the figure (a write under way):
    the browser then drops it ("reference p2578 isn't known", seen in the browser fuzz under load). Every
    change to it must therefore be made while the document is held."""
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    import camsim_explorer.compare as module

    doc = Document()
    holds = []
    real = module.HistogramPlot.show

    def spy(self, *args, **kwargs):
        holds.append(doc.callbacks.hold_value)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(module.HistogramPlot, "show", spy)
    with set_curdoc(doc):
        state = ExplorerState()
        view = CompareView(state)
        view.pin("DCS-200")
        state.camera = "human-cones"
        view.pin("cones")
        view.unpin("cones")
    assert len(holds) >= 3 and all(h is not None for h in holds), holds
    assert doc.callbacks.hold_value is None  # and let go of afterwards


def test_each_image_frame_takes_the_shape_of_its_image():
    """A wide scene's images sat in square frames with white bands above and below (HoloViews sized each frame
    once, for the first, 2 x 2 placeholder); the frames now take the images' shape (square pixels, the frame
    filled, at most 375 px high), made anew when a scene of another shape comes."""
    import panel as pn
    from bokeh.models import Image, ImageRGBA, Plot

    from camsim_explorer.views import ASPECT_TOLERANCE

    FRAME_WIDTH, MAX_FRAME_HEIGHT = 250, 375  # camsim_explorer.compare's

    def figures(root):  # what a page shows: the Bokeh figures of the tab's images (visible design slots, A/B)
        images = [f for f in root.select({"type": Plot})
                  if any(isinstance(r.glyph, (Image, ImageRGBA)) for r in f.renderers if hasattr(r, "glyph"))]
        return [f for f in images if f.title.text.strip()]  # a slot without a design has no title

    state = ExplorerState()  # cacaphony290: wider than high
    view = CompareView(state)
    root = pn.Column(view.views).get_root()  # the page shows the tab before its images come
    view.pin("DCS-200")
    state.camera = "human-cones"
    h, w = state.result.rendered.data.shape[:2]
    assert h < 0.8 * w  # a wide scene: a square frame would leave bands
    shown = figures(root)
    assert len(shown) >= 4, [f.title.text for f in shown]
    for fig in shown:
        assert fig.frame_width == FRAME_WIDTH, fig.title.text
        assert fig.frame_height == pytest.approx(FRAME_WIDTH * h / w, abs=1), fig.title.text
        # the ranges are the image's extent, in the frame's proportions: square pixels, no band
        x_span, y_span = fig.x_range.end - fig.x_range.start, fig.y_range.end - fig.y_range.start
        assert y_span / x_span == pytest.approx(fig.frame_height / fig.frame_width, rel=ASPECT_TOLERANCE - 1)
    # a scene taller than wide: new frames, at most MAX_FRAME_HEIGHT high, of the images' shape; a slot no design
    # uses keeps its frame until it is used (a new frame lays the tab out again in the browser)
    unused = view.render_views[-1].figure
    before = (unused.frame_width, unused.frame_height)
    state.scene = "munsell"
    assert state.set_chart("rows=8, cols=2")
    h, w = state.result.rendered.data.shape[:2]
    assert h / w > MAX_FRAME_HEIGHT / FRAME_WIDTH, (h, w)
    for fig in figures(root):
        assert fig.frame_height == MAX_FRAME_HEIGHT
        assert fig.frame_width == pytest.approx(MAX_FRAME_HEIGHT * w / h, abs=1)
        x_span, y_span = fig.x_range.end - fig.x_range.start, fig.y_range.end - fig.y_range.start
        assert y_span / x_span == pytest.approx(fig.frame_height / fig.frame_width, rel=ASPECT_TOLERANCE - 1)
        assert fig.y_range.start <= 0 and fig.y_range.end >= h / w * 0.999  # the whole image (scene widths)
    assert (unused.frame_width, unused.frame_height) == before


def test_a_zoom_survives_a_live_move_and_a_new_scene_shows_the_whole_image(compared):
    """The images' shared ranges are set to the whole image only for a new scene or image shape: a user
    zoomed into the designs keeps the zoom while changing the live design (they were reset at every image)."""
    state, view = compared
    x, y = view.x_range, view.y_range
    h, w = state.result.rendered.data.shape[:2]
    assert x.start <= 0 and x.end >= 1 and y.start <= 0 and y.end >= h / w * 0.999  # scene widths, whole
    x.update(start=0.2, end=0.4)  # zoomed in, as the browser would set it
    y.update(start=0.1, end=0.2)
    state.noise_sigma = 3.0  # a live move: new images for the live design, the zoom kept
    assert (x.start, x.end, y.start, y.end) == (0.2, 0.4, 0.1, 0.2)
    state.scene = "bfgb128"  # another scene: the whole image again (and the reset tool comes back to it)
    h, w = state.result.rendered.data.shape[:2]
    assert x.start <= 0 and x.end >= 1 and y.start <= 0 and y.end >= h / w * 0.999
    assert (x.reset_start, x.reset_end, y.reset_start, y.reset_end) == (x.start, x.end, y.start, y.end)


def test_designs_that_come_quickly_are_shown_in_one_update(compared, monkeypatch):
    """Each update lays the whole tab out in the browser: designs done within UPDATE_EVERY_S of the start of
    their computation, or of the last update, wait for the last one; a slow batch still shows progress."""
    import time

    import camsim_explorer.compare as module

    state, view = compared
    shown = []
    monkeypatch.setattr(view, "update", lambda: shown.append(view.progress.value))
    view._generation += 1
    view.progress.max, view._started = 3, time.monotonic()  # as ``refresh`` starts three designs
    view._progress(view._generation, 1, 3)
    view._progress(view._generation, 2, 3)
    assert shown == []  # quick: nothing shown yet, the bar moves
    assert view.progress.value == 2
    view._progress(view._generation, 3, 3)
    assert len(shown) == 1  # all three at once
    view._started = time.monotonic() - module.UPDATE_EVERY_S  # a batch computing for a while
    view._updated = 0.0
    view._progress(view._generation, 1, 3)
    assert len(shown) == 2  # shown as it comes


def test_the_comparisons_status_shows_only_while_its_box_is_ticked():
    """The raw JSON status (for scripts) is hidden until asked for (issue 38: it was always in view)."""
    view = CompareView(ExplorerState(start=False))
    assert view.status.visible is False
    view.show_status.value = True
    assert view.status.visible is True
    view.show_status.value = False
    assert view.status.visible is False


def test_a_live_move_sends_views_made_in_the_computing_thread(monkeypatch):
    """With designs pinned, what the tab shows of a new live result (its image views' data, histogram and part
    of the colour scale) is made in the session's computing thread with the result; the event loop only sends
    it (a frame-sized chart's took the loop ~60-100 ms a design at each update)."""
    import threading

    from served_state import served, settle

    loop = threading.get_ident()
    state = ExplorerState(start=False)
    outcomes = served(state)
    view = CompareView(state)
    state.recompute()
    settle(state, outcomes)
    assert view.pin("DCS-200")
    made = []
    for kind, fn in list(CompareView._MAKERS.items()):
        monkeypatch.setitem(CompareView._MAKERS, kind,
                            lambda a, fn=fn, kind=kind: made.append((kind, threading.get_ident())) or fn(a))
    state.noise_sigma = 3.0
    settle(state, outcomes)
    live = next(r for r in view.designs() if r.name == "live")
    assert live.params["noise_sigma"] == 3.0 and any(s is not None and s[1] is live.rendered for s in view._shown)
    assert {kind for kind, _ in made} == {"render", "de", "hist", "top"}, made
    assert all(thread != loop for _, thread in made), made


def test_a_refusal_made_while_designs_compute_stays_in_sight():
    """A name refused while pinned designs were computing vanished when they were done (the computing note's
    place was cleared whatever it held): the browser fuzz, under load, never saw the refusal. The note itself
    still gives way when the designs are done."""
    state = ExplorerState()
    view = CompareView(state)
    view.message.object = view._computing_text = "Computing 1 pinned design(s) on cacaphony290..."
    view._progress(view._generation, 1, 1)
    assert view.message.object == ""
    view.message.object = view._computing_text = "Computing 1 pinned design(s) on cacaphony290..."
    assert not view.pin("n" * 400)
    refusal = view.message.object
    view._progress(view._generation, 1, 1)
    assert "at most" in refusal and view.message.object == refusal


def _pinned_entries(*cameras):
    """Pinned-design entries (as a link or a parameters file holds them) for ``cameras`` on the default scene."""
    from camsim_core.review.design import check_pinned

    return check_pinned([{"name": cam, "params": {"camera": cam}} for cam in cameras])  # full parameters


@pytest.fixture
def counted(monkeypatch):
    """Calls of evaluate_design by the Compare tab (names), with a registry of shared designs of this test's own."""
    import camsim_explorer.compare as module

    calls = []
    real = module.evaluate_design
    monkeypatch.setattr(module, "evaluate_design", lambda params, name, **kw: calls.append(name) or real(params, name, **kw))
    monkeypatch.setattr(module, "SHARED_DESIGNS", module.SharedDesigns())
    return calls


def test_a_links_pinned_designs_compute_while_the_compare_tab_is_hidden_and_show_when_it_opens(counted):
    """A link's (or a parameters file's) pinned designs are computed from the moment the page has them, whatever
    tab is open: the Compare tab was built, and its designs computed, only once a student opened it (a link
    of four designs of a frame-sized chart: 10-13 s after the page was open)."""
    from camsim_explorer import main
    from camsim_explorer.views import ResultsView

    entries = _pinned_entries("kodak-dcs200-ir", "human-cones")
    state = ExplorerState(start=False)
    tabs = main._lazy_tabs(state, {"state": state, "results": ResultsView(state)})
    compare_holder = tabs.objects[main._COMPARE_TAB]
    assert compare_holder.objects == []  # no designs, no Compare tab yet (a light page)
    state.pinned = entries
    assert tabs.active == 0 and len(compare_holder.objects) == 1
    view = compare_holder.objects[0].compare
    assert counted == ["kodak-dcs200-ir", "human-cones"]  # computed with the tab hidden
    assert view.progress.value == 0 and not view._computing
    assert "human-cones" not in (view.status.object or "")  # and shown only when the tab opens
    tabs.active = main._COMPARE_TAB
    status = json.loads(view.status.object)
    assert [d["name"] for d in status["designs"]][-2:] == ["kodak-dcs200-ir", "human-cones"]
    assert status["busy"] is False and counted == ["kodak-dcs200-ir", "human-cones"]


def test_a_design_another_session_holds_is_taken_not_computed_again(counted):
    """A class opening its teacher's link: each page computed the teacher's designs again (5-8 s and 71 MB a
    design of a frame-sized chart, per page). A design another session holds is the same object, not a copy;
    the registry keeps nothing no session holds, and never an uploaded scene's design."""
    import gc
    import types

    import camsim_explorer.compare as module

    entries = _pinned_entries("human-cones")
    counted.clear()
    first = CompareView(ExplorerState(start=False))
    first.state.pinned = entries
    second = CompareView(ExplorerState(start=False))
    second.state.pinned = entries
    assert counted == ["human-cones"]
    key = first._scene_key()
    mine, theirs = first.store.get(key, entries[0]["params"]), second.store.get(key, entries[0]["params"])
    assert mine is not None and mine is theirs
    assert len(module.SHARED_DESIGNS) == 1
    del first, second, mine, theirs
    gc.collect()
    assert len(module.SHARED_DESIGNS) == 0  # held weakly: gone with the sessions that held it
    upload, held = ("upload:mine.npz@140000", 0.2), types.SimpleNamespace()  # a session's own scene: not shared
    module.SHARED_DESIGNS.put(upload, entries[0]["params"], held)
    assert module.SHARED_DESIGNS.get(upload, entries[0]["params"]) is None and len(module.SHARED_DESIGNS) == 0


def test_designs_computed_for_a_page_being_built_start_once_its_session_is_live(monkeypatch):
    """A link's designs start computing while its page is built, before Bokeh has made the page's session: the
    worker's callbacks added meanwhile were lost or ran out of order (the last design's among them, and the tab
    said "computing" for ever: one link in three when the designs were at hand). The worker starts on the
    session's first tick; once the session is live, at once. A link's sweep too."""
    import threading
    import types

    import camsim_explorer.compare as module

    # shared designs of this test's own: a design another test's page still held (until the garbage collector
    # came) was shown at once, with nothing to compute
    monkeypatch.setattr(module, "SHARED_DESIGNS", module.SharedDesigns())

    class Doc:
        def __init__(self, session):
            self.session_context = types.SimpleNamespace(session=session)
            self.ticks = []

        def add_next_tick_callback(self, fn):
            self.ticks.append(fn)

    entries = _pinned_entries("human-cones")
    for session in (None, object()):
        view = CompareView(ExplorerState(start=False))
        started = threading.Event()
        monkeypatch.setattr(view, "_compute", lambda *args: started.set())
        view._doc = doc = Doc(session)
        view.state.pinned = entries  # refresh: one design to compute
        if session is None:
            assert not started.wait(0.2) and len(doc.ticks) == 1
            doc.ticks.pop()()  # the session's first tick
        assert started.wait(30)
        swept = threading.Event()  # a link's sweep, the same way
        monkeypatch.setattr(view, "_sweep_work", lambda *args: swept.set())
        view.state.sweep = {"parameter": "noise_sigma", "values": [0.0, 1.0]}  # starts it
        if session is None:
            assert not swept.wait(0.2) and len(doc.ticks) == 1
            doc.ticks.pop()()
        assert swept.wait(30)


def test_a_pinned_design_is_shown_before_its_image_quality_measures_which_follow(counted, engine, monkeypatch):
    """A pin showed nothing until the design's image-quality measures were done: SSIM, PSNR and a chart's
    MTF50 are 0.3-0.7 s a design, more than the rest of a design pinned as it is shown (a pin took 1.5-2 s,
    its goal is 1 s). The design is shown once scored, its table cells say "measuring..." and fill in with
    the engine's numbers when measured; a design is offered to other pages only once measured."""
    import camsim_core.review.design as design
    import camsim_explorer.compare as module

    events, seen = [], {}
    view = CompareView(ExplorerState(start=False))
    # what the worker hands the page's event loop is run when the test says (the worker runs here)
    monkeypatch.setattr(view, "_schedule", lambda fn: events.append(("tick", fn)))
    real = design.quality_measures

    def measuring(*args):
        # the page's event loop runs what the worker handed it while the worker measures
        for kind, fn in events:
            fn()
        seen.update(status=json.loads(view.status.object), table=view.table.object,
                    shared=len(module.SHARED_DESIGNS))
        events[:] = [("measure", None)]
        return real(*args)

    monkeypatch.setattr(design, "quality_measures", measuring)
    view.state.pinned = _pinned_entries("human-cones")
    assert [d["name"] for d in seen["status"]["designs"]][-1] == "human-cones" and seen["status"]["busy"] is False
    assert seen["status"]["measuring"] == ["human-cones"]  # shown before measured
    assert 'data-measure="ssim"' in seen["table"] and "measuring..." in seen["table"]
    assert seen["shared"] == 0  # not yet offered to other pages
    assert [kind for kind, _ in events] == ["measure", "tick"]  # measured, then shown again
    events[1][1]()
    status = json.loads(view.status.object)
    assert status["measuring"] == [] and "measuring..." not in view.table.object
    cones = engine["cones"].quality  # the engine's numbers, as for the design alone
    assert f'data-value="{cones["ssim"]!r}"' in view.table.object and f'data-value="{cones["psnr_db"]!r}"' in view.table.object
    assert len(module.SHARED_DESIGNS) == 1 and counted == ["human-cones"]



def test_pinning_the_live_design_keeps_every_design_in_its_place(monkeypatch):
    """The live design was shown first, so each pin shifted every design by one slot and the tab sent every
    design's two images again (8 images, ~9 MB, at the fourth pin of a frame-sized chart). A design keeps its
    slot, the live design pinned stays where it was, and the tab's order (table, status) is the slots' order."""
    import camsim_explorer.compare as module

    # shared designs of this test's own: the same design held by another test's page (until the garbage
    # collector came) was shown in place of the live design's own images
    monkeypatch.setattr(module, "SHARED_DESIGNS", module.SharedDesigns())
    state = ExplorerState()
    view = CompareView(state)
    view.pin("DCS-200")
    state.camera = "human-cones"

    def images():  # design name -> (rendered image, dE map) its slot holds, in the page's order
        return {r.figure.title.text.rpartition(":")[0]: (r.source.data["image"][0], d.source.data["image"][0])
                for r, d, slot in zip(view.render_views, view.de_views, view.slots) if slot.visible}

    before = images()
    assert list(before) == ["DCS-200", "live"]
    view.pin("cones")  # the live design, pinned: shown as "cones" where it was
    after = images()
    assert list(after) == ["DCS-200", "cones"] == [r.name for r in view.designs()]
    assert all(a is b for a, b in zip(after["DCS-200"], before["DCS-200"]))
    assert all(a is b for a, b in zip(after["cones"], before["live"]))  # nothing sent again
    state.noise_sigma = 2.0  # a new live design: the first free slot, after the pinned ones
    assert list(images()) == ["DCS-200", "cones", "live"]
    assert [d["name"] for d in json.loads(view.status.object)["designs"]] == ["DCS-200", "cones", "live"]


def test_the_first_a_b_pair_is_of_one_geometry_when_there_is_one():
    """The designs are listed in their places, the live design after the pinned ones: with a camera of another
    pixel count pinned second, the first A/B pair (the first two designs) could not be compared ("A/B not
    available") although the first design and the live one could."""
    state = ExplorerState()
    view = CompareView(state)
    view.pin("dcs")
    state.camera = "imx174"  # another sensor: another pixel count
    view.pin("imx")
    state.camera = "human-cones"
    names = [r.name for r in view.designs()]
    shapes = {r.name: r.shape for r in view.designs()}
    assert names == ["dcs", "imx", "live"] and shapes["imx"] != shapes["dcs"] == shapes["live"]
    assert (view.a_select.value, view.b_select.value) == ("dcs", "live")
    assert view.ab is not None and json.loads(view.status.object)["ab"]["b"] == "live"
    view.b_select.value = "imx"  # the student's own pair is kept, and told why it cannot be shown
    state.noise_sigma = 1.0
    assert (view.a_select.value, view.b_select.value) == ("dcs", "imx")
    assert "not available" in view.ab_text.object


def test_a_design_slot_joins_the_page_when_a_design_first_takes_it(monkeypatch):
    """The tab's five design slots were all on the page from the first pin, the free ones hidden: the browser
    built, laid out and drew their figures all the same (8 of the tab's 14 figures at the first pin). A slot
    joins the page when a design first takes it, and stays (hidden when free) so that no design moves."""
    import camsim_explorer.compare as module

    monkeypatch.setattr(module, "SHARED_DESIGNS", module.SharedDesigns())
    state = ExplorerState()
    view = CompareView(state)
    view.pin("DCS-200")  # the live design, pinned: one design, one slot
    assert view.slot_row.objects == view.slots[:1]
    assert view.ab_row.objects == []  # one design: no A/B difference, no empty frames for it
    state.camera = "human-cones"  # a live design beside it: a second slot
    assert view.slot_row.objects == view.slots[:2] and [s.visible for s in view.slots[:2]] == [True, True]
    assert view.ab_row.objects == [v.pane for v in view.ab_views]  # two designs: their difference, shown
    view.pin("cones")
    state.noise_sigma = 2.0
    assert view.slot_row.objects == view.slots[:3]
    view.unpin("DCS-200")
    assert view.slot_row.objects == view.slots[:3]  # the freed slot stays on the page, hidden
    assert [s.visible for s in view.slots[:3]] == [False, True, True]


def test_pinned_designs_are_computed_on_the_scene_under_the_light_level_in_force():
    """The light level is the scene's: a pinned design kept its light-1 dE (12.15) under a light of 0.25 (14.07
    by the engine), hid the live design as equal to it, gave its light-1 result to another session at 0.25, and
    its report said "light 1". Checked against the engine's own evaluation of each design at each level."""
    at = {light: evaluate_design({"light": light}, "A") for light in (1.0, 0.25)}
    assert at[1.0].measures["cielab"]["mean"] != pytest.approx(at[0.25].measures["cielab"]["mean"], rel=0.01)
    state = ExplorerState()
    view = CompareView(state)
    view.pin("A")
    state.light = 0.25
    (a,) = json.loads(view.status.object)["designs"]
    assert a["name"] == "A" and a["measures"] == at[0.25].measures
    assert view.designs()[0].params["light"] == 0.25  # what the report lists
    other = ExplorerState(light=0.25)  # another page, at the same level: computes A there, not the level-1 A
    view2 = CompareView(other)
    other.pinned = [{"name": "A", "params": state.pinned[0]["params"]}]
    (a2,) = json.loads(view2.status.object)["designs"]
    assert a2["measures"] == at[0.25].measures
    state.light = 1.0  # and back
    assert json.loads(view.status.object)["designs"][0]["measures"] == at[1.0].measures


@pytest.mark.parametrize("metric", ["S-CIELAB", "CIELAB"])
def test_the_live_design_stays_in_the_comparison_whatever_map_the_page_shows(metric):
    """On the Compare tab the live design is scored by both maps: in S-CIELAB it had no CIELAB map and left the
    comparison, its histogram and its report without a word; in CIELAB its S-CIELAB cells read "n/a"."""
    state = ExplorerState(metric=metric)
    view = CompareView(state)
    state.tab = "compare"  # as the page sets it when the tab is opened
    view.pin("A")
    state.noise_sigma = 4.0  # the live design now differs from A
    alone = evaluate_design(state.design_params(), "live")
    status = json.loads(view.status.object)
    designs = {d["name"]: d for d in status["designs"]}
    assert sorted(designs) == ["A", "live"]
    live = designs["live"]
    assert live["measures"]["cielab"] == alone.measures["cielab"]
    assert live["measures"]["scielab"] == alone.measures["scielab"]
    assert status["hist_curves"] == 2
    assert "live" in view.report_bytes().getvalue().decode()
    state.tab = "results"  # off the Compare tab a change makes the page's map alone (the other costs 1.6x a change)
    state.noise_sigma = 5.0
    assert (state.result.scielab is None) == (metric == "CIELAB") and (state.result.delta_e is None) == (metric != "CIELAB")
    state.tab = "compare"  # back: the map it lacks is made, and the live design is compared again
    assert state.result.scielab is not None and state.result.delta_e is not None
    assert "live" in [d["name"] for d in json.loads(view.status.object)["designs"]]


def test_the_report_draws_each_metrics_maps_on_the_scale_the_page_shows_them():
    """The report put every design's CIELAB and S-CIELAB maps on one scale over both (140 for a design the page
    showed on 90), and its A/B map on the designs' scale where the page draws it on its own; neither said so."""
    import html as html_module
    import re

    state = ExplorerState(exposure=0.4)  # 4x: large errors, where S-CIELAB's top is above CIELAB's
    view = CompareView(state)
    view.pin("DCS-200")
    state.camera = "human-cones"
    view.pin("cones")
    page_tops = {}
    for metric in ("CIELAB", "S-CIELAB"):
        state.metric = metric
        status = json.loads(view.status.object)
        page_tops[metric] = status["scale_top"]
        # the rule, computed here: the largest of the designs' 99th percentiles, rounded up to 5 (at least 5)
        maps = [r.delta_e if metric == "CIELAB" else r.scielab for r in view.designs()]
        expected = max(5.0, 5.0 * np.ceil(max(float(np.percentile(m, 99)) for m in maps) / 5.0))
        assert status["scale_top"] == expected
        assert all(v.figure.title.text.endswith(f" dE, 0 to {status['scale_top']:g}")
                   for v, slot in zip(view.de_views, view.slots) if slot.visible)
        text = view.report_bytes().getvalue().decode()
        data = json.loads(html_module.unescape(re.search(
            r'<script type="application/json" id="camsim-report-data">(.*?)</script>', text, re.S).group(1)))
        assert data["scale_tops"][metric] == page_tops[metric]
    assert page_tops["S-CIELAB"] != page_tops["CIELAB"]
    assert f"CIELAB dE map (0 to {page_tops['CIELAB']:g})" in text
    assert f"S-CIELAB dE map (0 to {page_tops['S-CIELAB']:g})" in text


def test_designs_record_the_light_they_were_computed_under_when_it_changes_meanwhile(monkeypatch):
    """The light moved while a design computed (the tab hidden, its refresh held): the designs after it were
    computed on the scene under the old level but recorded the new one, and shown at the old level as such."""
    import camsim_explorer.compare as module
    from camsim_explorer.shown import WhenShown

    state = ExplorerState()
    gate = WhenShown(shown=True)
    view = CompareView(state, when_shown=gate)
    real, calls = module.evaluate_design, []

    def evaluate(params, name, **kw):
        calls.append((name, params["light"]))
        if len(calls) == 1:  # while A computes: the student leaves the tab and moves the light
            gate.show(False)
            state.light = 0.25
        return real(params, name, **kw)

    monkeypatch.setattr(module, "evaluate_design", evaluate)
    base = state.design_params()
    state.pinned = [{"name": "A", "params": dict(base, noise_sigma=3.0)}, {"name": "B", "params": dict(base, noise_sigma=5.0)}]
    assert calls == [("A", 1.0), ("B", 1.0)]
    for key, result in view.store._items.items():
        assert result.params["light"] == key[0][2] == 1.0


def test_a_black_or_clipped_design_carries_its_warning_into_the_table_and_the_report():
    """Pinned at 0.1 s, 10 s and 1e-4 s, the DCS-200 was listed at 12.15, 77.15 and 67.44 with no word: a frame that
    recorded nothing ranked better than a clipped one. The Results tab's warnings go with the scores. The flags are
    checked against the raw data: its share of pixels at the full scale, and at 0."""
    import camsim_core as cs

    state = ExplorerState()
    view = CompareView(state)
    for name, exposure in (("ok", 0.1), ("over", 10.0), ("black", 1e-4)):
        state.exposure = exposure
        view.pin(name)
    status = {d["name"]: d for d in json.loads(view.status.object)["designs"]}
    for name, exposure in (("ok", 0.1), ("over", 10.0), ("black", 1e-4)):
        raw = cs.simulate(cs.load_scene("cacaphony290"), cs.review.camera_from_params(dict(state.design_params(),
                                                                                          exposure=exposure)))
        data = np.asarray(raw.data)
        clipped, black = float(np.mean(data >= 254.5)), float(np.mean(data <= 0.5))
        flags = " ".join(status[name]["flags"])
        assert ("clipped" in flags) == (clipped > 0.5) and (("black" in flags) or ("empty" in flags)) == (black > 0.5), \
            (name, flags, clipped, black)
    assert "clipped" in view.table.object and 'data-measure="exposure"' in view.table.object
    page = view.report_bytes().getvalue().decode()
    assert page.count('class="flag"') == len(status["over"]["flags"]) + len(status["black"]["flags"])


def test_a_sweep_of_the_scene_before_is_dropped_when_the_light_changes():
    """The sweep's points stayed at the old light level while the designs were computed at the new one, and the
    report mixed them; they are dropped, said so, and a new run computes them at the new level."""
    state = ExplorerState()
    view = CompareView(state)
    view.pin("A")
    state.sweep = {"parameter": "noise_sigma", "values": [0.0, 4.0]}
    assert len(view.points) == 2
    state.light = 0.5
    assert view.points == [] and "run it again" in view.sweep_message.object
    import html as html_module
    import re

    text = view.report_bytes().getvalue().decode()
    data = json.loads(html_module.unescape(re.search(
        r'<script type="application/json" id="camsim-report-data">(.*?)</script>', text, re.S).group(1)))
    assert "sweep" not in data  # no points of the old light beside designs of the new
    view.start_sweep()
    at_half = evaluate_design(dict(state.pinned[0]["params"], light=0.5, noise_sigma=4.0), "A")
    point = next(p for p in view.points if p.value == 4.0)
    assert point.measures["cielab"] == at_half.measures["cielab"]
