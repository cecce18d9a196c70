"""The explorer's Image quality view (no browser): its numbers are the engine's on the session's result."""

import numpy as np
import pytest

from camsim_core.metrics.report import measure_images

from camsim_explorer.quality import QualityView
from camsim_explorer.state import ExplorerState


def _engine(state, what):
    r = state.result
    return measure_images(what, raw=r.raw, demosaiced=r.demosaiced, rendered=r.rendered, ideal=r.ideal,
                          monitor=state.monitor)


def test_charts_are_in_the_scene_picker():
    objs = ExplorerState.param.scene.objects
    assert {"slanted-edge", "zone-plate", "uniform", "munsell"} <= set(objs)


def test_slanted_edge_shows_the_mtf():
    state = ExplorerState(scene="slanted-edge", distance=1.0)
    view = QualityView(state)
    assert state.message == ""
    expected = _engine(state, ("mtf",))["mtf"]["luminance"]["mtf50"]
    assert view.report["mtf"]["luminance"]["mtf50"] == pytest.approx(expected)
    assert 0.1 < expected < 0.6 and view.mtf.visible
    assert f"{expected:.3f}" in view.text.object


def test_uniform_shows_snr_and_macbeth_the_patch_table():
    state = ExplorerState(scene="uniform", distance=1.0, noise_sigma=2.0)
    view = QualityView(state)
    assert "SNR" in view.text.object and not view.mtf.visible
    assert view.report["snr"]["channels"]["G"]["sigma"] == pytest.approx(2.0, rel=0.15)
    state.scene = "macbeth"
    assert "CIEDE2000 per patch" in view.text.object and len(view.report["color"]["per_patch"]) == 24


def test_default_scene_gets_similarity_and_a_hint():
    state = ExplorerState()
    view = QualityView(state)
    s = view.report["similarity"]
    assert np.isfinite(s["psnr_db"]) and 0 < s["ssim"] < 1
    assert "slanted-edge" in view.text.object


def test_a_shown_tab_measures_in_the_computing_thread_and_a_hidden_one_not_at_all(monkeypatch):
    """The measures of a new result are made with the result, in the session's computing thread, while the tab
    is shown; the event loop (here the test's thread, as in test_chart_fit_off_loop) only shows them. A hidden
    tab measures nothing until it is shown."""
    import threading

    import camsim_explorer.quality as quality
    from camsim_explorer.shown import WhenShown
    from served_state import served, settle, threads_calling

    loop = threading.get_ident()
    measured = threads_calling(monkeypatch, quality, "measure_images")
    state = ExplorerState(start=False)
    outcomes = served(state)

    gate = WhenShown(shown=True)
    view = QualityView(state, gate)
    state.recompute()
    settle(state, outcomes)
    assert measured and loop not in measured, measured
    assert view.report["similarity"] == pytest.approx(_engine(state, ("similarity",))["similarity"])
    measured.clear()
    gate.show(False)
    state.noise_sigma = 3.0
    settle(state, outcomes)
    assert measured == []  # nobody looks: nothing measured
    gate.show(True)  # opened again: its numbers follow the result shown, measured now (on the loop)
    assert measured == [loop]
    assert view.report["similarity"] == pytest.approx(_engine(state, ("similarity",))["similarity"])


def test_the_mtf_plot_follows_each_result_drawn_in_place():
    """Every result is drawn in place, as new data for the same Bokeh figure (title included); another set
    of curves (a camera with other sensors) is shown in that figure too, the legend naming only them."""
    from bokeh.document import Document

    def figure_titles(root):
        return [m.title.text for m in root.references() if type(m).__name__ == "figure" and m.title is not None]

    state = ExplorerState(scene="slanted-edge", distance=1.0)
    view = QualityView(state)
    root = view.mtf_plot.get_root(Document())
    first = view.report["mtf"]["luminance"]["mtf50"]
    assert any(f"{first:.3f}" in t for t in figure_titles(root)), figure_titles(root)
    state.f_stop = 16.0  # diffraction: a lower MTF50, the same curves
    second = view.report["mtf"]["luminance"]["mtf50"]
    assert f"{second:.3f}" != f"{first:.3f}"
    assert any(f"{second:.3f}" in t for t in figure_titles(root)), figure_titles(root)
    state.camera = "human-cones"  # L, M, S sensors: other curves
    curves = set(view.report["mtf"])
    assert curves != {"R", "G", "B", "luminance"}
    items = [m for m in root.references() if type(m).__name__ == "LegendItem"]
    labels = {m.label["value"] for m in items if m.visible and all(r.visible for r in m.renderers)}
    assert labels == curves, (curves, labels)
    assert view.curves.shown()["luminance"] == "black"



def test_a_chart_too_small_to_measure_is_not_met_with_pick_that_chart():
    """Under a slanted edge made too small by its options (512 x 64 samples: 39 x 5 pixels), the tab said why
    and then "Pick the slanted-edge chart for the MTF", the chart already picked."""
    from camsim_explorer.quality import QualityView
    from camsim_explorer.state import ExplorerState

    state = ExplorerState(start=False)
    state.scene = "slanted-edge"
    state.set_chart("size=512x64")
    assert state.result.raw.data.shape == (39, 5)
    view = QualityView(state)
    view.update()
    text = view.text.object
    assert "Not measured" in text and "at least 16 x 16 pixels" in text
    assert "Pick the **slanted-edge** chart" not in text
    assert "Picked from the scene list, the **slanted-edge** chart is sized to the camera's frame" in text


def test_measures_of_a_badly_exposed_frame_carry_the_exposure_flags():
    """A clipped slanted edge's MTF50 read 0.74 cycles/pixel against 0.39 unclipped (diffraction and the pixel:
    0.40), shown plainly on this tab while the Results tab flagged the frame."""
    from camsim_explorer.quality import QualityView
    from camsim_explorer.state import ExplorerState

    state = ExplorerState(start=False)
    state.param.update(camera="human-cones", optics="diffraction", f_stop=11)
    state.scene = "slanted-edge"  # exposed for itself
    view = QualityView(state)
    view.update()
    assert "Exposure" not in view.text.object and state.result.exposure.flags == ()
    assert view.report["mtf"]["luminance"]["mtf50"] == pytest.approx(0.398, abs=0.02)  # theory x pixel, 0.398
    state.exposure = 2 * state.exposure
    view.update()
    assert state.result.exposure.clipped > 0.3
    assert view.text.object.startswith("⚠ **Exposure**: clipped") and "not the camera" in view.text.object


def test_an_unquantized_electron_level_snr_at_the_full_well_is_marked_saturated():
    """imx174 at 0 bits on the uniform field, 1 s: its green pixels at the full well read 72.8 dB, unmarked (the
    mark came from the ADC's full scale, which an unquantized raw has none of); at 12 bits the same is marked."""
    from camsim_explorer.quality import QualityView
    from camsim_explorer.state import ExplorerState

    state = ExplorerState(start=False)
    state.param.update(camera="imx174", bits=0)
    state.scene = "uniform"
    state.exposure = 1.0
    view = QualityView(state)
    view.update()
    green = view.report["snr"]["channels"]["G"]
    assert green["saturated"] and green["mean"] > 4000
    assert "(saturated)" in view.text.object


def test_the_snr_of_an_electron_level_camera_is_its_noise_not_the_lens_fall_off():
    """imx174 on the uniform chart (auto exposure, 12 bits): the SNR's sigma took in the optics' cos^4 fall-off
    over the central region (8 % from its middle to its sides): 81.9 DU, 31.7 dB at every exposure. With the
    shading removed it is the sensor's noise: shot noise of the electrons (dark current's among them), read
    noise, DSNU and PRNU at the system gain, and the ADC's rounding, computed here from the camera's sheet."""
    from camsim_explorer.quality import QualityView
    from camsim_explorer.state import ExplorerState

    state = ExplorerState(start=False)
    state.param.update(camera="imx174", bits=12)
    state.scene = "uniform"
    view = QualityView(state)
    view.update()
    cam = state.result.camera
    gain = cam.analog_gain / cam.electrons_per_dn  # DN per electron
    for name in ("R", "G", "B"):
        measured = view.report["snr"]["channels"][name]
        electrons = (measured["mean"] - float(np.max(cam.black_level))) / gain
        sigma = np.sqrt(gain ** 2 * (electrons + cam.read_noise ** 2 + cam.dsnu ** 2 + (cam.prnu * electrons) ** 2)
                        + 1 / 12)
        assert measured["sigma"] == pytest.approx(sigma, rel=0.03), (name, measured, sigma)
    assert "shading (lens fall-off) removed" in view.text.object


def test_the_experiments_alpha_axis_is_the_mixtures_range_whatever_was_run():
    """One alpha run (1, or 0.0001) drew an axis from 0 to 2, or -1 to 1: alphas no mixture has."""
    from camsim_explorer.experiments import ExperimentsView

    view = ExperimentsView(run=None)  # shown a run's records directly
    view._show([{"alpha": 1.0, "sigma": 0.0, "baseline": 3.0, "illuminant": 2.0}], None)
    for plot in view.curves.values():
        assert (plot.figure.x_range.start, plot.figure.x_range.end) == (-0.05, 1.05)
        assert plot.figure.title.text.endswith("rendering")
    assert view.message.object.startswith("Done: 1 configuration (")


def test_the_experiments_legend_covers_no_point():
    """Eight sigmas' names sat in the plot's top-left corner, over the points at alpha 0 (where a high sigma's dE
    is highest on the left): the legend is under the plotting area, every sigma named."""
    from camsim_explorer.experiments import ExperimentsView

    view = ExperimentsView(run=None)
    sigmas = [0, 0.5, 1, 2, 3, 5, 8, 12]
    view._show([{"alpha": a, "sigma": s, "baseline": 10 * a + s, "illuminant": 2 * a + s}
                for a in (0.0, 0.5, 1.0) for s in sigmas], None)
    for plot in view.curves.values():
        fig = plot.figure
        assert plot.legend in fig.below and plot.legend not in fig.center
        assert [item.label["value"] for item in plot.legend.items if item.visible] == [f"sigma {s:g}" for s in sigmas]
