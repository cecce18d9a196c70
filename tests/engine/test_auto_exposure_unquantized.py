"""Auto exposure of an unquantized electron-level camera aims at its full well, as the explorer reads it.

Unquantized (0 bits), an electron-level camera's range ends at its full well
(:func:`camsim_core.simulation.electrons.full_well_level`: K x full well, imx174's 4,095 DN at its 12-bit
conversion), which the exposure measures and the explorer's ``full_scale`` read as the top. Auto exposure
aimed at 255 instead: imx174 on the uniform field at 0.00237 s where 8 and 12 bits give 0.0380 s (16 x),
the raw's 99.5th percentile at 6 % of the full well, SNR 10 dB below 8 bits', and macbeth flagged
"under-exposed" right after it. A camera in digital units (the chapter's, no full well) keeps 255.
"""

import json

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.datasets import asset_path
from camsim_core.metrics.exposure import exposure_measures
from camsim_core.metrics.report import quality_report
from camsim_core.review import camera_from_params
from camsim_core.simulation.exposure import recordable_level

PHYSICAL = ("imx174", "phone-1.4um")
#: A uniform field over about 257 x 257 imx174 pixels at 1 m; the Macbeth chart as shipped.
SCENES = ("uniform:size=32,angular_resolution=4.5", "macbeth")


def _camera(name, bits):
    """The explorer's camera (its parameters at the scenes' 1 m and the sheet's f-number)."""
    return camera_from_params(dict(camera=name, bits=bits, distance=1.0, f_stop=cs.load_camera(name).f_stop))


def _full_well_level(camera):
    """K x full well, DN: the full well (e-) over the conversion (e-/DN) times the analog gain, by hand."""
    return camera.full_well * camera.analog_gain / camera.electrons_per_dn


@pytest.mark.parametrize("scene_name", SCENES)
@pytest.mark.parametrize("name", PHYSICAL)
@pytest.mark.parametrize("target", [0.9, 0.5])
def test_unquantized_auto_exposure_reaches_the_target_of_the_full_well(name, scene_name, target):
    scene = cs.load_scene(scene_name)
    cam = _camera(name, 0)
    assert cam.bits is None
    level = _full_well_level(cam)
    sheet = json.loads((asset_path("sensors") / f"{name}.json").read_text())
    assert level == pytest.approx(2 ** sheet["bits"] - 1, rel=1e-9)  # the sheet's ADC spans its full well
    raw = cs.simulate(scene, cam.replace(exposure=cs.auto_exposure(scene, cam, target=target)))
    # the brightest 0.5 % of the raw (noise, the lens's fall-off and the resampling within a few %)
    assert np.percentile(raw.data, 99.5) == pytest.approx(target * level, rel=0.06)


@pytest.mark.parametrize("scene_name", SCENES)
@pytest.mark.parametrize("name", PHYSICAL)
def test_unquantized_auto_exposure_is_the_quantized_one(name, scene_name):
    """0 bits exposes as 12 and 8 bits do (their ADCs span the full well), and measures alike after it."""
    scene = cs.load_scene(scene_name)
    times = {bits: cs.auto_exposure(scene, _camera(name, bits)) for bits in (0, 8, 12)}
    assert times[0] == pytest.approx(times[12], rel=0.01)
    assert times[0] == pytest.approx(times[8], rel=0.01)
    signals = {}
    for bits in (0, 12):
        cam = _camera(name, bits).replace(exposure=times[bits])
        measures = exposure_measures(cs.simulate(scene, cam), cam)
        assert not any("under-exposed" in f for f in measures.flags), measures.flags
        signals[bits] = measures.signal
    assert signals[0] == pytest.approx(signals[12], rel=0.02)


@pytest.mark.parametrize("name", PHYSICAL)
def test_unquantized_snr_after_auto_exposure_is_the_quantized_one(name):
    """imx174 on the uniform field read 30.9 dB at 0 bits after auto exposure, 41.3 dB at 8 bits."""
    scene = cs.load_scene(SCENES[0])
    snr = {}
    for bits in (0, 8, 12):
        cam = _camera(name, bits)
        cam = cam.replace(exposure=cs.auto_exposure(scene, cam))
        snr[bits] = quality_report(scene, cam, ("snr",))["snr"]["channels"]["G"]["snr_db"]
    assert snr[0] == pytest.approx(snr[12], abs=0.3)
    assert snr[0] == pytest.approx(snr[8], abs=0.6)  # 8 bits adds its quantization noise


@pytest.mark.parametrize("name", ["kodak-dcs200", "kodak-dcs200-ir"])
def test_unquantized_chapter_camera_still_aims_at_255(name):
    """A camera in digital units has no full well: unquantized, auto exposure keeps the engine's 255."""
    scene = cs.load_scene("macbeth")
    cam = cs.load_camera(name)
    flat = cam.replace(bits=None)
    assert recordable_level(flat) == 255.0
    assert cs.auto_exposure(scene, flat) == cs.auto_exposure(scene, cam.replace(bits=8))
    raw = cs.simulate(scene, flat.replace(exposure=cs.auto_exposure(scene, flat), noise_sigma=0.0))
    assert float(np.max(raw.data)) / 255 == pytest.approx(0.9, abs=0.01)


@pytest.mark.parametrize("name", ["imx174", "phone-1.4um"])
@pytest.mark.parametrize("distance", [3.32, 0.3, 0.1])
def test_auto_exposure_counts_the_lens_working_f_number_at_close_focus(name, distance):
    """A lens focused at distance d passes 1 / (1 + m)^2 of the light its f-number says (m = f / (d - f)); auto
    exposure left it out, and imx174 focused at 0.1 m reached 70 % of its range for the 90 % it promised. The
    centre of a uniform field (cos^4 = 1 there) must sit at the target of the full well's level, from the sheet."""
    from camsim_core.camera.physical import with_settings

    scene = cs.load_scene("uniform")
    cam = with_settings(cs.load_camera(name), distance=distance)
    raw = cs.simulate(scene, cam, exposure=cs.auto_exposure(scene, cam, target=0.9), distance=distance, seed=0)
    data = np.asarray(raw.data, float) - float(np.max(np.asarray(raw.black_level, float)))
    h, w = data.shape
    block = data[h // 2 - 16 : h // 2 + 16, w // 2 - 16 : w // 2 + 16]
    centre = max(block[i::2, j::2].mean() for i in (0, 1) for j in (0, 1))  # the brightest sensor of the tile
    top = min(cam.full_well * cam.analog_gain / cam.electrons_per_dn, 2 ** cam.bits - 1)  # well or ADC, sheet's
    assert centre / top == pytest.approx(0.9, abs=0.02), (distance, centre / top)
