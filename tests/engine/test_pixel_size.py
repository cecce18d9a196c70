"""The pixel-size experiment (the chapter's section 6 question) on a small grid, and its building blocks."""

import csv

import numpy as np
import pytest

from camsim_core.cli import main as camsim
from camsim_core.cli import experiment as cli_experiment
from camsim_core.experiments import pixel_size as P
from camsim_core.image import image_from_scene
from camsim_core.metrics import scielab
from camsim_core.simulation import run_stages


def test_small_grid_in_process_writes_csv_plot_table_and_the_optimum_moves_with_light(tmp_path, capsys):
    out = tmp_path / "ps"
    status = camsim(["experiment", "pixel-size", "--pitches", "1.4,4", "--lux", "10,1000", "--workers", "0",
                     "--no-progress", "--out", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    with open(out / "pixel-size-summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(float(r["lux"]), float(r["pitch_um"])) for r in rows] == [(10, 1.4), (10, 4), (1000, 1.4), (1000, 4)]
    err = {(float(r["lux"]), float(r["pitch_um"])): float(r["mean"]) for r in rows}
    assert all(np.isfinite(v) and v > 0 for v in err.values())
    # dim light: the big pixels' SNR wins; bright light: the small pixels' resolution wins
    assert err[10, 4] < err[10, 1.4] and err[1000, 1.4] < err[1000, 4]
    assert err[10, 1.4] > err[1000, 1.4]  # less light, more noise, more error
    assert {float(r["best_pitch_um"]) for r in rows if float(r["lux"]) == 10} == {4.0}
    # the two sides of the trade: bigger pixels, more SNR and less MTF50 (cycles/mm at the sensor)
    snr = {(float(r["lux"]), float(r["pitch_um"])): float(r["snr_db"]) for r in rows}
    mtf = {float(r["pitch_um"]): float(r["mtf50_cyc_per_mm"]) for r in rows}
    assert snr[10, 4] > snr[10, 1.4] + 6 and snr[1000, 1.4] > snr[10, 1.4] + 10
    assert mtf[1.4] > 1.5 * mtf[4]
    # 4 um pixels sample at 125 cycles/mm: the MTF50 of the pixel aperture, lens and bilinear demosaic lies below Nyquist
    assert mtf[4] < 125
    assert (out / "pixel-size.png").stat().st_size > 1000 and (out / "pixel-size-records.csv").exists()
    assert "best pitch: 10 lux -> 4 um, 1000 lux -> 1.4 um" in text


def test_the_comparison_chain_is_registered_and_scaled():
    """Noiseless, full-colour, unquantized sensor: mean XYZ equals the ideal's within 0.5 %, and the error
    grows with the pitch (only resolution is lost)."""
    errors = []
    for p in (1.0, 2.0, 4.0):
        base = P.camera(p)
        t, _ = P.exposure_for(base, 1000.0)
        cam = base.replace(noise_model="gaussian", full_well=None, dark_current=0.0, dsnu=0.0, prnu=0.0, mosaic=None,
                           bits=None, black_level=0.0, exposure=t)
        raw = run_stages(cam, image_from_scene(P.scene(1000.0)))
        xyz = raw.data @ P.colour_matrix(cam, 1000.0)
        ideal, white = P._ideal(1000.0)
        n = ideal.shape[0]
        cover = int(raw.data.shape[0] * p)
        cover -= (n - cover) % 2
        lo = (n - cover) // 2
        ref, shown = ideal[lo : lo + cover, lo : lo + cover], P._to_grid(xyz, p, cover)
        np.testing.assert_allclose(shown.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=5e-3)
        errors.append(float(np.mean(scielab(shown, ref, 120.0, white))))
    assert errors[0] < errors[1] < errors[2]


def test_sensor_scaling_with_the_pitch_is_as_documented():
    for p in (1.0, 1.4, 5.6):
        cam = P.camera(p)
        assert cam.full_well == pytest.approx(2200 * p * p)
        assert cam.fill_factor == pytest.approx(((p - 0.2) / p) ** 2)
        assert cam.height == cam.width == int(192 // p)
        assert cam.pixel_size == (p * 1e-6, p * 1e-6)
    assert P.camera(1.4).full_well == pytest.approx(4300, rel=0.01)  # the OV5647's well
    # in bright light the exposure fills the well: t x fill factor is the same at every pitch
    tff = [P.exposure_for(P.camera(p), 10000.0)[0] * P.camera(p).fill_factor for p in (1.0, 2.0, 5.6)]
    np.testing.assert_allclose(tff, tff[0], rtol=1e-9)


def test_cli_defaults_are_the_experiments():
    assert cli_experiment.PITCHES_DEFAULT == P.PITCHES_UM and cli_experiment.LUX_DEFAULT == P.LUX


@pytest.mark.parametrize("args, words", [
    (["--pitches=-1,2"], "pitches"),
    (["--lux", "0,100"], "lux"),
    (["--pitches", "2,2"], "repeated"),
    (["--seeds", "0"], "seeds"),
])
def test_bad_grid_is_refused_with_one_line_and_no_output(tmp_path, capsys, args, words):
    status = camsim(["experiment", "pixel-size", *args, "--workers", "0", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 2 and words in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()
