"""The optics stage against Fourier optics: the diffraction-limited MTF, energy, the camera equation, cos^4."""

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.datasets.sensors import Sensors
from camsim_core.image import image_from_scene
from camsim_core.optics import defocus_otf, diffraction_mtf, lens_sensor_responses, optics
from camsim_core.scene import Scene

H_C = 6.62607015e-34 * 299792458.0
WLS = np.array([450.0, 550.0, 650.0])
FOCAL_MM, DIST = 50.0, 1.05  # m = 0.05 / (1.05 - 0.05) = 0.05 exactly
#: The working f-number N (1 + m) over the nominal N at that focus distance (the blur's, like the irradiance's).
WORKING = 1.0 + FOCAL_MM * 1e-3 / (DIST - FOCAL_MM * 1e-3)


def airy_mtf(v):
    """Goodman's formula, written here independently of the code under test."""
    v = np.clip(v, 0, 1)
    return 2 / np.pi * (np.arccos(v) - v * np.sqrt(1 - v**2))


def scene_sampled_at(pitch_m, data, wavelengths):
    """A scene whose pixels are ``pitch_m`` wide at the sensor of a 50 mm lens focused at 1.05 m."""
    m = FOCAL_MM * 1e-3 / (DIST - FOCAL_MM * 1e-3)
    phi = 1.0 / np.degrees(np.arctan(pitch_m / m / DIST))  # pixels per degree
    return Scene(data, wavelengths, distance=DIST, angular_resolution=(phi, phi))


def lens_camera(f_stop=4.0, **kw):
    sens = Sensors(WLS, np.eye(3), ("B", "G", "R"), "Watts")
    return cs.Camera(sensors=sens, focal_length=FOCAL_MM, distance=DIST, f_stop=f_stop, bits=None, optics="diffraction", **kw)


def point_psf(n=256, pitch=0.5e-6, f_stop=4.0, **kw):
    data = np.zeros((n, n, 3))
    data[n // 2, n // 2, :] = 1.0
    scene = scene_sampled_at(pitch, data, WLS)
    return optics(lens_camera(f_stop, **kw), image_from_scene(scene)).data


def test_diffraction_mtf_closed_form_and_cutoff():
    # v = f lambda N: 0.5 at 550 nm, f/4 -> f = 0.5 / (550e-6 mm x 4)
    f = 0.5 / (550e-6 * 4.0)
    assert diffraction_mtf(f, 550.0, 4.0) == pytest.approx(airy_mtf(0.5), abs=1e-12)
    assert diffraction_mtf(0.0, 550.0, 4.0) == 1.0
    assert diffraction_mtf(1.0001 / (550e-6 * 4.0), 550.0, 4.0) == 0.0
    assert airy_mtf(0.5) == pytest.approx(0.3910, abs=1e-4)  # tabulated value (Goodman)
    freqs = np.linspace(0, 500, 11)
    assert diffraction_mtf(freqs, 450.0, 4.0).shape == freqs.shape


@pytest.mark.parametrize("k, wavelength", list(enumerate(WLS)))
def test_point_spread_mtf_equals_the_analytic_diffraction_mtf(k, wavelength):
    """MTF measured from the blurred point (|DFT| of the PSF) within 2 % of Goodman's formula up to 0.8 cutoff."""
    pitch, n_f = 0.5e-6, 4.0
    psf = point_psf(512, pitch, n_f)[:, :, k]
    otf = np.abs(np.fft.rfft2(psf)) / psf.sum()
    f = np.fft.rfftfreq(psf.shape[1], d=pitch * 1e3)  # cycles/mm along x
    v = f * wavelength * 1e-6 * n_f * WORKING
    keep = v <= 0.8
    measured, expected = otf[0, keep], airy_mtf(v[keep])
    assert np.max(np.abs(measured - expected)) < 0.02
    mid = expected > 0.2
    assert np.max(np.abs(measured[mid] / expected[mid] - 1)) < 0.02


def test_first_dark_ring_of_the_airy_pattern_at_1_22_lambda_n():
    """The radial profile of the PSF has its first minimum at 1.22 lambda N (1 + m) (an independent check of scale)."""
    pitch, n_f = 0.25e-6, 8.0
    psf = point_psf(256, pitch, n_f)[:, :, 1]  # 550 nm
    row = psf[128, 128:]
    r = np.arange(row.size) * pitch
    first_min = r[np.argmax(np.diff(row) > 0)]  # first place the profile turns up again
    assert first_min == pytest.approx(1.22 * 550e-9 * n_f * WORKING, abs=pitch)


def test_point_energy_in_the_frame_is_the_airy_encircled_energy():
    """Energy kept in a 128 um square frame lies between Rayleigh's encircled energy
    1 - J0^2 - J1^2 of its inscribed and circumscribed circles: the rest fell outside the frame."""
    from scipy.special import j0, j1

    n, pitch, n_f = 256, 0.5e-6, 4.0
    kept = point_psf(n, pitch, n_f).sum(axis=(0, 1))
    for k, lam in enumerate(WLS * 1e-9):
        ee = [1 - j0(x) ** 2 - j1(x) ** 2 for x in (np.pi * r / (lam * n_f) for r in (n / 2 * pitch, n / 2 * pitch * np.sqrt(2)))]
        assert ee[0] - 1e-3 <= kept[k] <= ee[1] + 1e-3


def test_blue_is_sharper_than_red_and_f16_softer_than_f2_8():
    psf = point_psf(256, 0.5e-6, 4.0)
    peaks = psf[128, 128]
    assert peaks[0] > peaks[1] > peaks[2]  # 450 nm keeps more energy in its peak than 650 nm
    soft = point_psf(256, 0.5e-6, 16.0)[128, 128, 1]
    sharp = point_psf(256, 0.5e-6, 2.8)[128, 128, 1]
    assert sharp > 10 * soft


def test_blur_conserves_the_energy_of_a_textured_image(rng):
    """A texture 80 samples (160 um) inside a dark frame: what the blur takes out of the frame is at most
    the Airy energy beyond 160 um (1 - EE = J0^2 + J1^2), and nothing is created; a uniform field
    (mirror-padded, so nothing leaves) keeps its energy exactly."""
    from scipy.special import j0, j1

    data = np.zeros((192, 224, 3))
    data[80:112, 80:144] = rng.uniform(0, 1, (32, 64, 3))
    scene = scene_sampled_at(2e-6, data, WLS)
    out = optics(lens_camera(8.0), image_from_scene(scene)).data
    lost = 1 - out.sum(axis=(0, 1)) / data.sum(axis=(0, 1))
    x = np.pi * 160e-6 / (WLS * 1e-9 * 8.0)
    assert np.all(lost >= -1e-9) and np.all(lost <= j0(x) ** 2 + j1(x) ** 2)
    assert not np.allclose(out, data)
    flat = optics(lens_camera(8.0), image_from_scene(scene_sampled_at(2e-6, np.full((40, 50, 3), 0.3), WLS))).data
    np.testing.assert_allclose(flat, 0.3, rtol=1e-12)


def test_defocus_otf_matches_a_numerical_pupil_autocorrelation():
    """The quadrature against the autocorrelation of a sampled pupil exp(i 2 pi w rho^2), by FFT."""
    w, n, pad = 1.0, 256, 1024
    y, x = (np.mgrid[0:n, 0:n] + 0.5 - n / 2) / (n / 2)
    pupil = np.where(x**2 + y**2 <= 1, np.exp(2j * np.pi * w * (x**2 + y**2)), 0)
    p = np.zeros((pad, pad), complex)
    p[:n, :n] = pupil
    auto = np.fft.ifft2(np.abs(np.fft.fft2(p)) ** 2)  # autocorrelation at integer shears
    auto = (auto / auto[0, 0]).real
    shears = np.arange(0, n, 16)  # shear s samples = 2 v (n / 2) -> v = s / n
    v = shears / n
    np.testing.assert_allclose(defocus_otf(v, w), auto[0, shears], atol=0.01)
    np.testing.assert_allclose(defocus_otf(v, 0.0), airy_mtf(v), atol=1e-12)
    assert np.all(defocus_otf(v[1:8], 1.0) < airy_mtf(v[1:8]))


def test_defocus_in_dioptres_blurs_more():
    in_focus = point_psf(128, 0.5e-6, 4.0)[64, 64, 1]
    out_of_focus = point_psf(128, 0.5e-6, 4.0, defocus=0.2)[64, 64, 1]  # W020 = 7 waves at 550 nm
    assert out_of_focus < 0.5 * in_focus


def test_cos4_relative_illumination_within_1_percent():
    """A flat scene across +-30 degrees: each pixel's gain equals cos^4 of its field angle."""
    n, phi = 121, 2.0  # 2 pixels per degree, 60 degrees across
    scene = Scene(np.ones((n, n, 3)), WLS, distance=2.0, angular_resolution=(phi, phi))
    cam = cs.Camera(sensors=Sensors(WLS, np.eye(3), ("B", "G", "R"), "Watts"), distance=2.0, bits=None,
                    relative_illumination=True)
    out = optics(cam, image_from_scene(scene)).data[:, :, 1]
    offs = (np.arange(n) + 0.5 - n / 2) / phi  # degrees from the axis
    tx, ty = np.tan(np.radians(offs))[None, :], np.tan(np.radians(offs))[:, None]
    theta = np.arctan(np.hypot(tx, ty))
    np.testing.assert_allclose(out, np.cos(theta) ** 4, rtol=0.01)
    assert out[n // 2, -1] == pytest.approx(np.cos(np.radians(29.75)) ** 4, rel=0.01)


def test_quantal_camera_receives_the_camera_equation_irradiance():
    """Electrons = q pi L T cos^4 / (4 N^2 (1 + m)^2) x pitch^2 x fill factor x t x lambda / hc, on the axis."""
    L, N, t, q, ff, T, p = 0.02, 2.8, 0.01, 0.6, 0.8, 0.9, 3e-6
    scene = Scene(np.full((9, 9, 1), L), [550.0], distance=1.05, angular_resolution=(200.0, 200.0))
    sens = Sensors([500.0, 600.0], [[q, q]], ("Q",), "Quanta")
    cam = cs.Camera(sensors=sens, focal_length=50.0, distance=1.05, f_stop=N, exposure=t, pixel_size=(p, p), fill_factor=ff,
                    lens_transmittance=cs.spectra.Spectrum([400.0, 700.0], [T, T]), bits=None, height=9, width=9,
                    angular_resolution=(200.0, 200.0))
    out = cs.simulate(scene, cam).data[4, 4, 0]
    m = 0.05 / 1.0
    expected = q * np.pi * L * T / (4 * N**2 * (1 + m) ** 2) * p * p * ff * t * 550e-9 / H_C
    assert out == pytest.approx(expected, rel=1e-9)


def test_default_camera_has_no_optics_stage_and_is_unchanged(cacaphony, dcs200_ir):
    assert dcs200_ir.optics == "none" and dcs200_ir.architecture == cs.DEFAULT_ARCHITECTURE
    cam = dcs200_ir.replace(optics="diffraction")
    assert cam.architecture == (lens_sensor_responses,) + cs.DEFAULT_ARCHITECTURE[1:]  # the lens fused with the sensor stage
    plain = cs.simulate(cacaphony, dcs200_ir.replace(bits=None))
    again = cs.simulate(cacaphony, dcs200_ir.replace(bits=None, architecture=(optics,) + cs.DEFAULT_ARCHITECTURE))
    assert np.array_equal(plain.data, again.data)
    blurred = cs.simulate(cacaphony, cam.replace(bits=None, f_stop=16.0))
    assert blurred.data.shape == plain.data.shape and not np.allclose(blurred.data, plain.data)


@pytest.mark.parametrize("field, value, words", [
    ("f_stop", 0.4, "f_stop"),
    ("optics", "geometric", "optics"),
    ("defocus", 1.0, "defocus"),
    ("vignetting", 1.5, "vignetting"),
])
def test_bad_optics_parameters_are_refused(dcs200_ir, field, value, words):
    with pytest.raises(cs.ParameterError, match=words):
        dcs200_ir.replace(**{field: value})


def test_diffraction_mtf_refuses_bad_input():
    with pytest.raises(cs.ParameterError, match="f_number"):
        diffraction_mtf(10.0, 550.0, 0.3)
    with pytest.raises(cs.ParameterError, match="wavelength"):
        diffraction_mtf(10.0, -550.0, 4.0)


def test_vignetting_takes_its_fraction_at_the_corner_of_the_pixel_array():
    """Without cos^4: 1 on the axis, 1 - v (r / r_corner)^2 elsewhere, r the image height of the pixel centre."""
    n, phi, f_mm, d = 41, 20.0, 50.0, 2.0
    s_img = f_mm * 1e-3 * d / (d - f_mm * 1e-3)  # lens to sensor, m
    pitch = s_img * np.tan(np.radians(1 / phi))
    scene = Scene(np.ones((n, n, 3)), WLS, distance=d, angular_resolution=(phi, phi))
    cam = cs.Camera(sensors=Sensors(WLS, np.eye(3), ("B", "G", "R"), "Watts"), distance=d, focal_length=f_mm, bits=None,
                    height=n, width=n, pixel_size=(pitch, pitch), angular_resolution=(phi, phi), vignetting=0.3)
    out = optics(cam, image_from_scene(scene)).data[:, :, 1]
    offs = np.tan(np.radians((np.arange(n) + 0.5 - n / 2) / phi)) * s_img
    r = np.hypot(offs[:, None], offs[None, :])
    corner = np.hypot(n * pitch, n * pitch) / 2
    np.testing.assert_allclose(out, 1 - 0.3 * (r / corner) ** 2, rtol=1e-9)
    assert out[n // 2, n // 2] == pytest.approx(1 - 0.3 * (r[n // 2, n // 2] / corner) ** 2) and out.min() > 0.7 - 1e-3


@pytest.mark.parametrize("k, wavelength", list(enumerate(WLS)))
def test_slanted_edge_mtf_of_the_blur_is_the_diffraction_mtf(k, wavelength):
    """An independent measurement: ISO 12233's e-SFR (camsim_core.metrics.sharpness) of a 5 degree edge
    through the lens, divided by the chart's own pixel-aperture sinc, against Goodman's formula up to 0.8 cutoff."""
    from camsim_core.metrics.sharpness import slanted_edge_mtf
    from camsim_core.scene.charts import edge_coverage

    n, pitch, n_f = 384, 0.5e-6, 4.0  # the e-SFR's window cuts the Airy tails: the error (at low frequency) falls as 1/n
    left = edge_coverage((n, n), 5.0)  # exact area average of the step: the chart's MTF is sinc(f)
    data = np.repeat((0.2 * left + 0.8 * (1 - left))[:, :, None], 3, axis=2)
    out = optics(lens_camera(n_f), image_from_scene(scene_sampled_at(pitch, data, WLS))).data[:, :, k]
    f, m = slanted_edge_mtf(out[16:-16, 16:-16], max_frequency=0.5)  # cycles per sample
    v = f / (pitch * 1e3) * wavelength * 1e-6 * n_f * WORKING
    keep = v <= 0.8
    np.testing.assert_allclose(m[keep] / np.sinc(f[keep]), airy_mtf(v[keep]), atol=0.02)


@pytest.mark.parametrize("shape, pads", [((7, 9, 2), ((3, 4), (0, 5))), ((20, 30, 3), ((6, 0), (2, 9))),
                                         ((5, 4, 1), ((7, 2), (1, 6)))])  # the last: pads wider than the image
def test_mirror_padding_is_numpys_symmetric_pad(shape, pads, rng):
    from camsim_core.optics.stage import _mirror_padded

    data = rng.uniform(0, 1, shape)
    expected = np.pad(np.moveaxis(data, 2, 0), ((0, 0), *pads), mode="symmetric")
    np.testing.assert_array_equal(_mirror_padded(data, np.float64, *pads), expected)


def test_a_float32_image_is_blurred_in_float32_like_its_float64_twin(rng):
    data = rng.uniform(0, 1, (40, 56, 3))
    scene64 = scene_sampled_at(2e-6, data, WLS)
    scene32 = scene_sampled_at(2e-6, data.astype(np.float32), WLS)
    out64 = optics(lens_camera(8.0), image_from_scene(scene64)).data
    out32 = optics(lens_camera(8.0), image_from_scene(scene32)).data
    assert out32.dtype == np.float32 and out64.dtype == np.float64
    np.testing.assert_allclose(out32, out64, atol=1e-5)
    assert not np.allclose(out64, data, atol=1e-3)  # and the blur did something
