"""Tests of Table 1.16's unstated choices (issue 41): the mosaic experiment's new parameters move the table the
way physics says, and the study runs, resumes and reports. Small scene: macbeth at 3.32 m, 45 x 67 pixels."""

from __future__ import annotations

import csv
import functools
import json

import numpy as np
import pytest

from camsim_core.cli import main as camsim
from camsim_core.errors import ParameterError
from camsim_core.experiments import mosaic
from camsim_core.experiments import table_1_16_study as study
from camsim_core.scene import load_scene

SMALL = "macbeth"


def cells(**options):
    """{(sensors, sigma): error} and the first record of a bilinear mosaic run on the small scene (options override)."""
    options.setdefault("demosaic", "bilinear")
    return _cells(tuple(sorted(options.items())))


@functools.lru_cache(maxsize=None)
def _cells(options):
    recs = mosaic.run(scenes=[SMALL], sigmas=[0, 5], **dict(options))
    return {(r["sensors"], r["sigma"]): r["error"] for r in recs}, recs[0]


def rise(table, n):
    return table[n, 5.0] - table[n, 0.0]


def test_lower_exposure_makes_the_noise_matter_more():
    bright, rb = cells()
    dark, rd = cells(exposure_fill=0.2)
    # the response is linear in exposure: a fill of 0.2 is 2/9 of the exposure of 0.9 (auto_exposure's percentile rule)
    assert rd["exposure"] == pytest.approx(rb["exposure"] * 0.2 / 0.9, rel=1e-9)
    assert rd["exposure_fill"] == 0.2 and rb["exposure_fill"] == 0.9
    for n in (3, 4):  # the same sigma = 5 DU against a signal 4.5 x smaller
        assert rise(dark, n) > rise(bright, n) + 1.0


def test_coarser_scielab_viewing_blurs_less_of_the_noise():
    """At 10.26 samples/deg a camera pixel spans ten times the visual angle: S-CIELAB's filters (fixed in degrees)
    span ten times fewer pixels, average less of the pixel noise away, and the noise raises the error more."""
    fine, rf = cells()
    coarse, rc = cells(viewing="camera/10")
    assert rf["samples_per_degree"] == pytest.approx(10 * rc["samples_per_degree"])
    for n in (3, 4):
        assert rise(coarse, n) > rise(fine, n) + 0.5


def test_white_normalization_equalizes_the_responses_to_the_illuminant():
    scene = load_scene(SMALL)
    for n in (3, 4):
        area = mosaic.camera(n)
        white = mosaic.camera(n, normalization="white", illuminant=scene.illuminant)
        # the scene holds no light outside its 400-700 nm bands
        e = np.interp(white.sensors.wavelengths, scene.illuminant.wavelengths, scene.illuminant.values, left=0, right=0)
        r_white = white.sensors.values @ e
        r_area = area.sensors.values @ e
        assert np.ptp(r_white) < 1e-9 * r_white.mean()  # every class gives the same response to the illuminant
        assert r_white.mean() == pytest.approx(r_area.mean(), rel=1e-9)  # the mean response is kept
        assert np.ptp(r_area) > 0.05 * r_area.mean()  # equal areas do not: the illuminant is not flat
        shape = lambda v: v / v.max(axis=1, keepdims=True)  # noqa: E731 - the curves keep their shapes
        assert np.allclose(shape(white.sensors.values), shape(area.sensors.values))
    with pytest.raises(ParameterError) as info:
        mosaic.camera(3, normalization="white")
    assert info.value.name == "normalization"


def test_surface_model_dimension_touches_only_the_four_sensor_design():
    nd, _ = cells()
    three_d, rec = cells(surface_dimensions=3)
    assert rec["surface_dimensions"] == 3
    assert three_d[3, 0.0] == nd[3, 0.0] and three_d[3, 5.0] == nd[3, 5.0]  # 3 sensors: N-D is 3-D
    assert abs(three_d[4, 0.0] - nd[4, 0.0]) > 0.05


def test_demosaic_noise_model_acts_through_the_noise_only():
    """The likelihood's noise only matters when there is noise: at sigma 0 'known' and 'ignored' are the same filter
    (both keep the 1/12 DU^2 of quantization), at sigma 5 they are not."""
    known, _ = cells(demosaic="bayesian", exposure_fill=0.3)
    ignored, rec = cells(demosaic="bayesian", exposure_fill=0.3, noise_model="ignored")
    assert rec["noise_model"] == "ignored"
    for n in (3, 4):
        assert ignored[n, 0.0] == known[n, 0.0]
        assert ignored[n, 5.0] != known[n, 5.0]


@pytest.mark.parametrize("options, name", [
    (dict(exposure_fill=0.0), "exposure_fill"), (dict(exposure_fill=1.5), "exposure_fill"),
    (dict(normalization="peak"), "normalization"), (dict(prior_detail=0.1), "prior_detail"),
    (dict(demosaic="bayesian", noise_model="fraction"), "noise_model"), (dict(rendering="fancy"), "rendering"),
    (dict(surface_dimensions=5), "surface_dimensions"), (dict(rendering="baseline", surface_dimensions=3), "surface_dimensions"),
])
def test_bad_choices_are_refused_by_name(options, name):
    options.setdefault("demosaic", "bilinear")
    with pytest.raises(ParameterError) as info:
        mosaic.configurations([SMALL], [0], **options)
    assert info.value.name == name


def test_crossover_on_published_numbers():
    assert study.CHAPTER == (2.37, 2.67, 4.04, 1.09, 1.99, 4.16)
    assert study.crossover(study.CHAPTER)
    assert not study.crossover((4.51, 4.57, 4.80, 1.38, 1.45, 1.80))  # camsim's defaults (issue 41)
    assert not study.crossover((1.0, 2.0, 3.0, 2.0, 3.0, 4.0))  # three always better


def test_study_runs_resumes_and_reports(tmp_path, capsys):
    grid = dict(scene=SMALL, fills=(0.3,), centers=(mosaic.CENTERS,), normalizations=("area",),
                demosaics=(("bilinear", None, None),), renderings=(("illuminant", None), ("illuminant", 3)),
                viewings=("camera", "camera/10"))
    tasks = study.tasks(**grid)
    assert len(tasks) == 2 and len({t.key for t in tasks}) == 2
    info = study.run(tasks, tmp_path, workers=0, limit=1, progress=False)
    assert (info["ran"], info["skipped"]) == (1, 0)
    rows = study.load(tmp_path)
    assert [r["viewing"] for r in rows] == ["camera", "camera/10"]
    r = rows[0]
    assert len(r["cells"]) == 6 and r["crossover"] == study.crossover(r["cells"])
    assert r["rms"] == pytest.approx(np.sqrt(np.mean((np.array(r["cells"]) - study.CHAPTER) ** 2)))
    # the rendering of the first task, measured the mosaic experiment's way: the same numbers
    first = tasks[0]
    one, _ = cells(exposure_fill=0.3, surface_dimensions=first.surface_dimensions)
    assert r["cells"][0] == pytest.approx(one[3, 0.0], rel=1e-12) and r["cells"][5] == pytest.approx(one[4, 5.0], rel=1e-12)
    # an interrupted write leaves a torn line: skipped on reading, the task is not counted twice
    with open(tmp_path / study.RESULTS_NAME, "a") as f:
        f.write('{"scene": "mac')
    calls = []
    info = study.run(tasks, tmp_path, workers=0, progress=False, function=lambda t: calls.append(t) or study.evaluate(t))
    assert (info["ran"], info["skipped"]) == (1, 1) and calls == [tasks[1]]
    assert study.run(tasks, tmp_path, workers=0, progress=False)["ran"] == 0
    rows = study.load(tmp_path)
    assert len(rows) == 4
    paths = study.write_report(rows, tmp_path)
    assert {p.name for p in paths} == {"combinations.csv", "best.csv", "effects.csv", "effects.png", "best.png", "summary.md"}
    assert "| chapter | | | **2.37** |" in (tmp_path / "summary.md").read_text()
    with open(tmp_path / "effects.csv") as f:
        effects = list(csv.DictReader(f))
    assert {e["choice"] for e in effects} == set(study.CHOICES)
    text = study.summary_text(rows)
    assert "4 combinations" in text and "2.37 2.67 4.04" in text


def test_cli_study_one_task(tmp_path, capsys):
    out = tmp_path / "s"
    status = camsim(["experiment", "table-1-16-study", "--scene", SMALL, "--fills", "0.3", "--workers", "0", "--limit", "1",
                     "--no-progress", "--no-report", "--out", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    assert "192 tasks (768 combinations) on this process" in text and "ran 1 task(s)" in text
    lines = (out / study.RESULTS_NAME).read_text().splitlines()
    assert len(lines) == len(study.VIEWINGS) and json.loads(lines[0])["exposure_fill"] == 0.3
    assert camsim(["experiment", "table-1-16-study", "--scene", SMALL, "--limit", "0", "--out", str(out)]) == 2
    assert "--limit" in capsys.readouterr().err


def test_cli_mosaic_takes_the_unstated_choices(tmp_path, capsys):
    out = tmp_path / "m"
    status = camsim(["experiment", "mosaic", "--scenes", SMALL, "--sigmas", "5", "--workers", "0", "--no-progress",
                     "--demosaic", "bayesian", "--exposure-fill", "0.5", "--normalization", "white", "--prior-detail", "0",
                     "--noise-model", "ignored", "--surface-dimensions", "3", "--out", str(out)])
    assert status == 0
    with open(out / "mosaic-records.csv") as f:
        recs = list(csv.DictReader(f))
    assert {(r["exposure_fill"], r["normalization"], r["prior_detail"], r["noise_model"], r["surface_dimensions"])
            for r in recs} == {("0.5", "white", "0.0", "ignored", "3")}


def fake_task(task):
    """A stand-in task: one combination per viewing, cells from the fill (no simulation)."""
    cells = [task.exposure_fill * i for i in range(1, 7)]
    return [{"task": task.key, "viewing": v, "cells": cells, "crossover": study.crossover(cells)} for v in task.viewings]


def test_partial_task_is_rerun_and_dask_runs_unchanged(tmp_path):
    tasks = study.tasks(scene=SMALL, fills=(0.5, 0.25), centers=(mosaic.CENTERS,), normalizations=("area",),
                        demosaics=(("bilinear", None, None),), renderings=(("illuminant", None),), viewings=("camera", "camera/10"))
    first = fake_task(tasks[0])
    with open(tmp_path / study.RESULTS_NAME, "w") as f:  # a run killed between a task's two lines
        f.write(json.dumps(first[0]) + "\n")
    # a local cluster of two thread workers (no process start-up in a unit test), the same code path as a scheduler's
    info = study.run(tasks, tmp_path, workers=2, processes=False, progress=False, function=fake_task)
    assert (info["ran"], info["skipped"]) == (2, 0)
    rows = study.load(tmp_path)
    assert sorted((r["task"], r["viewing"]) for r in rows) == sorted((t.key, v) for t in tasks for v in t.viewings)
    assert study.run(tasks, tmp_path, workers=2, processes=False, progress=False, function=fake_task)["ran"] == 0


def test_nothing_pending_starts_no_cluster(tmp_path, monkeypatch):
    from camsim_core.experiments import runner

    tasks = study.tasks(scene=SMALL, fills=(0.5,), centers=(mosaic.CENTERS,), normalizations=("area",),
                        demosaics=(("bilinear", None, None),), renderings=(("illuminant", None),), viewings=("camera",))
    study.run(tasks, tmp_path, workers=0, progress=False, function=fake_task)
    monkeypatch.setattr(runner, "local_cluster", lambda *a, **k: pytest.fail("a cluster started for nothing"))
    info = study.run(tasks, tmp_path, workers=2, progress=False, function=fake_task)
    assert (info["ran"], info["skipped"]) == (0, 1)
