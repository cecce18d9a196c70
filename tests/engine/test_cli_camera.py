"""The command line builds the camera the explorer and its parameters files build.

``camsim measure`` and ``camsim simulate`` set ``--bits`` and ``--distance`` through
:func:`camsim_core.camera.physical.with_settings`, the function behind
:func:`camsim_core.review.camera_from_params`. With ``Camera.replace`` they built another electron-level
camera: imx174 at 8 bits converted 7.81 e-/DN (the 12-bit sheet's, clipping at a sixteenth of its
32,000 e- full well) where the explorer converts 32,000 / 255 = 125.5, its pixel angle stayed that at
infinity (35.74 px/deg where the explorer's at 2 m is 35.96), and ``--bits 0`` (unquantized in the
parameters files and the explorer) was refused.
"""

import json

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.cli import main
from camsim_core.datasets import asset_path
from camsim_core.review import camera_from_params

#: The electron-level cameras and a distance other than the scenes' 1 m (and the explorer's 3.32 m).
PHYSICAL = ("imx174", "phone-1.4um")
DISTANCE = 2.0
#: A uniform field of 32 x 32 samples at 4.5 per degree (7.1 degrees): about 257 x 257 imx174 pixels at 1 m,
#: enough samples for a noise estimate within about 1 %.
FIELD = "uniform:size=32,angular_resolution=4.5"


def _sheet(name):
    return json.loads((asset_path("sensors") / f"{name}.json").read_text())


@pytest.fixture
def measured_camera(monkeypatch):
    """Run ``camsim measure ARGS`` and return the camera it measured (the report itself is not computed)."""
    import camsim_core.metrics.report as report

    seen = {}

    def capture(scene, camera, *args, **kwargs):
        seen["camera"] = camera
        return {}

    monkeypatch.setattr(report, "quality_report", capture)

    def run(*args):
        assert main(["measure", "--scene", "uniform", *args]) == 0
        return seen["camera"]

    return run


@pytest.mark.parametrize("bits", [0, 8, 12])
@pytest.mark.parametrize("name", PHYSICAL)
def test_measure_camera_is_the_explorers(measured_camera, name, bits):
    cli = measured_camera("--camera", name, "--bits", str(bits), "--distance", str(DISTANCE), "--exposure", "0.05",
                          "--f-stop", "4", "--seed", "0", "--noise-sigma", "0")
    explorer = camera_from_params(dict(camera=name, bits=bits, distance=DISTANCE, exposure=0.05, f_stop=4.0, seed=0))
    assert cli.describe() == explorer.describe()  # every field: sensors, mosaic, optics, noise, sensor, ADC
    # and the numbers that differed, from the sensor sheet by hand
    sheet = _sheet(name)
    full_well = sheet["full_well"]
    assert cli.full_well == explorer.full_well == full_well
    assert cli.bits == explorer.bits == (bits or None)
    adc_bits = bits or sheet["bits"]  # unquantized: the sheet's conversion gain, no ADC clipping
    assert cli.electrons_per_dn == pytest.approx(full_well / (2**adc_bits - 1), rel=1e-12)
    assert cli.electrons_per_dn == explorer.electrons_per_dn
    f, pitch = sheet["focal_length_mm"] * 1e-3, sheet["pixel_pitch_um"] * 1e-6
    m = f / (DISTANCE - f)  # the thin lens's magnification at the focus distance
    phi = 1.0 / np.degrees(np.arctan(pitch / (f * (1.0 + m))))
    assert cli.angular_resolution == pytest.approx((phi, phi), rel=1e-12)
    assert cli.angular_resolution == explorer.angular_resolution
    assert cli.distance == DISTANCE


def test_measure_camera_without_a_distance_is_at_the_scenes(measured_camera):
    """No ``--distance``: the simulation uses the scene's (1 m), and the pixel angle is the one there."""
    cli = measured_camera("--camera", "imx174", "--bits", "8", "--exposure", "0.05", "--f-stop", "4", "--seed", "0",
                          "--noise-sigma", "0")
    explorer = camera_from_params(dict(camera="imx174", bits=8, distance=1.0, exposure=0.05, f_stop=4.0, seed=0))
    assert cli.describe() == explorer.describe()


def test_measure_chapter_camera_is_unchanged(measured_camera):
    """A camera in digital units has no full well: ``--bits`` only sets its ADC (``--bits 0``: none)."""
    for bits in (0, 12):
        cli = measured_camera("--camera", "kodak-dcs200", "--bits", str(bits), "--distance", str(DISTANCE))
        assert cli.bits == (bits or None) and cli.electrons_per_dn == 1.0
        assert cli.angular_resolution == cs.load_camera("kodak-dcs200").angular_resolution


@pytest.mark.parametrize("bits", [0, 8])
def test_simulate_writes_the_explorers_raw(tmp_path, bits):
    """``camsim simulate`` records what the explorer's camera records, to the value (same seed)."""
    out = tmp_path / "raw.npy"
    assert main(["simulate", "--scene", "uniform:size=32,angular_resolution=9", "--camera", "imx174", "--bits", str(bits),
                 "--distance", str(DISTANCE), "--exposure", "0.3", "--f-stop", "8", "--seed", "3", "--out", str(out),
                 "--no-progress"]) == 0
    cam = camera_from_params(dict(camera="imx174", bits=bits, distance=DISTANCE, exposure=0.3, f_stop=8.0, seed=3))
    expected = cs.simulate(cs.load_scene("uniform:size=32,angular_resolution=9"), cam)
    written = np.load(out)
    assert written.shape == expected.data.shape
    np.testing.assert_array_equal(written, expected.data)
    if bits:  # an 8-bit readout of the full well, not clipped at a sixteenth of it
        assert written.max() < 255


def _physics_snr(sheet, mean_dn, exposure, bits=8):
    """SNR (linear) of a pixel of mean ``mean_dn`` DN from the sensor sheet alone: photon shot noise of the
    photo-electrons, dark current's shot noise, read noise and DSNU, PRNU, and the ADC's step^2 / 12, with the
    ADC spanning the full well at ``bits`` (analog gain 1)."""
    e_per_dn = sheet["full_well"] / (2**bits - 1)
    dark = sheet["dark_current"] * exposure
    electrons = mean_dn * e_per_dn - dark  # the photo-electrons (the dark signal is in the mean too)
    variance = (electrons + dark + sheet["read_noise"] ** 2 + sheet["dsnu"] ** 2 + (sheet["prnu"] * electrons) ** 2
                + e_per_dn**2 / 12.0)
    return electrons / np.sqrt(variance)


@pytest.mark.parametrize("name, exposure, f_stop", [("imx174", 0.5215, 11.0), ("phone-1.4um", 0.1, 2.9)])
def test_measure_snr_at_8_bits_is_the_sensors_physics(tmp_path, capsys, name, exposure, f_stop):
    """imx174 at 8 bits, 0.5215 s, f/11 (the exposure the explorer's auto exposure chose): ``camsim measure``
    read 255 DN, saturated, SNR inf (its 7.81 e-/DN clipped at 1,992 e-); the sheet gives 41.7 dB at the
    explorer's 195 DN. Auto exposure too read 10 dB below the physics (32.0 dB)."""
    out = tmp_path / "snr.json"
    assert main(["measure", "--scene", FIELD, "--camera", name, "--bits", "8", "--exposure", str(exposure),
                 "--f-stop", str(f_stop), "--json", str(out)]) == 0
    sheet = _sheet(name)
    channels = json.loads(out.read_text())["snr"]["channels"]
    for channel in "RGB":
        ch = channels[channel]
        assert not ch["saturated"] and 100 < ch["mean"] < 250
        assert ch["snr"] == pytest.approx(_physics_snr(sheet, ch["mean"], exposure), rel=0.04), channel
    # and with the command line's own auto exposure, the same physics
    assert main(["measure", "--scene", FIELD, "--camera", name, "--bits", "8", "--f-stop", str(f_stop),
                 "--json", str(out)]) == 0
    g = json.loads(out.read_text())["snr"]["channels"]["G"]
    assert 150 < g["mean"] < 250  # 90 % of the full scale at the brightest 0.5 %, less the lens's fall-off
    # (the exposure time only for the dark current's few electrons)
    auto = cs.auto_exposure(cs.load_scene(FIELD), camera_from_params(dict(camera=name, bits=8, distance=1.0, f_stop=f_stop)))
    assert g["snr"] == pytest.approx(_physics_snr(sheet, g["mean"], auto), rel=0.04)


def test_bits_0_is_unquantized_on_the_command_line(tmp_path, measured_camera):
    """``--bits 0`` is unquantized, as in the parameters files and the explorer (the CLI refused it: "1 to 32")."""
    assert measured_camera("--camera", "imx174", "--bits", "0").bits is None
    out = tmp_path / "raw.npy"
    assert main(["simulate", "--scene", "uniform", "--camera", "kodak-dcs200", "--bits", "0", "--out", str(out),
                 "--no-progress"]) == 0
    data = np.load(out)
    assert data.dtype.kind == "f" and not np.all(data == np.round(data))
    # a DNG holds quantized raw values: --bits 0 is refused for it as --unquantized is
    assert main(["simulate", "--scene", "uniform", "--camera", "imx174", "--bits", "0", "--out", str(tmp_path / "r.dng"),
                 "--no-progress"]) == 2
    assert not (tmp_path / "r.dng").exists()


def test_snr_vs_light_marks_a_channel_saturated_at_the_full_well():
    """Unquantized, imx174's G at 100 cd/m^2 and 0.05 s reaches its full well (32,000 e- x K DN/e-, from its
    sheet): its SNR was the clipped field's (72.9 dB printed). NaN, as the function says of a saturated channel;
    R and B, below the well, and G at 10 cd/m^2 are measured."""
    from camsim_core.metrics.snr import snr_vs_light
    from camsim_core.scene.charts import uniform_scene

    cam = cs.load_camera("imx174").replace(bits=None, height=64, width=64, seed=0)
    field = cs.simulate(uniform_scene(64, luminance=100.0, angular_resolution=cam.angular_resolution), cam,
                        exposure=0.05).data
    well = cam.full_well * cam.analog_gain / cam.electrons_per_dn  # DN at the full well, from the sheet
    assert np.asarray(field, float).max() >= 0.99 * well  # the field does reach the well
    out = snr_vs_light(cam, [10.0, 100.0], exposure=0.05)
    assert np.isnan(out["G"][1]) and np.isfinite(out["G"][0])
    assert np.all(np.isfinite(out["R"])) and np.all(np.isfinite(out["B"]))


def test_simulate_at_a_distance_samples_as_the_explorer_does():
    """``simulate(scene, imx174, distance=0.3)`` kept the pixel angle of a lens focused at infinity (35.74
    px/deg) where the explorer's camera at 0.3 m has the angle of its image distance f (1 + m): 4 % more."""
    scene = cs.load_scene("uniform")
    cam = cs.load_camera("imx174")
    raw = cs.simulate(scene, cam, distance=0.3, exposure=0.01, seed=0)
    explorer = camera_from_params({"camera": "imx174", "distance": 0.3})
    m = cam.focal_length / (300.0 - cam.focal_length)
    np.testing.assert_allclose(raw.angular_resolution, explorer.angular_resolution, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(raw.angular_resolution) / np.asarray(cam.angular_resolution), 1 + m, rtol=2e-3)
