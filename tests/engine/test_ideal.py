"""The ideal comparison image (chapter section 4.3)."""

import colour
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.camera import camera_preset
from camsim_core.rendering import ideal_camera
from camsim_core.scene import Scene, macbeth_scene


@pytest.fixture(scope="module")
def monitor():
    return cs.load_monitor("simtoolbox-test")


def test_ideal_has_camera_geometry_and_cones(monitor):
    scene = macbeth_scene("D65", patch_size=10, border=2)
    cam = camera_preset("kodak-dcs200-ir", noise_sigma=3.0)
    raw = cs.simulate(scene, cam, exposure=0.05)
    # the default (the scene's reference): the camera's pixel grid, the monitor's frame-buffer scale, not quantized
    scene_ideal = cs.ideal_image(scene, cam, monitor, exposure=0.05)
    assert scene_ideal.data.shape == raw.data.shape + (3,)  # same spatial resolution as the camera image
    assert scene_ideal.space == "monitor" and scene_ideal.bits == 8 and not scene_ideal.quantized
    assert scene_ideal.angular_resolution == raw.angular_resolution
    assert scene_ideal.extra["reference"] == "scene" and not np.array_equal(scene_ideal.data, np.rint(scene_ideal.data))
    # the chapter's reference (section 4.3): the cone camera quantized like the camera
    ideal = cs.ideal_image(scene, cam, monitor, exposure=0.05, reference="chapter")
    assert ideal.data.shape == raw.data.shape + (3,)  # same spatial resolution as the camera image
    assert ideal.space == "monitor" and ideal.bits == 8 and ideal.quantized and ideal.extra["reference"] == "chapter"
    assert ideal.angular_resolution == raw.angular_resolution
    icam = ideal_camera(cam)
    assert icam.mosaic is None and icam.noise_sigma == 0 and icam.bits == cam.bits
    assert np.array_equal(icam.sensors.values, camera_preset("human-cones").sensors.values)
    # noiseless: the same picture twice is identical, and a uniform patch stays uniform
    again = cs.ideal_image(scene, cam, monitor, exposure=0.05, seed=7, reference="chapter")
    assert np.array_equal(ideal.data, again.data)
    with pytest.raises(cs.ParameterError, match="reference"):
        cs.ideal_image(scene, cam, monitor, reference="camera")


def test_ideal_white_is_colorimetric_and_fills_the_display(monitor):
    """A perfect white reflector renders at the top of the monitor's range with the light's chromaticity.

    The display-scale rule maps the cone rendering of the scene illuminant's white to full scale in
    the strongest channel; the cones are (nearly) a linear transform of the CIE 1931 functions,
    so the displayed white has the chromaticity of the illuminant (colour-science's, for CIE A).
    """
    import colour as c

    w = np.arange(400, 701, 10.0)
    a = c.SDS_ILLUMINANTS["A"].copy().align(c.SpectralShape(400, 700, 10)).values
    e = a / a.max() * 0.05
    from camsim_core.spectra import Spectrum

    scene = Scene(np.broadcast_to(e, (20, 20, w.size)).copy(), w, 1.0, (102.6, 102.6), illuminant=Spectrum(w, e, "A"))
    cam = camera_preset("kodak-dcs200")
    ideal = cs.ideal_image(scene, cam, monitor, exposure=cs.auto_exposure(scene, cam, target=0.8))
    assert ideal.data.max() >= 254
    xy = colour.XYZ_to_xy(cs.to_xyz(ideal, monitor)[10, 10])
    xy_a = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["A"]
    assert np.linalg.norm(xy - xy_a) < 0.01


def test_ideal_is_independent_of_camera_sensors(monitor):
    """The ideal image depends on the camera's geometry only, not on its sensors or noise."""
    scene = macbeth_scene("D65", patch_size=8, border=2)
    a = cs.ideal_image(scene, camera_preset("kodak-dcs200"), monitor, exposure=0.05)
    b = cs.ideal_image(scene, camera_preset("gaussian-4", noise_sigma=5.0), monitor, exposure=0.05)
    assert np.array_equal(a.data, b.data)


def test_the_ideal_camera_reads_no_file(monkeypatch):
    """The explorer builds the ideal camera on every move: the shipped camera file behind the presets'
    geometry is read once per process, not per camera (every preset is frozen, its arrays read-only)."""
    from camsim_core.camera import load

    load._dcs200_geometry.cache_clear()
    reads = []
    real = load.read_scam
    monkeypatch.setattr(load, "read_scam", lambda path: reads.append(path) or real(path))
    cam = camera_preset("kodak-dcs200-ir")
    for exposure in (0.05, 0.06, 0.07):
        ideal_camera(cam.replace(exposure=exposure))
    assert len(reads) == 1
    assert not cam.sensors.values.flags.writeable and not cam.mosaic.flags.writeable
