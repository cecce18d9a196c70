"""The sensor pedestal (black level): added before quantization, carried, subtracted by processing."""

import dataclasses

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.camera.load import CAMERA_NAMES, camera_preset
from camsim_core.errors import ParameterError
from camsim_core.scene import Scene

W31 = np.arange(400, 701, 10.0)


def _flat(level=0.01, h=48, w=48):
    return Scene(np.full((h, w, 31), level), W31)


@pytest.mark.parametrize("name", CAMERA_NAMES)
def test_every_preset_takes_a_black_level(name):
    cam = dataclasses.replace(camera_preset(name), black_level=15)
    assert cam.black_level == 15.0
    assert cam.describe()["black_level_du"] == 15.0
    assert camera_preset(name).black_level == 0.0


def test_black_level_is_validated():
    cam = camera_preset("kodak-dcs200-ir")
    for bad in (-1.0, float("nan"), float("inf"), "15", None):
        with pytest.raises(ParameterError, match="black_level"):
            cam.replace(black_level=bad)


def test_flat_field_raw_is_signal_plus_pedestal_and_processing_removes_it(dcs200_ir):
    """A 15 DU pedestal: raw = signal + 15 (within noise); demosaic + render equals the pedestal-free render."""
    scene = _flat()
    cam = dcs200_ir.replace(noise_sigma=1.0, seed=3)
    ex = cs.auto_exposure(scene, cam, target=0.5)
    signal = cs.simulate(scene, cam.replace(noise_sigma=0.0, bits=None), exposure=ex).data
    raw0 = cs.simulate(scene, cam, exposure=ex)
    raw15 = cs.simulate(scene, cam.replace(black_level=15), exposure=ex)
    assert raw15.black_level == 15.0 and raw0.black_level == 0.0
    assert raw15.metadata()["black_level"] == 15.0
    # the mean offset of the raw over the noiseless signal is the pedestal (noise sigma 1 DU, ~2300 px)
    assert np.mean(raw15.data - signal) == pytest.approx(15.0, abs=0.1)
    assert np.mean(raw0.data - signal) == pytest.approx(0.0, abs=0.1)
    # the same noise draw: the raws differ by exactly the (integer) pedestal where nothing clipped
    np.testing.assert_array_equal(raw15.data - raw0.data, 15.0)
    mon = cs.load_monitor("simtoolbox-test")
    for method in ("bilinear", "bayesian"):
        r0 = cs.render(cs.demosaic(raw0, method), mon)  # display scale from the image (no illuminant)
        dm15 = cs.demosaic(raw15, method)
        assert dm15.black_level == 0.0
        r15 = cs.render(dm15, mon, scale=r0.extra["display_scale"])
        assert np.max(np.abs(r15.data - r0.data)) <= 1.0
    # without subtraction the pedestal would show: the flat grey is lifted by many levels
    lifted = cs.render(cs.demosaic(raw15.replace(black_level=0.0)), mon, scale=r0.extra["display_scale"])
    assert np.median(lifted.data - r0.data) > 5


def test_pedestal_lets_negative_noise_survive_quantization(dcs200_ir):
    """Around black, a pedestal keeps the noise's lower half that a zero-offset camera clips to 0."""
    scene = _flat(0.0)
    cam = dcs200_ir.replace(mosaic=None, noise_sigma=4.0, seed=1)
    raw0 = cs.simulate(scene, cam).data
    raw15 = cs.simulate(scene, cam.replace(black_level=15)).data
    assert np.mean(raw0 == 0) > 0.4  # about half the noise clipped
    assert np.mean(raw15 - 15.0) == pytest.approx(0.0, abs=0.1)  # unbiased around the pedestal


def test_full_colour_camera_pedestal_is_subtracted_by_render(dcs200_ir):
    scene = _flat()
    cam = dcs200_ir.replace(mosaic=None)
    mon = cs.load_monitor("simtoolbox-test")
    r0 = cs.render(cs.simulate(scene, cam, exposure=0.05), mon, scale=50.0)
    r15 = cs.render(cs.simulate(scene, cam.replace(black_level=15), exposure=0.05), mon, scale=50.0)
    assert np.max(np.abs(r15.data - r0.data)) <= 1.0


def test_unquantized_camera_adds_the_pedestal_exactly(dcs200_ir):
    scene = _flat()
    cam = dcs200_ir.replace(mosaic=None, bits=None)
    a = cs.simulate(scene, cam).data
    b = cs.simulate(scene, cam.replace(black_level=2.5))
    np.testing.assert_allclose(b.data, a + 2.5)
    assert b.black_level == 2.5


def test_raw_from_array_carries_the_black_level():
    raw = cs.raw_from_array(np.array([[20, 30], [40, 10]], np.uint8), "GRBG", black_level=15)
    assert raw.bits == 8 and raw.quantized and raw.black_level == 15.0
    np.testing.assert_array_equal(raw.data, [[20, 30], [40, 10]])  # the data keep the pedestal
    flat = cs.raw_from_array(np.full((8, 8), 40, np.uint8), "GRBG", black_level=15)
    np.testing.assert_array_equal(cs.demosaic(flat).data, 25.0)
    dark = cs.raw_from_array(np.full((8, 8), 10, np.uint8), "GRBG", black_level=15)
    np.testing.assert_array_equal(cs.demosaic(dark).data, -5.0)  # signed: below the pedestal stays below 0
    for bad in (-1, "x", float("nan")):
        with pytest.raises(ParameterError, match="black_level"):
            cs.raw_from_array(np.zeros((2, 2)), "GRBG", black_level=bad)


def test_changing_the_black_level_reruns_from_digitize_only(dcs200_ir):
    from camsim_core.cache import Pipeline, Processing

    scene = _flat()
    pipe = Pipeline()
    cam = dcs200_ir.replace(distance=3.0)
    first = pipe.run(scene, cam, Processing(metrics=("cielab",)))
    again = pipe.run(scene, cam.replace(black_level=15), Processing(metrics=("cielab",)))
    assert "stage:digitize" in again.ran_steps and "stage:resample" not in again.ran_steps
    assert again.raw.black_level == 15.0
    # the pedestal is removed by processing: the rendered image is unchanged within a level
    assert np.max(np.abs(again.rendered.data - first.rendered.data)) <= 1.0
