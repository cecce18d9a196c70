"""Tests of the section 5 experiments: grid validation, seeding, Dask runner, outputs, and the
chapter's alpha = 0 claim on a small scene (macbeth at 3.32 m: 45 x 67 pixels)."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from PIL import Image

from camsim_core.cli import main as camsim
from camsim_core.errors import ParameterError
from camsim_core.experiments import grid, mosaic, results, sensors
from camsim_core.experiments.runner import run_tasks

SMALL = "macbeth"  # 84 x 124 scene; 45 x 67 camera pixels at the default 3.32 m


def fake_sensors(config):
    """A stand-in evaluation: a deterministic function of the configuration plus noise drawn from its seed."""
    rng = np.random.default_rng(config.noise_seed)
    e = rng.normal(0.0, 1.0, 2)
    return {"scene": config.scene, "alpha": config.alpha, "sigma": config.sigma, "seed": config.seed,
            "noise_seed": config.noise_seed, "baseline": 10 * config.alpha + config.sigma * e[0],
            "illuminant": 5 * config.alpha + config.sigma * e[1]}


# --- grid validation, before any task starts -------------------------------------------------------------

def _never_called(config):  # pragma: no cover - the point is that it is never called
    raise AssertionError("a task started on a bad grid")


@pytest.mark.parametrize(
    "kwargs, name, words",
    [
        (dict(alphas=[0, 1.2]), "alphas", "[0, 1]"),
        (dict(alphas=[-0.1, 0.5]), "alphas", "[0, 1]"),
        (dict(alphas=[0, float("nan")]), "alphas", "finite"),
        (dict(sigmas=[0, -2]), "sigmas", ">= 0"),
        (dict(scenes=["no-such-scene"]), "scenes", "unknown scene 'no-such-scene'"),
        (dict(seeds=0), "seeds", ">= 1"),
        (dict(distance=-1.0), "distance", "positive"),
        (dict(monitor="no-such-monitor"), "monitor", "unknown monitor"),
    ],
)
def test_bad_sensors_grid_is_refused_before_any_task(kwargs, name, words, monkeypatch):
    from camsim_core.experiments import runner

    monkeypatch.setattr(runner, "local_cluster", _never_called)  # no cluster may start either
    args = dict(scenes=[SMALL], alphas=[0, 1], sigmas=[0], seeds=1)
    args.update(kwargs)
    with pytest.raises(ParameterError) as info:
        sensors.run(**args, function=_never_called, workers=1, processes=False)
    assert info.value.name == name
    assert words in str(info.value)


@pytest.mark.parametrize(
    "kwargs, name",
    [(dict(sigmas=[-5]), "sigmas"), (dict(centers=[460, 520, 580]), "centers"), (dict(centers=[520, 460, 580, 640]), "centers"),
     (dict(scenes=["nowhere.Simg"]), "scenes"), (dict(std_nm=0), "std_nm"), (dict(designs=[5]), "designs")],
)
def test_bad_mosaic_grid_is_refused(kwargs, name):
    args = dict(scenes=[SMALL], sigmas=[0], seeds=1)
    args.update(kwargs)
    with pytest.raises(ParameterError) as info:
        mosaic.run(**args, function=_never_called, workers=1, processes=False)
    assert info.value.name == name


def test_parse_values():
    assert grid.parse_values("0:1:11", "a") == pytest.approx([i / 10 for i in range(11)])
    assert grid.parse_values("0, 2,5", "s") == [0.0, 2.0, 5.0]
    with pytest.raises(ParameterError, match="--alphas"):
        grid.parse_values("0:1", "--alphas")
    with pytest.raises(ParameterError, match="--sigmas"):
        grid.parse_values("two", "--sigmas")


def test_cli_refuses_bad_grid_with_one_line(capsys, tmp_path):
    status = camsim(["experiment", "sensors", "--scenes", SMALL, "--alphas", "0,1.5", "--workers", "0",
                     "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 2
    assert "alphas" in err and "[0, 1]" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()  # no output folder for a refused grid


# --- seeding and the runner ------------------------------------------------------------------------------

def test_task_seed_is_a_function_of_the_configuration_only():
    a = sensors.SensorsConfig(SMALL, 0.3, 2.0, 1, 0.1)
    assert a.noise_seed == sensors.SensorsConfig(SMALL, 0.3, 2.0, 1, 0.1).noise_seed
    # common random numbers: the same noise for every alpha of a (scene, sigma, seed)
    assert a.noise_seed == sensors.SensorsConfig(SMALL, 0.9, 2.0, 1, 0.1).noise_seed
    others = {sensors.SensorsConfig(SMALL, 0.3, 5.0, 1, 0.1).noise_seed, sensors.SensorsConfig(SMALL, 0.3, 2.0, 2, 0.1).noise_seed,
              sensors.SensorsConfig("cacaphony290", 0.3, 2.0, 1, 0.1).noise_seed,
              mosaic.MosaicConfig(SMALL, 3, 2.0, 1, 0.1).noise_seed}
    assert a.noise_seed not in others and len(others) == 4
    assert sensors.SensorsConfig(SMALL, 0.3, 2, 1, 0.1).noise_seed == a.noise_seed  # sigma 2 (int) is sigma 2.0


def test_runner_keeps_grid_order_whatever_the_finishing_order():
    def slow_first(x):
        import time

        time.sleep(0.2 if x == 0 else 0.0)
        return x * x

    assert run_tasks(slow_first, range(6), workers=2, processes=False, progress=False) == [0, 1, 4, 9, 16, 25]


def test_one_and_two_dask_workers_give_identical_numbers_fake():
    kw = dict(scenes=[SMALL], alphas=[0, 0.5, 1], sigmas=[0, 5], seeds=2, function=fake_sensors, processes=False)
    serial = sensors.run(**kw, workers=None)
    one = sensors.run(**kw, workers=1)
    two = sensors.run(**kw, workers=2)
    assert one == two == serial
    assert len(one) == 12
    # the noise draws differ between seeds (the seed index reaches the task)
    assert one[2]["baseline"] != one[3]["baseline"]


def test_local_cluster_listens_on_loopback_only():
    import psutil

    from camsim_core.experiments.runner import local_cluster

    cluster = local_cluster(2, processes=False)
    try:
        listening = [c.laddr for c in psutil.Process().net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
    finally:
        cluster.close()
    assert len(listening) >= 3  # scheduler and two workers
    assert {a.ip for a in listening} == {"127.0.0.1"}


def test_existing_scheduler_gives_the_same_numbers():
    from camsim_core.experiments.runner import local_cluster

    kw = dict(scenes=[SMALL], alphas=[0, 1], sigmas=[2], seeds=2, function=fake_sensors)
    cluster = local_cluster(2, processes=False)
    try:
        remote = sensors.run(**kw, scheduler=cluster.scheduler_address)
    finally:
        cluster.close()
    assert remote == sensors.run(**kw)


def test_summary_is_mean_and_sample_std_over_seeds():
    recs = [{"scene": "s", "alpha": 0.5, "sigma": 2.0, "seed": i, "baseline": v, "illuminant": 1.0}
            for i, v in enumerate([1.0, 2.0, 6.0])]
    rows = sensors.summarize(recs)
    base = [r for r in rows if r["method"] == "baseline"][0]
    assert base["mean"] == pytest.approx(3.0) and base["n"] == 3
    assert base["std"] == pytest.approx(math.sqrt(((1 - 3) ** 2 + (2 - 3) ** 2 + (6 - 3) ** 2) / 2))
    one = results.summarize(recs[:1], ("scene",), ("baseline",))
    assert math.isnan(one[0]["std"])


def test_sensors_outputs_csv_png_and_table(tmp_path):
    recs = sensors.run(scenes=[SMALL], alphas=[0, 0.5, 1], sigmas=[0, 2], seeds=2, function=fake_sensors)
    paths = sensors.write_outputs(recs, tmp_path)
    names = sorted(p.name for p in paths)
    assert names == ["figure-1-14.png", "sensors-records.csv", "sensors-summary.csv"]
    with open(tmp_path / "sensors-summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 * 2 * 2  # alpha x sigma x method
    r = [r for r in rows if r["alpha"] == "1.0" and r["sigma"] == "0.0" and r["method"] == "baseline"][0]
    assert float(r["mean"]) == pytest.approx(10.0) and float(r["std"]) == pytest.approx(0.0) and r["n"] == "2"
    png = Image.open(tmp_path / "figure-1-14.png")
    assert png.format == "PNG" and png.size[0] > 1.5 * png.size[1]  # two panels side by side
    text = sensors.table(sensors.summarize(recs))
    assert "baseline s=2" in text and "illuminant s=0" in text and "10.00 ± 0.00" in text
    assert not list(tmp_path.glob("*.part"))


def test_engine_does_not_import_gui_libraries():
    import subprocess
    import sys

    code = ("import sys, camsim_core.experiments as e, camsim_core.experiments.plot, camsim_core.cli.experiment; "
            "from camsim_core.experiments.runner import run_tasks; "
            "assert run_tasks(abs, [-1, -2], workers=1, processes=False, progress=False) == [1, 2]; "
            "print(sorted(m for m in ('panel', 'holoviews', 'bokeh') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]"


# --- the real pipeline on a small scene ------------------------------------------------------------------

def test_alpha_zero_without_noise_is_perfect_for_both_methods_and_alpha_one_is_not():
    """Chapter section 5: with the cones' sensitivities and no noise both renderings reproduce the ideal image."""
    recs = sensors.run(scenes=[SMALL], alphas=[0.0, 1.0], sigmas=[0.0], seeds=1)
    zero, one = recs
    assert (zero["height"], zero["width"]) == (45, 67)
    assert zero["baseline"] < 0.05 and zero["illuminant"] < 0.05
    # the DCS-200 end is visibly wrong, so the zero above is not a measurement that always says zero
    assert one["baseline"] > 1.0 and one["illuminant"] > 0.5


def test_optional_bayer_mosaic_adds_demosaicing_error_at_alpha_zero():
    """With --mosaic the alpha = 0 camera is no longer perfect: the error is the bilinear demosaicing's."""
    rec = sensors.run(scenes=[SMALL], alphas=[0.0], sigmas=[0.0], seeds=1, mosaic=True)[0]
    assert rec["mosaic"] is True
    assert rec["baseline"] > 0.5  # small patches with black gaps: colour fringes at every edge
    assert rec["illuminant"] == pytest.approx(rec["baseline"], abs=1e-6)  # cones: both methods are the same map


def test_noise_raises_the_alpha_zero_error():
    recs = sensors.run(scenes=[SMALL], alphas=[0.0], sigmas=[0.0, 2.0, 5.0], seeds=1)
    e = [r["baseline"] for r in recs]
    assert e[0] < 0.05 < e[1] < e[2]


def test_real_sweep_identical_on_one_and_two_dask_workers():
    kw = dict(scenes=[SMALL], alphas=[0.0, 0.6], sigmas=[0.0, 5.0], seeds=1, processes=False)
    one = sensors.run(**kw, workers=1)
    two = sensors.run(**kw, workers=2)
    keys = ("alpha", "sigma", "seed", "noise_seed", "baseline", "illuminant")
    assert [tuple(r[k] for k in keys) for r in one] == [tuple(r[k] for k in keys) for r in two]
    assert one[1]["baseline"] != one[3]["baseline"]  # the noisy configurations really differ by alpha


def test_cli_sensors_in_process_writes_outputs(tmp_path, capsys):
    out = tmp_path / "run"
    status = camsim(["experiment", "sensors", "--scenes", SMALL, "--alphas", "0,1", "--sigmas", "0", "--workers", "0",
                     "--no-progress", "--out", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    assert (out / "figure-1-14.png").stat().st_size > 1000
    with open(out / "sensors-records.csv") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["alpha"]) for r in rows] == [0.0, 1.0]
    assert float(rows[0]["baseline"]) < 0.05
    assert "Figure 1.14" in text and "baseline s=0" in text


# --- the mosaic experiment -------------------------------------------------------------------------------

def test_mosaic_designs_follow_figure_1_15():
    from camsim_core.simulation import FOUR_SENSOR_GRID, bayer

    four, three = mosaic.camera(4), mosaic.camera(3)
    peaks = lambda cam: [float(cam.sensors.wavelengths[i]) for i in np.argmax(cam.sensors.values, axis=1)]
    assert peaks(four) == [460.0, 520.0, 580.0, 640.0]
    assert peaks(three) == [640.0, 580.0, 460.0]  # R, G, B: class 2 (520 nm) left out
    assert np.array_equal(four.mosaic, FOUR_SENSOR_GRID) and np.array_equal(three.mosaic, bayer("GRBG"))
    # 27 nm standard deviation: the curve falls to exp(-1/2) of its peak 27 nm away
    v = four.sensors.values[1]
    w = four.sensors.wavelengths
    assert np.interp(520 + 27, w, v) / v.max() == pytest.approx(np.exp(-0.5), rel=0.02)
    assert peaks(mosaic.camera(3, centers=(450, 530, 590, 650))) == [650.0, 590.0, 450.0]


def test_cli_mosaic_writes_table_in_the_chapters_layout(tmp_path, capsys):
    out = tmp_path / "m"
    status = camsim(["experiment", "mosaic", "--scenes", SMALL, "--sigmas", "0,5", "--workers", "0", "--no-progress",
                     "--demosaic", "bilinear", "--out", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    with open(out / "table-1-16.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["sensors"] for r in rows] == ["3", "4"]
    assert [float(r["chapter_sigma_5"]) for r in rows] == [4.04, 4.16]
    assert all(float(r["mean_sigma_0"]) > 0.1 for r in rows)  # neither Gaussian design is colorimetric
    assert "460, 520, 580, 640 nm" in text and "camsim's choice" in text and "[2.37]" in text


# --- S-CIELAB viewing ------------------------------------------------------------------------------------

def test_figure_1_14_is_not_monotonic_with_noise_at_the_originals_viewing(tmp_path, capsys):
    """At 10.26 samples/deg (the original's S-CIELAB example, the DCS-200's 102.6 / 10) the chapter's
    remark holds: with noise (sigma 5) the illuminant-based error is lowest between the cones and the
    DCS-200, not at alpha 0. At the chapter-era 102.6 the eye's blur hides the noise and it is not."""
    out = tmp_path / "s"
    status = camsim(["experiment", "sensors", "--alphas", "0,0.3,1", "--sigmas", "5", "--workers", "0", "--no-progress",
                     "--samples-per-degree", "10.26", "--out", str(out)])
    text = capsys.readouterr().out
    assert status == 0 and "10.26 samples/deg" in text
    with open(out / "sensors-summary.csv") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
    assert reader.fieldnames == ["scene", "alpha", "sigma", "method", "mean", "std", "n"]
    ill = {float(r["alpha"]): float(r["mean"]) for r in rows if r["method"] == "illuminant"}
    assert min(ill, key=ill.get) != 0.0
    assert ill[0.3] < ill[0.0] < ill[1.0]
    with open(out / "sensors-records.csv") as f:
        recs = list(csv.DictReader(f))
    assert {r["viewing"] for r in recs} == {"spd:10.26"} and {float(r["samples_per_degree"]) for r in recs} == {10.26}


def test_viewing_changes_the_measured_error_and_is_recorded():
    rec102 = sensors.run(scenes=[SMALL], alphas=[0.0], sigmas=[5.0], seeds=1)[0]
    rec10 = sensors.run(scenes=[SMALL], alphas=[0.0], sigmas=[5.0], seeds=1, viewing="camera/10")[0]
    assert rec102["viewing"] == "camera" and rec102["samples_per_degree"] == pytest.approx(102.6)
    assert rec10["viewing"] == "camera/10" and rec10["samples_per_degree"] == pytest.approx(10.26)
    assert rec10["noise_seed"] == rec102["noise_seed"]  # the same noise field, seen ten times larger
    assert rec10["baseline"] > 2 * rec102["baseline"]


def test_cli_mosaic_takes_samples_per_degree(tmp_path, capsys):
    out = tmp_path / "m"
    status = camsim(["experiment", "mosaic", "--scenes", SMALL, "--sigmas", "0", "--workers", "0", "--no-progress",
                     "--demosaic", "bilinear", "--samples-per-degree", "20", "--out", str(out)])
    assert status == 0 and "20 samples/deg" in capsys.readouterr().out
    with open(out / "mosaic-records.csv") as f:
        assert {float(r["samples_per_degree"]) for r in csv.DictReader(f)} == {20.0}


@pytest.mark.parametrize("args", [["--samples-per-degree", "-1"], ["--viewing", "sideways"],
                                  ["--viewing", "camera", "--samples-per-degree", "3"]])
def test_cli_refuses_a_bad_viewing(tmp_path, capsys, args):
    try:
        status = camsim(["experiment", "sensors", "--scenes", SMALL, "--workers", "0", "--out", str(tmp_path / "x")] + args)
    except SystemExit as exc:  # argparse: the two options exclude each other
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err
    assert "viewing" in err or "samples_per_degree" in err
    assert not (tmp_path / "x").exists()
