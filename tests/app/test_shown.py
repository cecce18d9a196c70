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
