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
