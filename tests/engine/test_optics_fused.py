"""The lens fused with the sensor responses: the optics stage's image through a low-rank OTF over wavelength."""

import numpy as np
import pytest
import scipy.fft as sfft

import camsim_core as cs
import camsim_core.optics.fused as fused
from camsim_core.image import image_from_scene
from camsim_core.optics import OTF_TOLERANCE, lens_sensor_responses, optics, otf_factors
from camsim_core.scene import Scene
from camsim_core.simulation import DEFAULT_ARCHITECTURE, sensor_responses

WL = np.arange(400.0, 701.0, 10.0)


def airy_mtf(v):
    """Goodman's formula, written here independently of the code under test."""
    v = np.clip(v, 0, 1)
    return 2 / np.pi * (np.arccos(v) - v * np.sqrt(1 - v**2))


def exact_pair(camera, image):
    """What the fused stage stands for: the optics stage's spectral planes, then the sensor responses."""
    return sensor_responses(camera, optics(camera, image))


@pytest.fixture
def no_fallback(monkeypatch):
    """The fused stage must not fall back on the optics stage (it would give the exact image and prove nothing)."""
    def refuse(*_):
        raise AssertionError("the fused stage fell back on the per-wavelength optics stage")
    monkeypatch.setattr(fused, "optics", refuse)


@pytest.mark.parametrize("f_number", [2.8, 11.0, 16.0])
def test_low_rank_otf_is_within_its_tolerance_and_one_at_zero_frequency(f_number):
    """On the explorer's default sampling (11 um at the sensor, Nyquist 45 cycles/mm): the factors give
    Goodman's OTF at every wavelength and frequency of the grid within the tolerance, with 2-3 terms."""
    shape, pitch = (200, 320), (11.06e-6, 11.06e-6)
    u, v = otf_factors(shape, pitch, WL, f_number)
    rho = np.hypot(sfft.fftfreq(shape[0], pitch[0] * 1e3)[:, None], sfft.rfftfreq(shape[1], pitch[1] * 1e3)[None, :])
    expected = np.stack([airy_mtf(rho * lam * 1e-6 * f_number) for lam in WL])
    approx = np.einsum("nr,hwr->nhw", v, u)
    assert np.max(np.abs(approx - expected)) <= 1.01 * OTF_TOLERANCE
    np.testing.assert_allclose(approx[:, 0, 0], 1.0, rtol=0, atol=1e-12)  # energy: exactly 1 at zero frequency
    assert u.shape == rho.shape + (v.shape[1],) and 1 <= v.shape[1] <= 3
    assert not u.flags.writeable and not v.flags.writeable


def test_low_rank_otf_with_defocus_is_within_its_tolerance():
    from camsim_core.optics import defocus_otf

    shape, pitch, n_f = (64, 96), (6e-6, 6e-6), 8.0
    waves = np.linspace(1.2, 0.7, WL.size)  # W020 falls as the wavelength grows
    u, v = otf_factors(shape, pitch, WL, n_f, waves)
    rho = np.hypot(sfft.fftfreq(shape[0], pitch[0] * 1e3)[:, None], sfft.rfftfreq(shape[1], pitch[1] * 1e3)[None, :])
    expected = np.stack([defocus_otf(rho * lam * 1e-6 * n_f, w) for lam, w in zip(WL, waves)])
    assert np.max(np.abs(np.einsum("nr,hwr->nhw", v, u) - expected)) <= 2 * OTF_TOLERANCE


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("settings", [
    dict(f_stop=4.0),
    dict(f_stop=11.0, defocus=0.3),
    dict(f_stop=8.0, relative_illumination=True, vignetting=0.4,
         lens_transmittance=cs.spectra.Spectrum([400.0, 700.0], [0.6, 0.95])),
])
def test_fused_stage_gives_the_optics_then_sensor_image(cacaphony, dcs200_ir, dtype, settings, no_fallback):
    scene = Scene(cacaphony.data.astype(dtype), cacaphony.wavelengths, distance=cacaphony.distance,
                  angular_resolution=cacaphony.angular_resolution)
    cam = dcs200_ir.replace(distance=3.32, optics="diffraction", **settings)
    image = image_from_scene(scene)
    exact = exact_pair(cam.replace(architecture=(optics,) + DEFAULT_ARCHITECTURE), image)
    out = lens_sensor_responses(cam, image)
    assert out.data.dtype == dtype and out.data.shape == exact.data.shape and out.space == "sensor"
    assert out.history[-2:] == ("optics", "sensor_responses") and out.gain == exact.gain
    np.testing.assert_array_equal(out.sensitivities, exact.sensitivities)
    scale = np.abs(exact.data).max()
    assert np.max(np.abs(out.data - exact.data)) <= 3 * OTF_TOLERANCE * scale  # the OTF's error, spread over the image
    assert not np.allclose(exact.data, sensor_responses(cam, image).data, rtol=1e-3)  # and the lens did blur


def test_fused_stage_of_a_photon_counting_camera(cacaphony, no_fallback):
    """The IMX174 sheet: quanta sensitivities, the working f-number's (1 + m)^-2 and cos^4 on the output."""
    cam = cs.load_camera("imx174").replace(distance=3.32, relative_illumination=True)
    image = image_from_scene(cacaphony)
    exact = exact_pair(cam, image)
    out = lens_sensor_responses(cam, image)
    np.testing.assert_allclose(out.sensitivities, exact.sensitivities, rtol=1e-12)
    assert np.max(np.abs(out.data - exact.data)) <= 3 * OTF_TOLERANCE * np.abs(exact.data).max()


def test_a_uniform_field_keeps_its_responses(dcs200_ir, no_fallback):
    """The low-rank OTF is 1 at zero frequency at every wavelength and the planes are mirror-padded:
    nothing of a uniform field is lost or made, whatever the spectrum (to the float32 transforms' rounding)."""
    spectrum = np.linspace(0.01, 0.03, WL.size)
    scene = Scene(np.broadcast_to(spectrum, (60, 80, WL.size)).copy(), WL, distance=3.32, angular_resolution=(102.6, 102.6))
    cam = dcs200_ir.replace(distance=3.32, optics="diffraction", f_stop=11.0)
    flat = sensor_responses(cam, image_from_scene(scene)).data
    np.testing.assert_allclose(lens_sensor_responses(cam, image_from_scene(scene)).data, flat, rtol=1e-6)


def test_a_camera_whose_fused_form_costs_more_is_blurred_plane_by_plane(cacaphony):
    """Eight sensors on a grid that holds the OTF's cutoff (the phone's 0.8 um samples at f/8, where the
    cutoff moving with the wavelength needs ~12 terms): 8 x 12 + 8 transforms would exceed the optics stage's
    2 x 31, so the stage runs the optics stage and gives its image exactly."""
    from camsim_core.datasets.sensors import Sensors

    centres = np.linspace(420.0, 680.0, 8)
    gauss = np.exp(-0.5 * ((WL[None, :] - centres[:, None]) / 20.0) ** 2)
    cam = cs.load_camera("phone-1.4um").replace(distance=3.32, f_stop=8.0, mosaic=None,
                                                 sensors=Sensors(WL, gauss, tuple("ABCDEFGH"), "Quanta"))
    image = image_from_scene(cacaphony)
    np.testing.assert_array_equal(lens_sensor_responses(cam, image).data, exact_pair(cam, image).data)


def test_a_camera_with_optics_gets_the_fused_stage_in_place_of_the_sensor_stage(cacaphony, dcs200_ir):
    assert dcs200_ir.architecture == DEFAULT_ARCHITECTURE
    cam = dcs200_ir.replace(optics="diffraction", distance=3.32)
    assert cam.architecture == (lens_sensor_responses,) + DEFAULT_ARCHITECTURE[1:]
    explicit = cam.replace(architecture=(optics,) + DEFAULT_ARCHITECTURE)  # named: kept as it is
    assert explicit.architecture == (optics,) + DEFAULT_ARCHITECTURE
    off = cam.replace(optics="none", bits=None)  # the fused stage without optics is the sensor stage
    np.testing.assert_array_equal(cs.simulate(cacaphony, off).data, cs.simulate(cacaphony, dcs200_ir.replace(bits=None, distance=3.32)).data)
    a = cs.simulate(cacaphony, cam.replace(bits=None)).data
    b = cs.simulate(cacaphony, explicit.replace(bits=None)).data
    assert np.max(np.abs(a - b)) <= 3 * OTF_TOLERANCE * np.abs(b).max()


@pytest.mark.parametrize("wavelength", [450.0, 550.0, 650.0])
def test_slanted_edge_mtf_through_the_fused_stage_is_the_diffraction_mtf(wavelength, no_fallback):
    """A camera's default lens stage, measured as ISO 12233 measures a lens: a 5 degree edge on a 31-plane
    scene sampled at 0.5 um (the grid holds the whole OTF, so ~12 terms), one sensor that sees only
    ``wavelength``; e-SFR divided by the chart's pixel-aperture sinc against Goodman's formula up to 0.8 cutoff."""
    from camsim_core.datasets.sensors import Sensors
    from camsim_core.metrics.sharpness import slanted_edge_mtf
    from camsim_core.scene.charts import edge_coverage

    n, pitch, n_f, dist, focal = 384, 0.5e-6, 4.0, 1.05, 50.0
    phi = 1.0 / np.degrees(np.arctan(pitch / (focal * 1e-3 / (dist - focal * 1e-3)) / dist))
    left = edge_coverage((n, n), 5.0)
    data = np.repeat((0.2 * left + 0.8 * (1 - left))[:, :, None], WL.size, axis=2)
    scene = Scene(data, WL, distance=dist, angular_resolution=(phi, phi))
    sensor = Sensors([wavelength - 10, wavelength, wavelength + 10], [[0.0, 1.0, 0.0]], ("S",), "Watts")
    cam = cs.Camera(sensors=sensor, focal_length=focal, distance=dist, f_stop=n_f, bits=None, optics="diffraction")
    out = lens_sensor_responses(cam, image_from_scene(scene)).data[:, :, 0]
    f, m = slanted_edge_mtf(out[16:-16, 16:-16], max_frequency=0.5)  # cycles per sample
    v = f / (pitch * 1e3) * wavelength * 1e-6 * n_f * (1 + focal * 1e-3 / (dist - focal * 1e-3))  # N (1 + m)
    keep = v <= 0.8
    np.testing.assert_allclose(m[keep] / np.sinc(f[keep]), airy_mtf(v[keep]), atol=0.02)
