"""Sensor-size images on the machine's cores: the same numbers on one core as on many."""

import os

import numpy as np
import pytest

import camsim_core._parallel as parallel
from camsim_core._parallel import CORES
from camsim_core.image import image_from_scene
from camsim_core.scene import Scene
from camsim_core.simulation import noise, resample, sensor_responses
from camsim_core.simulation.noise import NOISE_BLOCK_VALUES


@pytest.fixture
def big_raw(dcs200_ir):
    """A float32 camera image of 1500 x 2000 x 3 values (over the threshold at which blocks run in parallel)."""
    rng = np.random.default_rng(3)
    scene = Scene(rng.uniform(0, 0.02, (300, 400, 31)).astype(np.float32), np.arange(400.0, 701.0, 10.0),
                  distance=3.32, angular_resolution=(102.6, 102.6))
    cam = dcs200_ir.replace(distance=0.664, height=1500, width=2000, noise_sigma=2.0, seed=7, bits=None)  # 5 x closer
    return cam, sensor_responses(cam, image_from_scene(scene))


def on_cores(monkeypatch, n, fn):
    monkeypatch.setattr(parallel, "CORES", n)
    return fn()


def test_resampling_by_row_blocks_on_two_cores_equals_one_core(big_raw, monkeypatch):
    cam, image = big_raw
    one = on_cores(monkeypatch, 1, lambda: resample(cam, image).data)
    two = on_cores(monkeypatch, 2, lambda: resample(cam, image).data)
    assert one.dtype == np.float32 and one.size >= parallel.PARALLEL_VALUES
    np.testing.assert_array_equal(one, two)


def test_block_noise_is_the_seeds_on_any_number_of_cores_and_has_its_sigma(big_raw, monkeypatch):
    cam, image = big_raw
    sampled = resample(cam, image)
    one = on_cores(monkeypatch, 1, lambda: noise(cam, sampled).data)
    two = on_cores(monkeypatch, 2, lambda: noise(cam, sampled).data)
    np.testing.assert_array_equal(one, two)
    dev = (two - sampled.data).astype(float)
    assert dev.std() == pytest.approx(2.0, rel=0.01) and abs(dev.mean()) < 0.01
    # the blocks are different streams: neighbouring blocks' deviates are uncorrelated, not repeated
    rows = NOISE_BLOCK_VALUES // (dev.shape[1] * dev.shape[2])
    a, b = dev[:rows].ravel(), dev[rows : 2 * rows].ravel()
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.01
    other = noise(cam.replace(seed=8), sampled).data
    assert not np.array_equal(other, two)


def test_run_blocks_covers_every_block_once_and_raises_a_failure(monkeypatch):
    monkeypatch.setattr(parallel, "CORES", 2)
    out = np.zeros(10, int)

    def mark(a, b):
        out[a:b] += 1

    parallel.run_blocks(mark, parallel.split(10, 4), values=parallel.PARALLEL_VALUES)
    assert out.tolist() == [1] * 10

    def fail(a, b):
        if a:
            raise ValueError("block failed")

    with pytest.raises(ValueError, match="block failed"):
        parallel.run_blocks(fail, [0, 5, 10], values=parallel.PARALLEL_VALUES)


@pytest.mark.parametrize("tile", [np.array([[1, 0], [2, 1]]), np.array([[0, 1, 2], [2, 0, 1], [1, 2, 0]])])
def test_mosaic_and_digitize_by_row_blocks_on_two_cores_equal_one_core(big_raw, monkeypatch, tile):
    """An odd number of rows (a partial tile at the bottom), a pedestal, values past full scale and a NaN."""
    from camsim_core.simulation import digitize, mosaic

    cam, image = big_raw
    cam = cam.replace(mosaic=tile, bits=8, black_level=3.0)
    sampled = resample(cam, image)
    data = sampled.data[:1489].copy()  # 1489 rows: a partial tile at the bottom for both tiles
    data[0, 0, 0], data[1, 1, 1] = np.float32(1e30), np.float32(np.nan)
    sampled = sampled.replace(data=data)

    def chain():
        return digitize(cam, mosaic(cam, sampled)).data

    one, two = on_cores(monkeypatch, 1, chain), on_cores(monkeypatch, 2, chain)
    np.testing.assert_array_equal(one, two)
    h, w = data.shape[:2]
    index = np.tile(tile, (-(-h // tile.shape[0]), -(-w // tile.shape[1])))[:h, :w]
    expected = np.clip(np.rint(np.take_along_axis(data, index[:, :, None], axis=2)[:, :, 0] + 3.0), 0, 255)
    expected[np.isnan(expected)] = 255
    np.testing.assert_array_equal(two, expected)


def test_bilinear_demosaic_by_class_on_two_cores_equals_one_core(big_raw, monkeypatch):
    from camsim_core import demosaic
    from camsim_core.simulation import digitize, mosaic

    cam, image = big_raw
    raw = digitize(cam, mosaic(cam, resample(cam, image)))
    one = on_cores(monkeypatch, 1, lambda: demosaic(raw, "bilinear").data)
    two = on_cores(monkeypatch, 2, lambda: demosaic(raw, "bilinear").data)
    assert one.size >= parallel.PARALLEL_VALUES
    np.testing.assert_array_equal(one, two)


def test_per_pixel_chunks_on_two_cores_equal_one_core(monkeypatch):
    """dE of two 1200 x 1200 XYZ images: six chunks of pixels, all of them on the pool (one row first gives the
    output's shape and dtype)."""
    from camsim_core.metrics import delta_e

    rng = np.random.default_rng(5)
    a, b = rng.uniform(1, 90, (2, 1200, 1200, 3)).astype(np.float32)
    white = np.array([95.0, 100.0, 108.9])
    one = on_cores(monkeypatch, 1, lambda: delta_e(a, b, white))
    two = on_cores(monkeypatch, 2, lambda: delta_e(a, b, white))
    assert one.shape == (1200, 1200)
    np.testing.assert_array_equal(one, two)
    np.testing.assert_allclose(two[700, 900], delta_e(a[700:701, 900:901], b[700:701, 900:901], white)[0, 0], rtol=1e-6)


def _work_in_a_forked_child(_):
    """Blocks on the block pool, and an exposure move whose ideal side runs on the branch pool."""
    import camsim_core as cc
    from camsim_core._chunks import map_pixels
    from camsim_core.cache import Pipeline, Processing

    doubled = map_pixels(lambda c: c * 2, np.ones((3000, 1000, 3)))
    scene = cc.load_scene("cacaphony290")
    cam = cc.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0)
    p = Pipeline()
    p.run(scene, cam, Processing(metrics=("cielab",)))
    r = p.run(scene, cam.replace(exposure=0.12), Processing(metrics=("cielab",)))
    return float(doubled.sum()), float(np.nanmean(r.delta_e))


@pytest.mark.skipif(not hasattr(os, "fork") or CORES < 2, reason="needs fork and two cores (the pools run in the caller otherwise)")
def test_a_forked_child_gets_pools_of_its_own():
    """A script that forks worker processes after using camsim (multiprocessing's default on Linux): the
    children inherit pool objects whose threads do not exist in them; they must make their own pools, not
    wait forever for work queued to dead threads."""
    import multiprocessing

    parent = _work_in_a_forked_child(0)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        child = pool.map_async(_work_in_a_forked_child, [0]).get(timeout=120)
    assert child == [parent]


def test_blocks_that_split_their_work_again_run_it_in_their_own_thread(monkeypatch):
    """A block that calls run_blocks again (S-CIELAB's bands converting by chunks) must not wait on the pool
    it occupies: its inner blocks run in turn in its own thread, and the whole finishes."""
    import threading

    monkeypatch.setattr(parallel, "CORES", 2)
    inner_threads = {}
    out = np.zeros(8, int)

    def outer(a, b):
        def inner(c, d):
            inner_threads[c] = (threading.current_thread().name, outer_thread)
            out[c:d] += 1

        outer_thread = threading.current_thread().name
        parallel.run_blocks(inner, [a * 4, a * 4 + 2, a * 4 + 4], values=parallel.PARALLEL_VALUES)

    done = threading.Event()
    watcher = threading.Thread(target=lambda: (parallel.run_blocks(outer, [0, 1, 2], values=parallel.PARALLEL_VALUES),
                                               done.set()), daemon=True)
    watcher.start()
    assert done.wait(30), "nested blocks waited on the pool they occupy"
    assert out.tolist() == [1] * 8
    assert all(name == outer_name and name.startswith("camsim-block") for name, outer_name in inner_threads.values())


def test_scielab_bands_on_two_cores_equal_one_core(monkeypatch):
    """S-CIELAB of a 1100 x 1400 image: four bands of 275 rows, two groups on the cores (each group's transforms on
    one thread), give the numbers of the bands in turn (transforms split over the cores)."""
    from camsim_core.metrics import s_cielab

    rng = np.random.default_rng(11)
    xyz = rng.uniform(1, 90, (1100, 1400, 3)).astype(np.float32)
    white = np.array([95.0, 100.0, 108.9])
    assert len(s_cielab._band_groups(xyz.shape[:2])) == (3 if CORES >= 2 else 2)
    monkeypatch.setattr(s_cielab, "CORES", 2)
    assert s_cielab._band_groups(xyz.shape[:2]) == [0, 550, 1100]  # four bands of 275 rows (374 at most: 3, made 4), two to a core
    for fn in (lambda: s_cielab.filtered_lab(xyz, 102.6, white), lambda: s_cielab.scielab_filter(xyz, 102.6)):
        two = on_cores(monkeypatch, 2, fn)
        monkeypatch.setattr(s_cielab, "CORES", 1)
        one = on_cores(monkeypatch, 1, fn)
        monkeypatch.setattr(s_cielab, "CORES", 2)
        np.testing.assert_array_equal(one, two)


def test_map_pixels_runs_every_chunk_on_the_pool_and_probes_one_row_here(monkeypatch):
    """A large image's chunks all run on the pool, the first too; the call's own thread computes only one
    row, to learn the output's shape and dtype. The numbers are those of one call on the whole."""
    import threading

    from camsim_core import _chunks

    monkeypatch.setattr(parallel, "CORES", 2)
    monkeypatch.setattr(_chunks, "CORES", 2)
    calls = []
    here = threading.current_thread().name

    def halve(rows):
        calls.append((rows.shape[0], threading.current_thread().name))
        return rows[:, :2] * 0.5

    x = np.random.default_rng(12).uniform(0, 1, (1000, 1100, 3))
    out = _chunks.map_pixels(halve, x, chunk=200_000)
    np.testing.assert_array_equal(out, x[:, :, :2] * 0.5)
    assert calls[0] == (1, here)
    chunks = calls[1:]
    assert sorted(n for n, _ in chunks) == sorted([200_000] * 5 + [100_000])
    assert all(name.startswith("camsim-block") for _, name in chunks)


@pytest.mark.parametrize("shape", [(1000, 1100, 3), (40, 50, 3), (0, 7, 3)])
def test_map_pixels_into_writes_each_chunk_in_place_once(monkeypatch, shape):
    """With ``into``, each chunk is handed its own C-ordered rows of the result to write (no probe row, no
    copy): the rows cover the result exactly once, large images on the pool, and the numbers are the
    function's on the whole."""
    import threading

    from camsim_core import _chunks

    monkeypatch.setattr(parallel, "CORES", 2)
    monkeypatch.setattr(_chunks, "CORES", 2)
    seen = []

    def halve(rows, out):
        assert out.flags.c_contiguous and out.shape == (rows.shape[0], 2) and out.dtype == np.float32
        seen.append((out.__array_interface__["data"][0], rows.shape[0], threading.current_thread().name))
        out[:] = rows[:, :2] * 0.5
        return "ignored"

    x = np.random.default_rng(13).uniform(0, 1, shape).astype(np.float32)
    out = _chunks.map_pixels(halve, x, chunk=200_000, into=(2, np.float32))
    assert out.shape == shape[:2] + (2,) and out.dtype == np.float32
    np.testing.assert_array_equal(out, x[:, :, :2] * np.float32(0.5))
    n = shape[0] * shape[1]
    assert sorted(rows for _, rows, _ in seen) == sorted([200_000] * (n // 200_000) + ([n % 200_000] if n % 200_000 else []))
    base = out.__array_interface__["data"][0]
    assert sorted(ptr - base for ptr, _, _ in seen) == [i * 200_000 * 2 * 4 for i in range(len(seen))]
    if n > 200_000:
        assert all(name.startswith("camsim-block") for _, _, name in seen)
