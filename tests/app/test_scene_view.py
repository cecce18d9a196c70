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


def test_a_wavelength_beyond_the_scene_is_put_on_its_nearest_band_and_said():
    """``?wavelength=5000`` (a typo for 500): the Scene tab showed the 700 nm band without a word, and the address
    and the status kept 5000. The first result says so and the state holds the band shown; the address changed in
    the page to another such value: the Scene tab says so."""
    state = ExplorerState(wavelength=5000.0)
    assert state.wavelength == 700.0 and state.result.params["wavelength"] == 700.0
    assert "Wavelength 5000 nm is outside the scene's 400-700 nm" in state.notice and "700 nm" in state.notice
    state.noise_sigma = 1.0  # said once
    assert "Wavelength" not in state.notice
    view = SceneView(state)
    state.wavelength = 250.0
    assert state.wavelength == 400.0 and view.wavelength.value == 0
    assert "Wavelength 250 nm is outside" in state.notice and ">Radiance at 400 nm," in view.plane_label.object
    state.wavelength = 405.0  # within half a band of 400: taken as it is, shown on the nearest band
    assert state.wavelength == 405.0 and "Wavelength 405" not in state.notice
