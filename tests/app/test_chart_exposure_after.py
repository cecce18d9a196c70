"""A scene picked after a chart gets the exposure that was in force before the chart.

A chart picked in the scene list is exposed for itself (its brightest 0.5 % at 80 % of full scale: 0.80 s on
the default camera for the Macbeth chart, 1.21 s for the slanted edge on gaussian-3, against the preset's
0.1 s). That exposure stayed when a student went back to a photo: the default scene then came out with 69.5 %
of its pixels clipped and a mean dE of 67.9 instead of 12.2, and nothing said why. Checked against a page that
never saw a chart (same parameters, so the same raw and dE), with the engine's own clipped share.
"""

import numpy as np
import pytest

from camsim_explorer.state import ExplorerState
from served_state import served, settle


def _state(with_runner):
    state = ExplorerState(start=False)
    if not with_runner:
        state.recompute()
        return state, lambda: None
    outcomes = served(state)
    state.recompute()
    settle(state, outcomes)
    return state, lambda: settle(state, outcomes)


@pytest.fixture(scope="module")
def never_saw_a_chart():
    state = ExplorerState(start=False)
    state.recompute()
    return state


@pytest.mark.parametrize("with_runner", [False, True], ids=["in the watcher", "in the computing thread"])
def test_a_photo_after_charts_gets_the_exposure_from_before_them(never_saw_a_chart, with_runner):
    state, done = _state(with_runner)
    before = state.exposure
    state.scene = "macbeth"
    done()
    assert state.scene.startswith("macbeth:") and state.exposure > 2 * before  # exposed for the chart
    state.scene = "slanted-edge"  # chart to chart: each exposed for itself
    done()
    assert state.scene.startswith("slanted-edge:") and state.exposure != before
    state.scene = "cacaphony290"
    done()
    assert state.exposure == before == never_saw_a_chart.exposure
    assert state.result.camera.exposure == before
    np.testing.assert_array_equal(state.result.raw.data, never_saw_a_chart.result.raw.data)
    assert float(np.mean(state.result.delta_e)) == pytest.approx(float(np.mean(never_saw_a_chart.result.delta_e)))
    assert state.result.exposure.clipped < 0.01 and state.result.exposure.flags == ()
    assert f"Exposure {before:.4g} s again, as before the chart" in state.notice, state.notice


def test_an_exposure_the_user_set_is_kept():
    state, done = _state(with_runner=False)
    state.scene = "macbeth"
    state.exposure = 0.3  # set on the chart
    state.scene = "cacaphony290"
    assert state.exposure == 0.3 and "again" not in state.notice
    state.scene = "zone-plate"
    state.param.update(scene="photo-astronaut", exposure=0.2)  # set with the scene (a link, a parameters file)
    assert state.exposure == 0.2
    state.scene = "stripes"
    state.start_over()
    state.scene = "cacaphony290"
    assert state.exposure == 0.1  # the preset's, nothing left over from before Start over
