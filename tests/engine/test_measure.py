"""camsim measure and the quality report: physics through the whole pipeline, and the command line."""

import json

import numpy as np
import pytest

import camsim_core as cs
from camsim_core.cli import main
from camsim_core.metrics.report import quality_report


def test_full_colour_camera_edge_mtf_is_the_pixel_aperture():
    # no mosaic, no noise, no blur: the resample stage averages each camera pixel's area, a 1 px box,
    # whose MTF perpendicular to a 5 degree edge is sinc(f cos 5) sinc(f sin 5)
    cam = cs.load_camera("kodak-dcs200-ir").replace(mosaic=None, bits=None, noise_sigma=0.0)
    res = quality_report("slanted-edge", cam, ("mtf",), exposure=0.05)["mtf"]["luminance"]
    f = np.asarray(res["frequency"])
    c, s = np.cos(np.radians(5)), np.sin(np.radians(5))
    box = np.sinc(f * c) * np.sinc(f * s)
    assert np.abs(np.asarray(res["mtf"]) - box)[f <= 0.5].max() < 0.01
    assert res["mtf50"] == pytest.approx(0.603, abs=0.006)


def test_bayer_demosaic_lowers_red_mtf_below_green():
    rep = quality_report("slanted-edge", "kodak-dcs200-ir", ("mtf",), exposure=0.05)["mtf"]
    assert rep["R"]["mtf50"] < rep["G"]["mtf50"] < 0.603  # R sampled every other column and row


def test_cli_measure_snr_json(tmp_path, capsys):
    out = tmp_path / "snr.json"
    assert main(["measure", "--scene", "uniform:size=1024", "--noise-sigma", "2", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())
    for name in "RGB":
        ch = rep["snr"]["channels"][name]
        # 8-bit quantization adds 1/12 DU^2 to the noise variance
        assert ch["sigma"] == pytest.approx(np.sqrt(4 + 1 / 12), rel=0.06)
        assert ch["snr_db"] == pytest.approx(20 * np.log10(ch["mean"] / ch["sigma"]), abs=1e-6)
    assert "SNR dB" in capsys.readouterr().out


def test_cli_measure_mtf_of_a_dng_file(tmp_path, capsys):
    dng = tmp_path / "edge.dng"
    assert main(["simulate", "--scene", "slanted-edge", "--camera", "kodak-dcs200-ir", "--auto-exposure",
                 "--bits", "12", "--out", str(dng)]) == 0
    direct = quality_report("slanted-edge", cs.load_camera("kodak-dcs200-ir").replace(bits=12),
                            ("mtf",), exposure=cs.auto_exposure(cs.load_scene("slanted-edge"),
                                                                cs.load_camera("kodak-dcs200-ir").replace(bits=12)))
    out = tmp_path / "mtf.json"
    assert main(["measure", "--image", str(dng), "--what", "mtf", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())
    assert rep["mtf"]["G"]["mtf50"] == pytest.approx(direct["mtf"]["G"]["mtf50"], rel=1e-9)


def test_cli_measure_snr_of_a_file_is_measured_about_its_shading(tmp_path, capsys):
    """The SNR of a raw file is measured as the explorer and ``camsim measure --scene`` measure it, about the
    field's shading (``region_snr(detrend=True)``, checked against a synthetic fall-off in test_quality.py): the
    file's numbers are those of the same raw measured so in the process, not those with the shading counted."""
    from camsim_core.metrics.snr import region_snr

    from camsim_core.camera.physical import with_settings

    dng = tmp_path / "flat.dng"
    scene = cs.load_scene("uniform:size=512")
    # the camera ``camsim simulate`` builds: at the scene's distance (its pixel angle that at 1 m), as the explorer
    camera = with_settings(cs.load_camera("imx174"), bits=12, distance=scene.distance)
    exposure = cs.auto_exposure(scene, camera)
    assert main(["simulate", "--scene", "uniform:size=512", "--camera", "imx174", "--bits", "12",
                 "--exposure", repr(exposure), "--out", str(dng)]) == 0
    out = tmp_path / "snr.json"
    assert main(["measure", "--image", str(dng), "--what", "snr", "--json", str(out)]) == 0
    rep = json.loads(out.read_text())["snr"]
    assert rep["detrended"] is True
    raw = cs.simulate(scene, camera.replace(exposure=exposure))
    flat, shaded = region_snr(raw, detrend=True), region_snr(raw)
    for name in ("R", "G", "B"):
        assert rep["channels"][name]["sigma"] == pytest.approx(flat[name]["sigma"], rel=1e-9)
        assert flat[name]["sigma"] < shaded[name]["sigma"]  # the fall-off, however small here, left out


def test_cli_measure_bad_input(tmp_path, capsys):
    assert main(["measure", "--what", "sharpness"]) == 2
    assert "unknown measure" in capsys.readouterr().err
    assert main(["measure", "--image", str(tmp_path / "none.dng")]) == 2
    assert "no such file" in capsys.readouterr().err.lower()
    assert main(["measure", "--scene", "uniform", "--what", "mtf"]) == 2
    assert "no edge" in capsys.readouterr().err


def test_cli_snr_vs_light(tmp_path, capsys):
    out = tmp_path / "curve.json"
    assert main(["measure", "--snr-vs-light", "5,20", "--noise-sigma", "2", "--exposure", "0.5", "--bits", "12",
                 "--json", str(out)]) == 0
    curve = json.loads(out.read_text())["snr_vs_light"]
    assert curve["luminance"] == [5.0, 20.0]
    # additive noise: 4 x the light is 4 x the SNR, +12.04 dB
    assert curve["G"][1] - curve["G"][0] == pytest.approx(20 * np.log10(4), abs=0.6)
    assert "cd/m^2" in capsys.readouterr().out
