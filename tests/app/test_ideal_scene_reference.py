"""The ideal image is the scene's, not the camera's (issue 37): checked against physics and against
computations made here with colour-science, not with the engine's colour code.

The scene's reference (``camsim_core.ideal_image``'s default, the explorer's) is the scene through the
human cones on the camera image's pixel grid: an ideal lens, no noise, no pedestal, unquantized, normalised
by the scene's white. Nothing the camera does to the light (exposure, f-number, bit depth, noise, black
level, optics) may change it; a noiseless, unquantized camera whose sensors are the cones must render it
(to the display's 8-bit rounding); its white is the scene's white.
"""

import colour
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.cache import Pipeline, Processing
from camsim_core.camera import camera_preset
from camsim_core.scene import Scene, scale_light
from camsim_core.spectra import Spectrum

MONITOR = cs.load_monitor("simtoolbox-test")
CIE1931 = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
SMITH_POKORNY = colour.MSDS_CMFS["Smith & Pokorny 1975 Normal Trichromats"]
CIELAB = Processing(metrics=("cielab",))


def _on(msds, wavelengths):
    """(3, N) colour-science functions on ``wavelengths`` (linear interpolation, zero outside)."""
    return np.stack([np.interp(wavelengths, msds.wavelengths, msds.values[:, i], left=0.0, right=0.0)
                     for i in range(3)])


def _phosphors(values):
    """Linear phosphor intensities of frame-buffer values, by the monitor's calibration table."""
    return MONITOR.settings_to_linear(np.asarray(values, float) / float(2**MONITOR.bits - 1))


def _xyz(values):
    """XYZ (cd/m^2) of frame-buffer values on the monitor: 683 x CIE 1931 (colour-science) x B_M x phosphors."""
    m = 683.0 * _on(CIE1931, MONITOR.wavelengths) @ MONITOR.primaries
    return _phosphors(values) @ m.T


def _lab(xyz):
    white = _xyz(np.full(3, 2.0**MONITOR.bits - 1))
    return colour.XYZ_to_Lab(xyz / white[1], colour.XYZ_to_xy(white))


def _delta_e(a, b):
    """CIE 1976 dE*ab between two rendered images, computed here with colour-science."""
    return colour.delta_E(_lab(_xyz(a)), _lab(_xyz(b)), method="CIE 1976")


@pytest.fixture(scope="module")
def scene():
    return cs.load_scene("cacaphony290")


@pytest.fixture(scope="module")
def chapter_camera():
    """The chapter's setting: the DCS-200 with its IR filter, 3.32 m, 0.1 s, f/11."""
    return cs.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0)


def _variants(cam):
    """The camera at 0.1 and 1.6 s, 8 and 12 bits, with and without noise and a pedestal, at other f-numbers,
    with a diffraction-limited lens and vignetting."""
    return {
        "as is": cam,
        "1.6 s": cam.replace(exposure=1.6),
        "12 bits": cam.replace(bits=12),
        "12 bits, 1.6 s": cam.replace(bits=12, exposure=1.6),
        "unquantized": cam.replace(bits=None),
        "noise 5 DN": cam.replace(noise_sigma=5.0, seed=3),
        "pedestal 16 DN": cam.replace(black_level=16.0),
        "noise and pedestal, 12 bits": cam.replace(noise_sigma=5.0, black_level=64.0, bits=12, seed=1),
        "f/4": cam.replace(f_stop=4.0),
        "f/22, 1.6 s": cam.replace(f_stop=22.0, exposure=1.6),
        "diffraction, vignetting": cam.replace(optics="diffraction", relative_illumination=True, vignetting=0.3),
    }


def test_the_ideal_image_does_not_change_with_the_camera(scene, chapter_camera):
    """Physics: the scene and the observer are the same, so the reference is the same, bit for bit, at 0.1 and
    1.6 s, 8 and 12 bits, with and without noise and pedestal, at any f-number and lens; directly and through
    the explorer's pipeline. The chapter's reference (the cone camera at the camera's exposure) is not."""
    direct = {k: cs.ideal_image(scene, cam, MONITOR) for k, cam in _variants(chapter_camera).items()}
    ref = np.asarray(direct["as is"].data)
    ref_xyz = _xyz(ref)
    for name, image in direct.items():
        assert np.array_equal(np.asarray(image.data), ref), name
        assert np.allclose(_xyz(image.data), ref_xyz, rtol=1e-6, atol=0), name
    p = Pipeline()
    for name, cam in _variants(chapter_camera).items():
        r = p.run(scene, cam, CIELAB)
        assert r.errors == {}, (name, r.errors)
        assert np.array_equal(np.asarray(r.ideal.data), ref), name
    # an explicit keyword exposure or f-stop (the camera's settings for one picture) changes nothing either
    assert np.array_equal(np.asarray(cs.ideal_image(scene, chapter_camera, MONITOR, exposure=1.6, f_stop=4.0).data), ref)
    # what the issue measured: the chapter's reference moves with the exposure (88 % of XYZ at most)
    a = _xyz(cs.ideal_image(scene, chapter_camera, MONITOR, reference="chapter").data)
    b = _xyz(cs.ideal_image(scene, chapter_camera.replace(exposure=1.6), MONITOR, reference="chapter").data)
    assert np.max(np.abs(a - b) / np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-9)) > 0.5


def test_a_quantal_camera_gets_the_same_reference_at_any_exposure_and_depth(scene):
    """A physical (quantal, diffraction-limited, cos^4) camera: its reference does not move either, and has the
    camera image's pixel grid (the issue: the IMX174's S-cone channel had 9 levels in the explorer)."""
    cam = cs.load_camera("imx174").replace(distance=3.32, exposure=0.1, f_stop=11.0, bits=8)
    raw = cs.simulate(scene, cam)
    ideal = cs.ideal_image(scene, cam, MONITOR)
    assert ideal.data.shape == raw.data.shape + (3,) and ideal.angular_resolution == raw.angular_resolution
    for moved in (cam.replace(exposure=0.01), cam.replace(bits=12, exposure=1.0), cam.replace(f_stop=2.8)):
        assert np.array_equal(np.asarray(cs.ideal_image(scene, moved, MONITOR).data), np.asarray(ideal.data))
    assert all(np.unique(np.asarray(ideal.data)[..., c]).size > 256 for c in range(3))


def test_more_than_256_values_per_channel_on_the_default_scene():
    """The explorer's default scene through its default camera: the reference is not quantized (the chapter's
    has at most 256 frame-buffer values per channel, fewer where the camera is dim)."""
    from camsim_explorer.state import ExplorerState

    state = ExplorerState()
    r = Pipeline().run(state.scene_object(), state.camera_object(), state.processing())
    assert r.errors == {}, r.errors
    data = np.asarray(r.ideal.data)
    assert not r.ideal.quantized and r.ideal.extra["reference"] == "scene"
    counts = [np.unique(data[..., c]).size for c in range(3)]
    assert min(counts) > 256, counts
    xyz = np.asarray(r.ideal_xyz)
    assert min(np.unique(xyz[..., c]).size for c in range(3)) > 256


@pytest.mark.parametrize("bits, exposure", [(None, 0.1), (None, 1.6), (12, "auto")])
def test_a_camera_whose_sensors_are_the_cones_renders_the_ideal_image(scene, bits, exposure):
    """Chapter section 5: a noiseless camera whose sensors are the cones, without a mosaic, matches the
    comparison image. Unquantized (or at 12 bits, well exposed) it does to the display's 8-bit rounding of its
    own rendering: dE*ab (colour-science, CIE 1976) of a fraction of a unit. The DCS-200 does not."""
    cam = camera_preset("human-cones").replace(bits=bits, distance=3.32, f_stop=11.0, noise_sigma=0.0)
    cam = cam.replace(exposure=cs.auto_exposure(scene, cam) if exposure == "auto" else exposure)
    raw = cs.simulate(scene, cam)
    rendered = cs.render(raw, MONITOR)
    ideal = cs.ideal_image(scene, cam, MONITOR)
    assert ideal.data.shape == rendered.data.shape
    if bits is None:  # the rendering rounds to integer frame-buffer values: half a step from the ideal image, at most
        assert np.abs(np.asarray(rendered.data, float) - np.asarray(ideal.data, float)).max() <= 0.5 + 1e-3
    de = _delta_e(rendered.data, ideal.data)
    assert de.mean() < 0.35 and np.percentile(de, 99) < 1.0 and de.max() < 1.5, (de.mean(), de.max())
    dcs = cs.load_camera("kodak-dcs200-ir").replace(bits=bits, distance=3.32, f_stop=11.0, exposure=cam.exposure,
                                                    mosaic=None)
    assert _delta_e(cs.render(cs.simulate(scene, dcs), MONITOR).data, ideal.data).mean() > 5.0


@pytest.mark.parametrize("illuminant", ["D65", "A", "FL2"])
def test_a_white_patch_has_the_scenes_white_up_to_one_scale(illuminant):
    """Strips of a perfect white reflector and of 50 % and 20 % greys under an illuminant: the monitor light of
    the ideal image is the scene's light up to one global scale, for the cones (colour-science's Smith &
    Pokorny fundamentals: within 1e-4) and in CIE 1931 XYZ to the difference between those cones' observer
    (Judd-Vos) and CIE 1931's (a few per cent in X and Z, 0.01 in xy). The white fills the display's strongest
    channel (the exposure normalisation)."""
    w = np.arange(400, 701, 10.0)
    e = colour.SDS_ILLUMINANTS[illuminant].copy().align(colour.SpectralShape(400, 700, 10)).values
    e = e / e.max() * 0.05  # W/sr/m^2 per 10 nm band
    reflectance = np.ones((12, 30))
    reflectance[:, 10:20], reflectance[:, 20:] = 0.5, 0.2
    radiance = reflectance[..., None] * e
    scene = Scene(radiance, w, 1.0, (102.6, 102.6), illuminant=Spectrum(w, e, illuminant))
    cam = camera_preset("kodak-dcs200").replace(height=12, width=30)  # the scene's own grid: 1:1
    ideal = np.asarray(cs.ideal_image(scene, cam, MONITOR, exposure=0.001).data, float)
    assert ideal.shape == (12, 30, 3)
    assert np.max(ideal[:, :10]) == pytest.approx(2.0**MONITOR.bits - 1, abs=1e-3)  # the white at full scale
    # the monitor's light on the scene's sampling (per 10 nm band: the 4 nm bands' power times 10 / 4)
    step = float(np.mean(np.diff(MONITOR.wavelengths)))
    b_m = np.stack([np.interp(w, MONITOR.wavelengths, MONITOR.primaries[:, c]) for c in range(3)], axis=1) * (10 / step)
    light = _phosphors(ideal) @ b_m.T  # (12, 30, N)
    for functions, tolerance in ((SMITH_POKORNY, 1e-4), (CIE1931, 0.06)):
        seen, truth = light @ _on(functions, w).T, radiance @ _on(functions, w).T
        k = seen[0, 0, 1] / truth[0, 0, 1]  # one scale for every pixel and every channel
        assert np.allclose(seen, k * truth, rtol=tolerance, atol=0), (functions.name, seen[0, 0] / truth[0, 0] / k)
    xy = colour.XYZ_to_xy(light[0, 0] @ _on(CIE1931, w).T)
    assert np.linalg.norm(xy - colour.XYZ_to_xy(e @ _on(CIE1931, w).T)) < 0.01
    # the engine's XYZ of the white patch has nearly the same chromaticity (it also counts the monitor's light
    # from 380 to 400 and 700 to 780 nm, outside the scene's range, which the cones' match does not constrain)
    engine = np.asarray(cs.to_xyz(cs.ideal_image(scene, cam, MONITOR), MONITOR))[5, 5]
    assert np.linalg.norm(colour.XYZ_to_xy(engine) - colour.XYZ_to_xy(e @ _on(CIE1931, w).T)) < 0.015


def test_the_light_level_and_a_missing_illuminant_leave_the_ideal_image_as_it_is(scene, chapter_camera):
    """The reference is normalised by the scene's white: four times the light (and its illuminant) gives the
    same image; without an illuminant, the brightest white (a patch over 0.5 % of the pixels) takes its place."""
    ideal = np.asarray(cs.ideal_image(scene, chapter_camera, MONITOR).data)
    brighter = np.asarray(cs.ideal_image(scale_light(scene, 4.0), chapter_camera, MONITOR).data)
    assert np.allclose(brighter, ideal, rtol=1e-6, atol=1e-6)
    w = np.arange(400, 701, 10.0)
    e = colour.SDS_ILLUMINANTS["D65"].copy().align(colour.SpectralShape(400, 700, 10)).values / 100.0
    reflectance = np.full((40, 40), 0.3)
    reflectance[:8, :8] = 1.0  # 4 % of the pixels: a perfect white reflector
    lit = Scene(reflectance[..., None] * e, w, 1.0, (102.6, 102.6), illuminant=Spectrum(w, e, "D65"))
    dark = Scene(reflectance[..., None] * e, w, 1.0, (102.6, 102.6))
    cam = camera_preset("kodak-dcs200").replace(height=40, width=40)
    known = cs.ideal_image(lit, cam, MONITOR)
    found = cs.ideal_image(dark, cam, MONITOR)
    assert found.extra["scale_source"].startswith("scene's brightest white")
    assert np.allclose(np.asarray(found.data), np.asarray(known.data), rtol=1e-6, atol=1e-4)


def test_the_chapter_reference_stays_the_chapter_cone_camera(scene, chapter_camera):
    """``reference="chapter"``: the cone camera simulated at the camera's exposure, quantized like it and rendered
    (section 4.3), as the chapter's experiments use it: composed here from the public stages."""
    from camsim_core.rendering import ideal_camera

    chapter = cs.ideal_image(scene, chapter_camera, MONITOR, reference="chapter")
    composed = cs.render(cs.simulate(scene, ideal_camera(chapter_camera)), MONITOR)
    assert np.array_equal(np.asarray(chapter.data), np.asarray(composed.data))
    assert chapter.quantized and chapter.extra["reference"] == "chapter"
    r = Pipeline().run(scene, chapter_camera, Processing(metrics=("cielab",), reference="chapter"))
    assert np.array_equal(np.asarray(r.ideal.data), np.asarray(chapter.data))
    bad = Pipeline().run(scene, chapter_camera, Processing(metrics=("cielab",), reference="nonsense"))
    assert "reference" in bad.errors["ideal"] and bad.rendered is not None and bad.delta_e is None


def test_the_rendering_is_eq_1_4_unquantized_and_its_xyz_is_to_xyzs():
    """The Macbeth chart on its own grid (1:1): the ideal image is Eq. 1.4 with the cones, divided by the white's
    strongest setting, gamma corrected by the monitor's table and not rounded, computed here with numpy; its XYZ
    (the compiled pass the explorer uses) is to_xyz's to float32 rounding, over one chunk of pixels and over many."""
    from camsim_core.rendering.ideal import ideal_xyz
    from camsim_core.scene import macbeth_scene

    scene = macbeth_scene("D65", patch_size=12, border=3)
    h, w = scene.data.shape[:2]
    cam = camera_preset("kodak-dcs200").replace(height=h, width=w, angular_resolution=scene.angular_resolution,
                                                distance=scene.distance)
    ideal = cs.ideal_image(scene, cam, MONITOR)
    wl = scene.wavelengths
    t_h = camera_preset("human-cones").sensors.on(wl)  # (3, N)
    b_m = MONITOR.primaries_on(wl)  # (N, 3) per band
    to_settings = np.linalg.inv(t_h @ b_m)
    white = to_settings @ (t_h @ scene.illuminant.per_band(wl))
    linear = np.clip(np.asarray(scene.data, float) @ t_h.T @ to_settings.T / white.max(), 0.0, 1.0)
    expected = MONITOR.linear_to_settings(linear) * 255.0
    assert np.abs(np.asarray(ideal.data, float) - expected).max() < 1e-4
    assert ideal.data.dtype == scene.data.dtype and not ideal.quantized
    for image in (ideal, ideal.replace(data=np.tile(np.asarray(ideal.data), (12, 12, 1)))):  # > 262144 pixels
        fast, slow = ideal_xyz(image, MONITOR), np.asarray(cs.to_xyz(image, MONITOR))
        assert fast.dtype == slow.dtype
        assert np.allclose(fast, slow, rtol=1e-6, atol=1e-9)
    quantized = cs.ideal_image(scene, cam, MONITOR, quantize=True)
    assert quantized.quantized and np.array_equal(quantized.data, np.rint(quantized.data))
    assert np.array_equal(ideal_xyz(quantized, MONITOR), np.asarray(cs.to_xyz(quantized, MONITOR)))
    assert np.abs(np.asarray(quantized.data, float) - expected).max() <= 0.5 + 1e-6
