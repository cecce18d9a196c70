"""Close focus: the diffraction blur at the working f-number N (1 + m), and a pixel's angle at the focus distance.

Against physics, not the engine's own formulas: a slanted edge is simulated
through a diffraction-limited 50 mm f/4 lens on 2 um pixels, its MTF
measured by the ISO 12233 e-SFR (camsim_core.metrics.sharpness), and the
MTF50 compared with the analytic MTF of a circular aperture at the working
f-number, 2/pi (acos x - x sqrt(1 - x^2)), x = f lambda N (1 + m) / pitch,
times the pixel aperture's sinc(f) (the camera pixel's area average, which
the resampling stage models at a fill factor of 1). m = f / (d - f) is the
thin lens's magnification at the focus distance d: 1 at 0.1 m, 5e-5 at 1 km.
"""

import numpy as np
import pytest

import camsim_core as cc
from camsim_core.camera.physical import physical_camera, with_sensor
from camsim_core.metrics.sharpness import edge_mtf
from camsim_core.scene.charts import slanted_edge_scene

FOCAL_MM = 50.0
F_NUMBER = 4.0
PITCH = 2.0e-6


def analytic_mtf50(wavelengths, weights, working_f_number, pitch=PITCH):
    """MTF50 (cycles/px) of the weighted mean diffraction MTF over ``wavelengths`` (nm) times the pixel's sinc."""
    f = np.linspace(0.0, 1.0, 200_001)  # cycles per pixel
    mtf = np.zeros_like(f)
    for lam, w in zip(wavelengths, weights / np.sum(weights)):
        x = np.clip(f * lam * 1e-9 * working_f_number / pitch, 0.0, 1.0)
        mtf += w * (2.0 / np.pi) * (np.arccos(x) - x * np.sqrt(1.0 - x * x))
    mtf *= np.sinc(f)
    i = np.argmax(mtf < 0.5)
    return float(f[i - 1] + (mtf[i - 1] - 0.5) * (f[i] - f[i - 1]) / (mtf[i - 1] - mtf[i]))


def edge_camera(distance):
    """An ideal (noise-free, unquantized) full-colour camera on 2 um pixels behind a 50 mm f/4 lens at ``distance``."""
    return physical_camera("imx174", focal_length=FOCAL_MM, f_stop=F_NUMBER, distance=distance, mosaic=None,
                           height=160, width=160, pixel_size=(PITCH, PITCH), full_well=None, read_noise=0.0,
                           dark_current=0.0, dsnu=0.0, prnu=0.0, exposure=50.0, bits=None,
                           relative_illumination=False)


def measured(distance, wavelengths):
    cam = edge_camera(distance)
    # the chart 4x finer than the camera: the camera's pixels average it (their aperture), the lens blurs it
    scene = slanted_edge_scene(640, angle=5.0, wavelengths=list(wavelengths), distance=distance,
                               angular_resolution=4 * cam.angular_resolution[0])
    return cam, scene, edge_mtf(cc.simulate(scene, cam))


@pytest.mark.parametrize("distance, m", [(0.1, 1.0), (1000.0, 0.05 / 999.95)])
def test_edge_mtf50_at_the_working_f_number(distance, m):
    """One wavelength (the per-plane optics stage): MTF50 within 3 % of the analytic value at N (1 + m)."""
    _, _, mtf = measured(distance, [550.0])
    expected = analytic_mtf50([550.0], np.ones(1), F_NUMBER * (1.0 + m))
    got = mtf["luminance"]["mtf50"]
    assert got == pytest.approx(expected, rel=0.03), (distance, got, expected)
    if distance < 1:  # at m = 1 the nominal f-number's value is far off (0.30 cycles/px): the test tells them apart
        assert abs(got - analytic_mtf50([550.0], np.ones(1), F_NUMBER)) > 0.25 * expected


@pytest.mark.parametrize("distance, m", [(0.1, 1.0), (1000.0, 0.05 / 999.95)])
def test_fused_lens_stage_at_the_working_f_number(distance, m):
    """Several wavelengths (the fused lens and sensor stage): the G channel's MTF50 within 3 % of the mean
    analytic MTF weighted by the photons G collects at each wavelength (illuminant x QE x lambda)."""
    wl = np.arange(520.0, 581.0, 10.0)
    cam, scene, mtf = measured(distance, wl)
    qe = cam.sensors.values[list(cam.sensors.names).index("G")]
    g = np.interp(wl, cam.sensors.wavelengths, qe)
    light = scene.illuminant.on(wl) if hasattr(scene.illuminant, "on") else np.ones_like(wl)
    expected = analytic_mtf50(wl, g * light * wl, F_NUMBER * (1.0 + m))
    assert mtf["G"]["mtf50"] == pytest.approx(expected, rel=0.03), (distance, mtf["G"]["mtf50"], expected)


@pytest.mark.parametrize("distance", [0.1, 0.5, 3.32, None])
def test_preset_angular_resolution_is_the_pixel_angle_at_the_focus_distance(distance):
    """A pixel of pitch p images the object patch p / m; seen from the lens at d it subtends atan(p / (m d)),
    which is p / (f (1 + m)) radians: the preset's pixels per degree at that distance."""
    cam = physical_camera("imx174", focal_length=FOCAL_MM, distance=distance)
    p, f = cam.pixel_size[1], FOCAL_MM * 1e-3
    if distance is None:
        angle = np.arctan(p / f)  # at infinity
    else:
        m = f / (distance - f)
        angle = np.arctan((p / m) / distance)
    assert cam.angular_resolution[0] == pytest.approx(1.0 / np.degrees(angle), rel=1e-12)
    assert cam.angular_resolution[1] == pytest.approx(1.0 / np.degrees(angle), rel=1e-12)


def test_moved_preset_follows_the_distance_and_hand_set_resolution_stays():
    """The explorer's path (a preset moved with ``replace`` then ``with_sensor``): the pixel angle at the new
    distance; an angular resolution set by hand is kept."""
    cam = physical_camera("imx174")
    f = cam.focal_length * 1e-3
    moved = with_sensor(cam.replace(distance=0.1))
    m = f / (0.1 - f)
    assert moved.angular_resolution[0] == pytest.approx(1.0 / np.degrees(np.arctan(cam.pixel_size[1] / (f * (1 + m)))),
                                                        rel=1e-12)
    smaller = with_sensor(cam.replace(distance=0.1), pixel_pitch_um=2.93)
    assert smaller.angular_resolution[0] == pytest.approx(2 * moved.angular_resolution[0], rel=1e-3)
    hand = with_sensor(cam.replace(distance=0.1, angular_resolution=(50.0, 50.0)))
    assert hand.angular_resolution == (50.0, 50.0)
