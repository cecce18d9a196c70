"""The explorer's Optics & sensor view (no browser): parameters in their units, the MTF, photon transfer."""

import numpy as np
import pytest

pytest.importorskip("panel")

from camsim_explorer.physical import PhysicalView, mtf_curves, parameter_table  # noqa: E402
from camsim_explorer.state import ExplorerState  # noqa: E402


def test_mtf_curves_follow_the_f_number_and_blue_is_sharper():
    curves, nyquist = mtf_curves(2.8, 1.4e-6)
    assert nyquist == pytest.approx(1 / (2 * 1.4e-3))
    f, blue = curves[450.0]
    _, red = curves[650.0]
    assert blue[0] == red[0] == 1.0 and np.all(blue[1:-1] > red[1:-1])
    f16, _ = mtf_curves(16.0, 1.4e-6)
    assert f16[550.0][0][-1] < curves[550.0][0][-1] / 5  # the cutoff falls as 1 / N


def test_parameter_table_names_units():
    state = ExplorerState(camera="imx174", distance=3.32, exposure=0.005, f_stop=4.0)
    table = parameter_table(state.result.camera)
    for words in ("5.86 | um", "32,000 | e-", "e-/s", "0.5 | %", "DN/e-", "f-number | 4"):
        assert words in table


def test_view_draws_photon_transfer_for_an_electron_sensor_and_explains_otherwise():
    state = ExplorerState(camera="imx174", distance=3.32, exposure=0.005)
    view = PhysicalView(state)
    assert list(view.ptc_curves.shown()) == ["R", "G", "B"]
    assert "system gain" in view.note.object and view.ptc_box.visible
    from bokeh.document import Document

    root = view.mtf.get_root(Document())  # the MTF plot as the page has it: the same figure gets new data
    state.f_stop = 16.0
    titles = [m.title.text for m in root.references() if type(m).__name__ == "figure" and m.title is not None]
    assert any("f/16" in t for t in titles), titles
    state.camera = "kodak-dcs200-ir"
    assert "Gaussian model" in view.note.object
    assert not view.ptc_box.visible  # no empty plot labelled "y" for a camera in digital units


def test_the_photon_transfer_curve_is_made_off_the_loop_and_only_for_a_new_sensor(monkeypatch):
    """While the tab is shown, the curve of a new sensor is simulated in the computing thread with the result
    (ten flat fields: it held every page of the server when made in the result's watcher); a change that
    leaves the sensor as it was (the noise seed) simulates nothing, nor does a hidden tab."""
    import threading

    import camsim_explorer.physical as physical
    from camsim_explorer.shown import WhenShown
    from served_state import served, settle, threads_calling

    loop = threading.get_ident()
    made = threads_calling(monkeypatch, physical, "photon_transfer")
    state = ExplorerState(start=False, camera="imx174", distance=3.32, exposure=0.005)
    outcomes = served(state)
    gate = WhenShown(shown=True)
    view = PhysicalView(state, gate)
    state.recompute()
    settle(state, outcomes)
    assert made and loop not in made, made
    assert "system gain K" in view.note.object and list(view.ptc_curves.shown()) == ["R", "G", "B"]
    made.clear()
    state.seed = 7  # the same sensor: the same curve
    settle(state, outcomes)
    assert made == []
    gate.show(False)
    state.exposure = 0.01
    settle(state, outcomes)
    assert made == []  # hidden: nothing simulated
    gate.show(True)  # shown again, outside a served page here: simulated at once for the sensor in force
    assert made == [loop] and "system gain K" in view.note.object
