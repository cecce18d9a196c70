"""The Scene tab shows the scene under the light level in force (``camsim_explorer.views.SceneView``).

A light level changed after the tab was drawn left its radiance plane, grey scale, clicked spectra and facts at
the old level (they followed the scene and the wavelength only), until the wavelength slider moved; opened after
the change, the tab showed the new level: what it showed depended on the order of a student's moves. Checked
against the scene's own radiance times the light level.
"""

import numpy as np
import pytest

from camsim_explorer.state import ExplorerState
from camsim_explorer.views import SceneView


def test_the_scene_tab_follows_the_light_level_and_keeps_the_clicked_spectra():
    state = ExplorerState(start=False)
    view = SceneView(state)
    base = state.scene_object().data
    k = int(np.argmin(np.abs(np.asarray(state.scene_object().wavelengths, float) - state.wavelength)))
    view.on_tap(10.5, 20.5)  # a pixel (x right, y up)
    h = base.shape[0]
    row, col = h - 1 - 20, 10
    np.testing.assert_allclose(view.curves.data["ys"][0], base[row, col], rtol=1e-6)
    state.light = 2.0
    np.testing.assert_allclose(view.plane_source.data["image"][0], base[::-1, :, k] * 2.0, rtol=1e-5)
    top = float(np.percentile(np.asarray(base[:, :, k], np.float32) * 2.0, 99.5))
    assert f"grey 0 to {top:.3g} (99.5th pct)" in view.plane_label.object
    assert len(view.curves.data["ys"]) == 1  # the spectrum clicked stays, read at the new level
    np.testing.assert_allclose(view.curves.data["ys"][0], base[row, col] * 2.0, rtol=1e-5)
    assert "x2 light" in view.meta.object
    state.scene = "macbeth"  # another scene: its own spectra
    assert view.curves.data["ys"] == []
