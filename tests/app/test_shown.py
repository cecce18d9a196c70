"""A hidden tab's views wait for the tab: their updates run once, with the newest design, when it is shown."""

import doctest

import camsim_explorer.shown as shown
from camsim_explorer.shown import WhenShown
from camsim_explorer.state import ExplorerState
from camsim_explorer.views import CameraView


def test_doctests():
    assert doctest.testmod(shown).failed == 0


def test_each_held_update_runs_once_and_in_the_order_given_when_shown():
    gate, calls = WhenShown(shown=False), []
    a, b = gate(lambda: calls.append("a")), gate(lambda: calls.append("b"))
    for _ in range(3):
        a(), b()
    assert calls == []
    gate.show(True)
    assert calls == ["a", "b"]
    a()
    assert calls[-1] == "a" and len(calls) == 3  # shown: at once
    gate.show(False)
    b()
    assert len(calls) == 3


def test_a_hidden_camera_tab_shows_the_camera_chosen_meanwhile_once_shown():
    state = ExplorerState(start=False)
    state.recompute()
    gate = WhenShown(shown=True)
    view = CameraView(state, gate)
    assert view.info.object.startswith("**kodak\\-dcs200\\-ir** ·")
    gate.show(False)
    state.camera = "human-cones"
    state.recompute()
    assert view.info.object.startswith("**kodak\\-dcs200\\-ir** ·")  # hidden: not redrawn
    gate.show(True)
    assert view.info.object.startswith("**human\\-cones** ·")


def test_a_callback_from_another_thread_is_added_to_the_page_on_the_event_loop():
    """``next_tick`` from a worker thread hands the call to the server's loop: Bokeh's ``add_next_tick_callback``
    made in the worker lost the callback when the loop's hold of the document ended at that moment (a link's
    pinned designs stayed "Computing..." for ever). Made on the loop, it is never concurrent with a hold."""
    import threading

    from tornado.ioloop import IOLoop

    added, ran, closed = [], threading.Event(), []

    class Doc:
        def __init__(self, open_=True):
            self.open = open_

        def add_next_tick_callback(self, fn):
            if not self.open:
                raise RuntimeError("Attempting to add session callback to already-destroyed Document")
            added.append(threading.get_ident())
            fn()

    ready = threading.Event()
    loops = {}

    def serve():
        import asyncio

        asyncio.set_event_loop(asyncio.new_event_loop())
        loop = IOLoop.current()
        loops["loop"], loops["thread"] = loop, threading.get_ident()
        shown.serve_on(loop)
        ready.set()
        loop.start()

    saved = dict(shown._SERVER)
    server = threading.Thread(target=serve, daemon=True)
    server.start()
    try:
        assert ready.wait(10)
        shown.next_tick(Doc(), ran.set)  # from this thread, not the loop's
        assert ran.wait(10)
        assert added == [loops["thread"]] and loops["thread"] != threading.get_ident()
        done = threading.Event()
        shown.next_tick(Doc(open_=False), ran.set, lambda: (closed.append(True), done.set()))
        assert done.wait(10) and closed == [True]  # a closed page: told, nothing raised in the loop
    finally:
        loops["loop"].add_callback(loops["loop"].stop)
        server.join(10)
        shown._SERVER.update(saved)
