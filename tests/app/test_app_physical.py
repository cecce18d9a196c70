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
    overlay = view.ptc.object
    assert len(overlay) == 3 and "system gain" in view.note.object
    state.f_stop = 16.0
    assert "f/16" in view.mtf.object.opts.get().kwargs["title"]
    state.camera = "kodak-dcs200-ir"
    assert "Gaussian model" in view.note.object
