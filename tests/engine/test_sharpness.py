"""Slanted-edge MTF against analytic MTFs: a Gaussian blur, the pixel aperture, diffraction."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ndtr

from camsim_core.errors import ParameterError
from camsim_core.metrics import edge_mtf, mtf50, mtf_at, slanted_edge_mtf
from camsim_core.metrics.sharpness import edge_angle
from camsim_core.scene.charts import edge_coverage


def _distance(shape, angle):
    h, w = shape
    y, x = np.mgrid[0:h, 0:w]
    return (x - (w / 2 + (y - h / 2) * np.tan(np.radians(angle)))) * np.cos(np.radians(angle))


def gaussian_edge(shape, angle, sigma, lo=0.2, hi=0.8):
    """A step blurred by a Gaussian of ``sigma`` px, sampled at pixel centres (no pixel aperture)."""
    return lo + (hi - lo) * ndtr(_distance(shape, angle) / sigma)


@pytest.mark.parametrize("angle", [5.0, -7.0, 12.0])
@pytest.mark.parametrize("sigma", [0.5, 1.0, 2.0])
def test_gaussian_blur_mtf_within_2_percent_to_nyquist(angle, sigma):
    f, m = slanted_edge_mtf(gaussian_edge((128, 128), angle, sigma))
    analytic = np.exp(-2 * np.pi**2 * sigma**2 * f**2)
    upto = f <= 0.5
    assert np.abs(m - analytic)[upto].max() < 0.02
    assert mtf50(f, m) == pytest.approx(np.sqrt(np.log(2) / 2) / (np.pi * sigma), rel=0.02)


def test_near_horizontal_edge_and_falling_edge():
    a = gaussian_edge((128, 160), 6.0, 1.0)
    for img in (a.T, a[:, ::-1], 1.0 - a):
        f, m = slanted_edge_mtf(img)
        assert np.abs(m - np.exp(-2 * np.pi**2 * f**2))[f <= 0.5].max() < 0.02


def test_area_sampled_step_has_the_pixel_aperture_mtf():
    # each pixel the exact area average of the step: MTF = |sinc(f)| of a 1 px box, sampled perpendicular
    # to the edge the box projects to a trapezoid; at 5 degrees the difference from sinc is below 0.3 %
    img = 0.2 + 0.6 * (1.0 - edge_coverage((160, 160), 5.0))
    f, m = slanted_edge_mtf(img)
    upto = f <= 0.5
    assert np.abs(m - np.abs(np.sinc(f)))[upto].max() < 0.02
    assert mtf_at(f, m) == pytest.approx(2 / np.pi, abs=0.02)  # sinc(0.5)


def _diffraction_mtf(nu, cutoff):
    """Diffraction-limited MTF of a circular pupil, incoherent light (Goodman, Fourier Optics, Eq. 6-32)."""
    v = np.clip(np.asarray(nu, float) / cutoff, 0, 1)
    return 2 / np.pi * (np.arccos(v) - v * np.sqrt(1 - v**2))


def test_diffraction_limited_edge_mtf_within_2_percent_to_nyquist():
    cutoff = 0.8  # cycles per pixel: e.g. 550 nm at f/4.5 on a 2 um pixel gives 1 / (lambda N) = 0.81
    # ESF(d) = 1/2 + integral_0^cutoff MTF(nu) sin(2 pi nu d) / (pi nu) dnu (the MTF is real and even)
    # (midpoint rule on 4000 frequencies; checked against scipy's quad at a few distances below)
    grid = np.linspace(-40, 40, 3201)
    dnu = cutoff / 4000
    nu = (np.arange(4000) + 0.5) * dnu
    esf = 0.5 + (np.sin(2 * np.pi * np.outer(grid, nu)) / (np.pi * nu)) @ _diffraction_mtf(nu, cutoff) * dnu
    for i in (1200, 1600, 1700):
        ref = 0.5 + quad(lambda v: _diffraction_mtf(v, cutoff) * np.sin(2 * np.pi * v * grid[i]) / (np.pi * v),
                         0, cutoff, limit=200)[0]
        assert esf[i] == pytest.approx(ref, abs=1e-5)
    img = 0.2 + 0.6 * np.interp(_distance((128, 128), 5.0), grid, esf)
    f, m = slanted_edge_mtf(img)
    upto = f <= 0.5
    assert np.abs(m - _diffraction_mtf(f, cutoff))[upto].max() < 0.02
    # the same against the optics stage's diffraction MTF: 550 nm on a 2 um pixel at f/4.545 (cutoff 0.8 cycles/px)
    from camsim_core.optics import diffraction_mtf

    pitch_mm, n = 0.002, 0.002 / (550e-6 * cutoff)
    assert np.abs(m - diffraction_mtf(f / pitch_mm, 550.0, n))[upto].max() < 0.02


def test_mtf50_and_mtf_at():
    f = np.linspace(0, 1, 11)
    assert mtf50(f, 1 - f) == pytest.approx(0.5)
    assert mtf50(f, 1 - 0.4 * f) != mtf50(f, 1 - 0.4 * f)  # nan: never below 0.5
    assert mtf_at(f, 1 - f, 0.25) == pytest.approx(0.75)
    with pytest.raises(ParameterError, match="frequency"):
        mtf50(f[::-1], f)


def test_per_channel_and_luminance():
    sigmas = (0.6, 1.0, 1.6)
    rgb = np.stack([gaussian_edge((128, 128), 5.0, s) for s in sigmas], axis=2)
    res = edge_mtf(rgb)
    for i, s in enumerate(sigmas):
        assert res[str(i)]["mtf50"] == pytest.approx(np.sqrt(np.log(2) / 2) / (np.pi * s), rel=0.02)
    lum = res["luminance"]
    # luminance = Rec. 709 weighted sum: its MTF is the weighted sum of the channels' (same contrast)
    w = np.array([0.2126, 0.7152, 0.0722])
    expected = sum(wi * np.exp(-2 * np.pi**2 * s**2 * lum["frequency"] ** 2) for wi, s in zip(w, sigmas))
    assert np.abs(lum["mtf"] - expected)[lum["frequency"] <= 0.5].max() < 0.02
    assert lum["mtf_nyquist"] == pytest.approx(np.interp(0.5, lum["frequency"], expected), abs=0.02)


def test_bad_edge_images():
    with pytest.raises(ParameterError, match="2-D"):
        slanted_edge_mtf(np.zeros((32, 32, 3)))
    with pytest.raises(ParameterError, match="no edge"):
        slanted_edge_mtf(np.ones((64, 64)))
    square = np.zeros((64, 64))
    square[:, 32:] = 1
    with pytest.raises(ParameterError, match="slant"):
        slanted_edge_mtf(square)
    with pytest.raises(ParameterError, match="16 x 16"):
        slanted_edge_mtf(np.zeros((8, 8)))


def _shaded_frame(shape, angle, falloff, noise, seed=0):
    """A full frame like a camera's: the area-sampled step under cos^4-like relative illumination, with noise.

    ``falloff``: the corners' illumination relative to the centre's (e.g. 0.85); ``noise``: sigma, in
    units of the step's dark side (0.2).
    """
    h, w = shape
    y, x = np.mgrid[0:h, 0:w]
    r2 = ((x - w / 2) ** 2 + (y - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
    shading = 1.0 - (1.0 - falloff) * r2
    img = (0.2 + 0.6 * (1.0 - edge_coverage(shape, angle))) * shading
    return img + np.random.default_rng(seed).normal(0.0, noise, shape)


@pytest.mark.parametrize("angle", [5.0, -8.0, 30.0])
def test_full_frame_with_shading_and_noise_has_the_pixel_aperture_mtf(angle):
    # a camera's whole frame (1000 x 1600 px) under 15 % corner falloff, as the explorer measures it: the
    # falloff is 0.2 of the step's height across the frame, so centroids over whole rows (not a band
    # around the edge, as ISO 12233's region of interest) put the edge 50 px and 0.6 degree off and
    # the MTF50 came out at 0.05 cycles/px instead of the pixel aperture's 0.60
    img = _shaded_frame((1000, 1600), angle, 0.85, 0.002)
    assert edge_angle(img) == pytest.approx(angle, abs=0.02)
    f, m = slanted_edge_mtf(img)
    upto = f <= 0.5
    assert np.abs(m - np.abs(np.sinc(f)))[upto].max() < 0.03
    assert mtf50(f, m) == pytest.approx(0.6034, abs=0.02)  # sinc(f) = 0.5


def test_edge_away_from_the_centre_and_a_band_narrower_than_the_blur():
    # the edge a third of the way across a shaded frame; a wide Gaussian blur (sigma 6 px) still fits the band
    h, w = 600, 900
    y, x = np.mgrid[0:h, 0:w]
    t = np.radians(6.0)
    dist = (x - (w / 3 + (y - h / 2) * np.tan(t))) * np.cos(t)
    shading = 1.0 - 0.15 * (((x - w / 2) ** 2 + (y - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2))
    img = (0.2 + 0.6 * ndtr(dist / 6.0)) * shading
    f, m = slanted_edge_mtf(img)
    assert mtf50(f, m) == pytest.approx(np.sqrt(np.log(2) / 2) / (np.pi * 6.0), rel=0.05)
    with pytest.raises(ParameterError, match="half_width"):
        slanted_edge_mtf(img, half_width=2)


def test_a_blur_wider_than_the_region_is_refused_not_measured_too_sharp():
    img = gaussian_edge((300, 400), 5.0, 12.0)  # 10-90 % rise of 31 px: the ESF still climbs 16 px from the centre
    with pytest.raises(ParameterError, match="half_width.*still rising"):
        slanted_edge_mtf(img, half_width=16)
    # a blur of sigma 4 px (MTF50 0.047 cycles/px) is measured in the default 64 px within 3 %
    f, m = slanted_edge_mtf(gaussian_edge((300, 400), 5.0, 4.0))
    assert mtf50(f, m) == pytest.approx(np.sqrt(np.log(2) / 2) / (np.pi * 4.0), rel=0.03)


@pytest.mark.parametrize("seed", range(5))
def test_noisy_small_edges_are_measured_not_refused(seed):
    # noise 5 % of the step on 128 x 128 px: the ends' flatness check must not mistake noise for a rise
    img = gaussian_edge((128, 128), 5.0, 1.0) + np.random.default_rng(seed).normal(0, 0.03, (128, 128))
    f, m = slanted_edge_mtf(img)
    assert mtf50(f, m) == pytest.approx(np.sqrt(np.log(2) / 2) / np.pi, rel=0.1)


def test_a_tall_narrow_noisy_region_is_not_taken_for_a_horizontal_edge():
    # 160 x 96 px around a 5 degree edge with noise 1 % of the step: summed absolute differences
    # (the old orientation test) counted the noise down 160 rows above the edge across 96 columns
    img = gaussian_edge((160, 96), 5.0, 0.7) + np.random.default_rng(3).normal(0, 0.006, (160, 96))
    assert edge_angle(img) == pytest.approx(5.0, abs=0.2)
    f, m = slanted_edge_mtf(img, half_width=32)
    assert mtf50(f, m) == pytest.approx(np.sqrt(np.log(2) / 2) / (np.pi * 0.7), rel=0.06)


def test_noise_alone_is_not_taken_for_an_edge():
    """The rise across the frame is held to the noise of a difference of means (a dim, coarse edge of 5 sigma
    per pixel is one): fields of noise alone, and noise over a faint ramp, are still refused, never measured."""
    rng = np.random.default_rng(0)
    for i in range(20):
        field = 100 + 2.0 * rng.standard_normal((128, 160))
        if i % 2:
            field += np.linspace(0, 0.2, 160)[None, :]  # a ramp of a tenth of the noise across the frame
        with pytest.raises(ParameterError):
            slanted_edge_mtf(np.round(field))
    for seed in range(20):  # a ramp of 2 sigma across a 200 px field: 35 in 40 were measured with the rise held
        field = 100 + np.random.default_rng(seed).standard_normal((200, 200)) + np.linspace(0, 2, 200)[None, :]
        with pytest.raises(ParameterError, match="no edge"):
            slanted_edge_mtf(field)
