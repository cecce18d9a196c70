"""Auto exposure puts the scene's bright end at the target of what the sensor can record.

For an electron-level camera that is the lower of the ADC's full scale and the full well (in
digital units, through the conversion gain and the analog gain): a 16-bit imx174 (full well
32,000 e- at 7.8 e-/DN, so 4,095 DN of 65,535) was exposed for 90 % of 65,535 and recorded a flat,
saturated field, on which no measure could find the slanted edge.
"""

import numpy as np
import pytest

from camsim_core import auto_exposure, load_camera, load_scene, simulate


def _top(raw, camera):
    """The brightest channel's 99.5th percentile above black, in DN (the quantity auto exposure sets)."""
    data = np.asarray(raw.data, float) - float(camera.black_level)
    return float(np.percentile(data, 99.5))


@pytest.mark.parametrize("bits, full_well, gain", [(16, 32000.0, 1.0), (12, 32000.0, 1.0), (12, 8000.0, 1.0),
                                                   (12, 32000.0, 4.0), (8, 32000.0, 1.0)])
def test_an_electron_level_camera_is_exposed_below_its_saturation(bits, full_well, gain):
    camera = load_camera("imx174").replace(height=120, width=160, bits=bits, full_well=full_well, analog_gain=gain,
                                           read_noise=0.0, dsnu=0.0, prnu=0.0, dark_current=0.0)
    scene = load_scene("macbeth")
    raw = simulate(scene, camera, exposure=auto_exposure(scene, camera), seed=3)
    k = gain / camera.electrons_per_dn  # DN per electron
    ceiling = min(2.0**bits - 1, full_well * k)  # the full scale, or the full well, whichever comes first
    assert _top(raw, camera) == pytest.approx(0.9 * ceiling, rel=0.06)  # shot noise and resampling: a few %
    assert float(np.max(raw.data)) < ceiling  # nothing clipped


def test_a_camera_in_digital_units_still_fills_its_full_scale():
    camera = load_camera("kodak-dcs200")
    scene = load_scene("macbeth")
    raw = simulate(scene, camera, exposure=auto_exposure(scene, camera))
    assert float(raw.data.max()) / 255 == pytest.approx(0.9, abs=0.01)
