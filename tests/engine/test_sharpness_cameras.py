"""The slanted-edge MTF of simulated cameras' whole frames, against the physics of their lenses.

The e-SFR measure takes the explorer's whole frame. An electron-level camera's frame has cos^4
relative illumination (its corners 10-20 % darker than its centre); centroids taken over whole
rows put imx174's edge 50 px off and its MTF50 at 0.05 cycles/px. These tests simulate the shipped
electron-level cameras on the slanted edge and check what the measure reports against
what the lens must do, computed here from the diffraction formula, not from camsim's optics.
"""

import numpy as np
import pytest

from camsim_core import auto_exposure, demosaic, load_camera, load_scene, simulate
from camsim_core.metrics import edge_mtf, mtf50, slanted_edge_mtf
from camsim_core.metrics.sharpness import luminance_weights
from camsim_core.scene.charts import chart_name, fitted_chart_options
from camsim_core.datasets.illuminants import illuminant

FRAME = (480, 640)  # a crop of the sensor: the physics per pixel is the same, the test 8x faster
QUIET = dict(read_noise=0.0, dsnu=0.0, prnu=0.0, dark_current=0.0)


def _diffraction_mtf(nu, cutoff):
    """Diffraction-limited MTF of a circular pupil, incoherent light (Goodman, Fourier Optics, Eq. 6-32)."""
    v = np.clip(np.asarray(nu, float) / cutoff, 0, 1)
    return 2 / np.pi * (np.arccos(v) - v * np.sqrt(1 - v**2))


def _edge_raw(name, optics, f_stop=11.0, **sensor):
    camera = load_camera(name).replace(height=FRAME[0], width=FRAME[1], optics=optics, f_stop=f_stop, **sensor)
    opts = fitted_chart_options("slanted-edge", FRAME, camera.angular_resolution, 3.32)
    scene = load_scene(chart_name("slanted-edge", opts))
    # exposed to 80 % of full scale: the light side holds ~20,000 electrons, so shot noise is under 1 %
    exposure = auto_exposure(scene, camera.replace(optics="none"), target=0.8)
    return camera, simulate(scene, camera, distance=3.32, exposure=exposure, seed=1)


def _plane(raw, camera, channel):
    """The raw mosaic's samples of one channel that lie on a square lattice (R or B of a Bayer tile)."""
    (y, x), = np.argwhere(np.asarray(camera.mosaic) == channel)
    return np.asarray(raw.data, float)[y::2, x::2]


def _polychromatic_diffraction(camera, channel, nu_per_mm, f_number):
    """The channel's diffraction MTF: each wavelength's, weighted by the photons the channel catches."""
    wl = np.arange(400.0, 701.0, 10.0)
    qe = camera.sensors.on(wl)[channel]
    d65 = illuminant("D65").on(wl)
    weight = qe * d65 * wl  # quanta: energy x wavelength
    cutoff = 1.0 / (wl * 1e-6 * f_number)  # cycles/mm
    per_wl = np.array([_diffraction_mtf(nu_per_mm, c) for c in cutoff])
    return weight @ per_wl / weight.sum()


@pytest.mark.parametrize("name, channel", [("imx174", 0), ("imx174", 2), ("phone-1.4um", 0)])
def test_a_lens_multiplies_the_raw_mtf_by_its_diffraction_mtf(name, channel):
    # the same camera with and without its lens at f/11: the ratio of the measured MTFs of one Bayer
    # channel (on its own lattice, 2 px apart) is the lens's polychromatic diffraction MTF
    cam, lens = _edge_raw(name, "diffraction", **QUIET)
    _, bare = _edge_raw(name, "none", **QUIET)
    f, with_lens = slanted_edge_mtf(_plane(lens, cam, channel), half_width=64)
    f2, without = slanted_edge_mtf(_plane(bare, cam, channel), half_width=64)
    np.testing.assert_allclose(f, f2)
    pitch_mm = cam.pixel_size[1] * 1e3 * 2  # the lattice's spacing
    working_n = 11.0 * (1 + cam.focal_length / (3320.0 - cam.focal_length))
    expected = _polychromatic_diffraction(cam, channel, f / pitch_mm, working_n)
    # within 0.035 to 0.35 cycles per sample, 0.05 to the lattice's Nyquist (where the lens leaves 0.1 or
    # more): the measure's precision on 240 rows under ~1 % shot noise (and the diffraction LSF's
    # 1/x^2 tails, cut at 64 samples: about 0.01 at low frequencies)
    error = np.abs(with_lens / without - expected)
    assert error[(f <= 0.35) & (expected > 0.1)].max() < 0.035
    assert error[(f <= 0.5) & (expected > 0.1)].max() < 0.05


def _filled_frame(name, f_stop):
    """The camera (its sensor cropped to about 480 x 640) and the slanted edge filling its frame, as the
    explorer shows it: a chart sized to the frame, the frame then cut to the chart (no dark surround)."""
    camera = load_camera(name)
    frame = (min(camera.height, FRAME[0]), min(camera.width, FRAME[1]))
    opts = fitted_chart_options("slanted-edge", frame, camera.angular_resolution, 3.32)
    scale = camera.angular_resolution[0] / opts["angular_resolution"]  # camera pixels per chart sample
    h, w = (int(n * scale) // 2 * 2 - 4 for n in opts["size"])
    camera = camera.replace(height=h, width=w, f_stop=f_stop)
    return camera, load_scene(chart_name("slanted-edge", opts))


@pytest.mark.parametrize("name, f_stop", [("imx174", 2.8), ("imx174", 11.0), ("phone-1.4um", 2.0),
                                          ("phone-1.4um", 11.0), ("kodak-dcs200", 8.0)])
def test_whole_frame_and_central_region_give_the_same_mtf50(name, f_stop):
    # ISO 12233 measures a small region around the edge; the explorer passes the whole demosaiced
    # frame, shading and noise included: both must agree (imx174's MTF50 was 0.05 cycles/px on the
    # whole frame, 4-7x below its central region's)
    camera, scene = _filled_frame(name, f_stop)
    raw = simulate(scene, camera, distance=3.32, exposure=auto_exposure(scene, camera, target=0.8), seed=1)
    full = demosaic(raw, "bilinear")
    whole = edge_mtf(full)["luminance"]["mtf50"]
    h, w = full.data.shape[:2]
    centre = full.data[h // 2 - 80 : h // 2 + 80, w // 2 - 48 : w // 2 + 48] @ luminance_weights(full)
    fc, mc = slanted_edge_mtf(centre, half_width=32)
    assert whole == pytest.approx(mtf50(fc, mc), rel=0.05)
    assert 0.05 < whole < 0.6


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_dim_coarsely_quantized_edge_is_measured_not_called_too_blurred(seed):
    # imx174 at 6 bits and a tenth of its exposure: a step of ~3 DN, whose ESF's ends scatter by more than
    # 5 % of the step; that is noise, and the measure said the blur was too wide for its region. And the step
    # is 5 sigma of one pixel's noise: "no edge found" for two seeds in three (the rise, a median of means over
    # rows, was held to one pixel's noise)
    camera = load_camera("imx174").replace(height=480, width=640, bits=6)
    opts = fitted_chart_options("slanted-edge", (480, 640), camera.angular_resolution, 3.32)
    scene = load_scene(chart_name("slanted-edge", opts))
    raw = simulate(scene, camera, distance=3.32, exposure=0.1 * auto_exposure(scene, camera, target=0.9), seed=seed)
    assert 0.1 < edge_mtf(demosaic(raw, "bilinear"))["luminance"]["mtf50"] < 0.45
