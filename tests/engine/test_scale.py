"""The engine at sensor sizes: dtype kept, fast paths equal to the plain formulas, small sweeps in-process."""

from __future__ import annotations

import dataclasses
import functools
import os
import subprocess
import sys
import time

import colour
import numpy as np
import pytest
from scipy import ndimage

import camsim_core as cs
from camsim_core import metrics
from camsim_core.cache import Pipeline, Processing
from camsim_core.demosaicing.bilinear import bilinear_planes, tent
from camsim_core.errors import ParameterError
from camsim_core.experiments.runner import MIN_CLUSTER_TASKS, choose_workers
from camsim_core.image import image_from_scene
from camsim_core.scene import Scene
from camsim_core.simulation import BAYER, mosaic, resample, tile_index_map

W31 = np.arange(400, 701, 10.0)


@pytest.fixture(scope="module")
def base():
    """The default scene in float64 (it ships as float32): the reference the float32 chain is held to."""
    shipped = cs.load_scene("cacaphony290")
    return dataclasses.replace(shipped, data=shipped.data.astype(np.float64))


@pytest.fixture(scope="module")
def camera():
    return cs.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, seed=0)


def _as32(scene):
    d = scene.data.astype(np.float32)
    return Scene(d, scene.wavelengths, scene.distance, scene.angular_resolution, scene.unit, scene.illuminant, scene.name)


# -- dtype ------------------------------------------------------------------
def test_float32_scene_stays_float32_and_a_read_only_array_is_not_copied():
    cube = np.random.default_rng(0).uniform(0, 1, (8, 9, 31)).astype(np.float32)
    cube.flags.writeable = False
    s = Scene(cube, W31)
    assert s.data.dtype == np.float32 and np.shares_memory(s.data, cube)
    writable = cube.copy()
    s2 = Scene(writable, W31)
    assert s2.data.dtype == np.float32 and not np.shares_memory(s2.data, writable)  # the caller's array is never frozen
    assert Scene(cube.astype(np.float16), W31).data.dtype == np.float64
    assert Scene(np.ones((2, 2, 31), int), W31).data.dtype == np.float64


def test_npz_float32_scene_loads_as_float32(tmp_path):
    p = tmp_path / "s.npz"
    np.savez(p, data=np.ones((4, 5, 31), np.float32), wavelengths=W31)
    assert cs.load_scene(p).data.dtype == np.float32


def test_float32_chain_keeps_float32_and_matches_float64(base, camera):
    """Every stage in float32 on a float32 scene; the 8-bit raw equals the float64 one except where a value
    lies within float32 rounding of a half step (at most 1 DU, a handful of pixels)."""
    s32 = _as32(base)
    cam = camera.replace(noise_sigma=0.0)
    r64, r32 = cs.simulate(base, cam), cs.simulate(s32, cam)
    assert r32.data.dtype == np.float32 and r64.data.dtype == np.float64
    diff = np.abs(r32.data - r64.data)
    assert diff.max() <= 1 and np.mean(diff > 0) < 1e-3
    mon = cs.load_monitor("simtoolbox-test")
    d32, d64 = cs.demosaic(r32, "bilinear"), cs.demosaic(r64, "bilinear")
    assert d32.data.dtype == np.float32
    np.testing.assert_allclose(d32.data, d64.data, atol=1.0)
    same = cs.demosaic(r64.replace(data=r64.data.astype(np.float32)), "bilinear").data
    np.testing.assert_allclose(same, d64.data, rtol=1e-6, atol=1e-4)  # same raw: float32 rounding only
    x32 = cs.to_xyz(cs.render(d32, mon), mon)
    assert x32.dtype == np.float32
    i32 = cs.to_xyz(cs.ideal_image(s32, cam, mon), mon)
    i64 = cs.to_xyz(cs.ideal_image(base, cam, mon), mon)
    assert i32.dtype == np.float32
    white = cs.rendering.white_xyz(mon)
    de32 = metrics.scielab(x32, i32, 102.6, white)
    de64 = metrics.scielab(cs.to_xyz(cs.render(d64, mon), mon), i64, 102.6, white)
    assert de32.dtype == np.float32
    assert abs(float(de32.mean()) - float(de64.mean())) < 0.05


def test_float32_noise_has_its_sigma_and_mean(camera):
    img = image_from_scene(Scene(np.full((200, 300, 31), 0.01, np.float32), W31, distance=3.32))
    cam = camera.replace(noise_sigma=3.0, noise_mean=1.5, mosaic=None, bits=None, seed=4)
    out = cs.simulation.noise(cam, cs.simulation.sensor_responses(cam, img))
    clean = cs.simulation.sensor_responses(cam, img).data
    d = out.data - clean
    assert out.data.dtype == np.float32
    assert abs(d.std() - 3.0) < 0.03 and abs(d.mean() - 1.5) < 0.03
    again = cs.simulation.noise(cam, cs.simulation.sensor_responses(cam, img))
    np.testing.assert_array_equal(again.data, out.data)  # seeded


def test_deep_float32_raw_is_rounded_in_float64(camera):
    img = image_from_scene(Scene(np.full((4, 4, 31), 0.01, np.float32), W31)).replace(
        data=np.full((4, 4), 2.0**25 + 1, np.float32), space="sensor")
    out = cs.simulation.digitize(camera.replace(bits=26), img)
    assert out.data.dtype == np.float64
    small = cs.simulation.digitize(camera.replace(bits=8), img.replace(data=np.full((4, 4), 7.6, np.float32)))
    assert small.data.dtype == np.float32 and np.all(small.data == 8)


# -- resampling ---------------------------------------------------------------
def _dense_axis(N, Phi, phi, D, d, limit):
    """Eq. 1.2 weights as a dense matrix, written independently of the engine."""
    size = 2 * phi * np.degrees(np.arctan((D / d) * np.tan(np.radians(N / (2 * Phi)))))
    n = max(int(round(size)), 1)
    to_scene = lambda p: Phi * np.degrees(np.arctan((d / D) * np.tan(np.radians(p / phi))))  # noqa: E731
    m = np.zeros((n, N))
    if n < N:
        edges = to_scene(np.arange(n + 1) - n / 2) + N / 2
        for j in range(n):
            for k in range(N):
                m[j, k] = max(0.0, min(edges[j + 1], k + 1) - max(edges[j], k))
        m /= m.sum(axis=1, keepdims=True)
    else:
        c = np.clip(to_scene(np.arange(n) + 0.5 - n / 2) + N / 2 - 0.5, 0, N - 1)
        for j, x in enumerate(c):
            i0 = int(np.floor(x))
            m[j, i0] += 1 - (x - i0)
            m[j, min(i0 + 1, N - 1)] += x - i0
    if limit is not None and n > limit:
        s = (n - limit) // 2
        m = m[s : s + limit]
    return m


@pytest.mark.parametrize("d, limit", [(3.32, 50), (1.2, 400), (6.0, None)])  # area averaging, interpolation, both crops
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_resample_equals_dense_eq_1_2_matrices(camera, d, limit, dtype):
    H, W = 61, 87
    data = np.random.default_rng(1).uniform(0, 1, (H, W, 3)).astype(dtype)
    img = image_from_scene(Scene(np.ones((H, W, 31)), W31, distance=2.0, angular_resolution=(57.3, 40.0))).replace(data=data, space="sensor")
    cam = camera.replace(distance=d, angular_resolution=(102.6, 80.0), height=limit or 10000, width=limit or 10000)
    out = resample(cam, img).data
    my = _dense_axis(H, 40.0, 80.0, 2.0, d, limit)
    mx = _dense_axis(W, 57.3, 102.6, 2.0, d, limit)
    ref = np.einsum("ij,jkc,lk->ilc", my, data.astype(float), mx, optimize=True)
    assert out.dtype == dtype and out.shape == ref.shape
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-12 if dtype == np.float64 else 1e-6)


def test_interpolating_resample_rounds_each_value_once_in_float32(camera):
    """Where the camera is finer than the scene (two taps per axis), each output value is the float32 rounding
    of the exact sum of its two float32 tap products (the y pass's rows made as the kernel makes them, one
    float32 multiply-add per tap): summed in float32 or accumulated in float64, the same numbers."""
    from camsim_core.simulation.resample import axis_weights

    H, W = 61, 87
    data = np.random.default_rng(3).uniform(0, 1, (H, W, 3)).astype(np.float32)
    img = image_from_scene(Scene(np.ones((H, W, 31)), W31, distance=2.0, angular_resolution=(57.3, 40.0))).replace(data=data, space="sensor")
    cam = camera.replace(distance=1.2, angular_resolution=(102.6, 80.0), height=400, width=400)
    out = resample(cam, img).data
    iy, wy = axis_weights(H, 40.0, 80.0, 2.0, 1.2, 400)
    ix, wx = axis_weights(W, 57.3, 102.6, 2.0, 1.2, 400)
    assert iy.shape[1] == ix.shape[1] == 2
    rows = np.zeros((iy.shape[0], W, 3), np.float32)
    for s in range(2):
        rows += wy[:, s, None, None].astype(np.float32) * data[iy[:, s]]
    p0, p1 = (wx[None, :, s, None].astype(np.float32) * rows[:, ix[:, s]] for s in range(2))
    assert p0.dtype == np.float32
    np.testing.assert_array_equal(out, (p0.astype(np.float64) + p1.astype(np.float64)).astype(np.float32))


@pytest.mark.parametrize("shape, dtype, view", [
    ((23, 17), np.float64, False),
    ((2, 3), np.float64, False),  # narrower than the 4-wide tile: only its first columns
    ((1403, 1500), np.float32, False),  # over 2**21 values: two blocks of rows on the cores, the second from row 701, not a whole tile down
    ((40, 31), np.float32, True),  # a strided view, as a caller may pass
])
@pytest.mark.parametrize("tile", [BAYER["GRBG"], np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]]), np.array([[2, 0, 1, 1]])])
def test_mosaic_equals_index_map(camera, tile, shape, dtype, view):
    data = np.random.default_rng(2).uniform(0, 9, shape + (3,)).astype(dtype)
    if view:
        data = np.random.default_rng(3).uniform(0, 9, (2 * shape[0], shape[1], 5)).astype(dtype)[::2, :, 1:4]
    img = image_from_scene(Scene(np.ones((2, 2, 31)), W31)).replace(data=data, space="sensor")
    out = mosaic(camera.replace(mosaic=tile), img).data
    ref = np.take_along_axis(data, tile_index_map(tile, shape)[:, :, None], axis=2)[:, :, 0]
    assert out.dtype == dtype and out.shape == shape
    np.testing.assert_array_equal(out, ref)


# -- demosaicing ---------------------------------------------------------------
def _bilinear_reference(data, tile, k):
    """Normalized convolution over full-frame sample and count planes (the textbook form)."""
    idx = np.tile(tile, (-(-data.shape[0] // tile.shape[0]), -(-data.shape[1] // tile.shape[1]), 1))[: data.shape[0], : data.shape[1]]
    ky, kx = tent(tile.shape[0]), tent(tile.shape[1])
    sep = lambda p: ndimage.correlate1d(ndimage.correlate1d(p, ky, axis=0, mode="constant"), kx, axis=1, mode="constant")  # noqa: E731
    out = np.empty(data.shape[:2] + (k,))
    for c in range(k):
        vals = np.where(idx == c, data, 0.0).sum(axis=2)
        count = (idx == c).sum(axis=2).astype(float)
        est = sep(vals) / np.where(sep(count) > 0, sep(count), 1)
        out[:, :, c] = np.where(count > 0, vals / np.maximum(count, 1), est)
    return out


@pytest.mark.parametrize("tile", [
    BAYER["RGGB"][:, :, None],
    np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])[:, :, None],
    np.array([[0, 1], [2, 3]])[:, :, None],
    np.array([[0, 1, 1, 2, 0]])[:, :, None],
    (np.arange(16).reshape(4, 4) % 4)[:, :, None],  # period 4: the separable passes, not the stencils
    np.stack([BAYER["GRBG"], BAYER["GRBG"][::-1]], axis=2),  # tiered: two samples at a pixel
])
@pytest.mark.parametrize("shape", [(31, 45), (5, 7), (2, 3)])
def test_bilinear_equals_normalized_convolution(tile, shape):
    k = int(tile.max()) + 1
    data = np.random.default_rng(3).uniform(0, 255, shape + (tile.shape[2],))
    out = bilinear_planes(data, tile, k)
    np.testing.assert_allclose(out, _bilinear_reference(data, tile, k), rtol=1e-12, atol=1e-9)
    out32 = bilinear_planes(data.astype(np.float32), tile, k)
    assert out32.dtype == np.float32
    np.testing.assert_allclose(out32, out, rtol=1e-5, atol=1e-3)


@functools.cache
def _bounds_checked_stencil_rows():
    """The stencil kernel compiled once for the cases below (with bounds checks: numba raises IndexError where
    the engine's build would write past its arrays); compiled anew per case it cost 1.2-2.2 s each."""
    import numba

    from camsim_core.demosaicing import bilinear

    return numba.njit(boundscheck=True)(bilinear._stencil_rows)


@pytest.mark.parametrize("tile", [BAYER["RGGB"], np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])])
@pytest.mark.parametrize("shape", [(1, 1), (1, 2), (2, 1), (3, 1), (1, 3), (2, 2), (4, 2), (2, 5)])
def test_bilinear_stencils_stay_inside_images_smaller_than_their_reach(tile, shape):
    """The stencil kernel compiled with bounds checks (numba raises IndexError where the engine's build
    would write past its arrays) on images narrower or shorter than the tile's reach: in bounds, and the
    textbook numbers."""
    from camsim_core.demosaicing import bilinear

    checked = _bounds_checked_stencil_rows()
    k = int(tile.max()) + 1
    t = np.ascontiguousarray(tile, np.int64)
    data = np.random.default_rng(5).uniform(0, 255, shape)
    out = np.full(shape + (k,), np.nan)
    checked(data, *bilinear._stencils(t.tobytes(), t.shape, k), out, 0, shape[0])
    np.testing.assert_allclose(out, _bilinear_reference(data[:, :, None], tile[:, :, None], k), rtol=1e-12, atol=1e-9)


# -- monitor tables --------------------------------------------------------------
@pytest.mark.parametrize("name", ["simtoolbox-test", "brainard-crt"])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_frame_buffer_table_is_identical_to_interpolation(name, dtype):
    m = cs.load_monitor(name)
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.random(150_000), rng.random(60_000) ** 8, np.linspace(0, 1, 90_000), [0.0, 1.0, 5e-324]])
    x = x[: x.size // 3 * 3].astype(dtype).reshape(-1, 1, 3)
    # every bucket edge of the table and its neighbours
    e = (np.arange(0, 1 << 16, 97) / (1 << 16)).astype(dtype)
    edges = np.concatenate([e, np.nextafter(e, dtype(0)), np.nextafter(e, dtype(1))])
    edges = edges[: edges.size // 3 * 3].reshape(-1, 1, 3)
    for v in (x, edges, np.tile(x, (8, 1, 1))):  # the last spans several of the conversion's chunks
        ref = np.rint(m.linear_to_settings(v) * 255)
        out = m.linear_to_frame_buffer(v)
        assert out.dtype == dtype
        np.testing.assert_array_equal(out, ref)
    fb = np.floor(rng.random((1000, 1, 3)) * 256)
    np.testing.assert_array_equal(m.frame_buffer_to_linear(fb), m.settings_to_linear(fb / 255.0))
    np.testing.assert_array_equal(m.frame_buffer_to_linear(fb + 0.5), m.settings_to_linear((fb + 0.5) / 255.0))


@pytest.mark.parametrize("name", ["simtoolbox-test", "brainard-crt"])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_compiled_rendering_gives_the_exact_frame_buffer_value_at_every_step(name, dtype):
    """The rendering kernel settles a value whose table bucket holds a step by the table of where each
    frame-buffer value begins: rint(255 x linear_to_settings(w)) exactly, at each step's first value and the
    value just below it, on random and very dark intensities (where steps crowd), out of range and NaN."""
    from camsim_core.monitor import _frame_buffer_steps

    m = cs.load_monitor(name)
    steps = _frame_buffer_steps(m, np.dtype(dtype))
    assert steps.shape == (3, 255) and np.all(np.diff(steps, axis=1) >= 0)
    rng = np.random.default_rng(9)
    edges = steps[np.isfinite(steps)].astype(dtype)
    w = np.concatenate([edges, np.nextafter(edges, dtype(0)), np.nextafter(edges, dtype(2)),
                        rng.random(60_000).astype(dtype), (rng.random(60_000) ** 8).astype(dtype),
                        np.array([0, 1, -0.5, 1.5, 5e-324, np.nan], dtype)])
    rows = np.repeat(w[:, None], 3, axis=1)  # each channel sees every value
    out = m._settings_to_frame_buffer(rows, np.eye(3), 1.0)
    expect = np.rint(m.linear_to_settings(np.clip(rows.astype(np.float64), 0, 1)) * 255)
    expect[np.isnan(rows)] = np.nan
    assert out.dtype == dtype
    np.testing.assert_array_equal(out, expect)


# -- metrics ------------------------------------------------------------------------
def test_numpy_lab_matches_colour_science():
    rng = np.random.default_rng(6)
    white = np.array([95.0, 100.0, 108.0])
    xyz = np.concatenate([rng.uniform(0, 120, (5000, 3)), rng.uniform(0, 0.5, (5000, 3))])  # both branches of f
    ref = colour.XYZ_to_Lab(xyz, colour.XYZ_to_xyY(white))
    np.testing.assert_allclose(metrics.xyz_to_lab(xyz, white), ref, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(metrics.delta_e(xyz[:5000], xyz[5000:], white), colour.delta_E(
        ref[:5000], ref[5000:], method="CIE 1976"), rtol=1e-12)
    lab32 = metrics.xyz_to_lab(xyz.astype(np.float32), white)
    assert lab32.dtype == np.float32
    np.testing.assert_allclose(lab32, ref, atol=2e-4)


def test_scielab_bands_give_the_numbers_of_one_transform(monkeypatch):
    from camsim_core.metrics import s_cielab

    rng = np.random.default_rng(7)
    a = ndimage.gaussian_filter(rng.uniform(5, 80, (70, 53, 3)), (1, 1, 0))
    b = a + rng.normal(0, 2, a.shape)
    white = np.array([95.0, 100.0, 108.0])
    whole = metrics.scielab(a, b, 30.0, white)  # one band: 70 rows < 512
    monkeypatch.setattr(s_cielab, "BAND_ROWS", 9)
    banded = metrics.scielab(a, b, 30.0, white)
    np.testing.assert_allclose(banded, whole, rtol=0, atol=1e-9)
    single = metrics.scielab(a.astype(np.float32), b.astype(np.float32), 30.0, white)
    assert single.dtype == np.float32
    np.testing.assert_allclose(single, whole, atol=2e-3)


def test_pipeline_keeps_the_ideal_lab_and_still_gives_fresh_numbers(base, camera, monkeypatch):
    from camsim_core.metrics import s_cielab

    calls = []
    real = s_cielab._filtered_lab  # what filtered_lab runs once it has checked its input, and what the pipeline calls
    monkeypatch.setattr(s_cielab, "_filtered_lab", lambda *a: calls.append(1) or real(*a))
    p = Pipeline()
    p.run(base, camera, Processing())
    assert len(calls) == 2  # camera and ideal image
    moved = camera.replace(noise_sigma=2.0)
    r = p.run(base, moved, Processing())
    assert len(calls) == 3  # only the camera image's side again
    fresh = metrics.scielab(r.xyz, r.ideal_xyz, metrics.samples_per_degree(r.rendered), r.white)
    np.testing.assert_array_equal(r.scielab, fresh)
    np.testing.assert_array_equal(r.delta_e, metrics.delta_e(r.xyz, r.ideal_xyz, r.white))


@pytest.mark.parametrize("beside", [True, False])
def test_an_scielab_move_checks_each_xyz_image_once(base, camera, monkeypatch, beside):
    """A distance move with S-CIELAB shown makes both images again; each one's finiteness pass runs once
    (the ideal's where its filtered L*a*b* is made; the camera's there too when it is made beside the ideal
    side, else in the error-map step after the join), and the map is the same either way."""
    from camsim_core import cache
    from camsim_core.metrics import cielab, s_cielab

    class NotYet:  # the ideal side still running when the camera's image reaches XYZ
        def __init__(self, future):
            self.future = future

        def done(self):
            return False

        def result(self):
            return self.future.result()

    start = cache._start
    monkeypatch.setattr(cache, "_start", (lambda fn, parallel: NotYet(start(fn, parallel=False))) if beside
                        else (lambda fn, parallel: start(fn, parallel=False)))
    checked, made = [], []
    real, real_lab = cielab.check_xyz, s_cielab._filtered_lab
    counting = lambda xyz, name="xyz": checked.append(name) or real(xyz, name)  # noqa: E731
    monkeypatch.setattr(cielab, "check_xyz", counting)
    monkeypatch.setattr(s_cielab, "check_xyz", counting)
    monkeypatch.setattr(s_cielab, "_filtered_lab", lambda *a: made.append(len(checked)) or real_lab(*a))
    p, shown = Pipeline(), Processing(metrics=("scielab",))
    p.run(base, camera, shown)
    checked.clear()
    made.clear()
    moved = camera.replace(distance=camera.distance * 1.1)  # (an exposure move keeps the scene's ideal image)
    r = p.run(base, moved, shown)
    assert "ideal" in r.ran_steps and "scielab" in r.ran_steps
    assert sorted(checked) == ["xyz", "xyz1"], checked
    assert made == [1, 2]  # the ideal's, then the camera's filtered L*a*b*, each made once its image is checked
    fresh = Pipeline().run(base, moved, shown)
    np.testing.assert_array_equal(r.scielab, fresh.scielab)


# -- experiments runner -------------------------------------------------------------
def test_choose_workers():
    assert choose_workers(10) is None  # a small sweep: in this process
    assert choose_workers(MIN_CLUSTER_TASKS - 1) is None
    assert choose_workers(MIN_CLUSTER_TASKS, cpus=2) == 2
    assert choose_workers(500, 0) is None
    assert choose_workers(3, 8) == 3  # never more workers than tasks
    with pytest.raises(ParameterError, match="workers"):
        choose_workers(5, -1)


def test_small_sweep_runs_in_process_by_default(tmp_path, capsys):
    from camsim_core.cli import main

    status = main(["experiment", "sensors", "--scenes", "stripes", "--alphas", "0,1", "--sigmas", "0",
                   "--no-progress", "--out", str(tmp_path / "out")])
    assert status == 0
    assert "2 tasks on this process" in capsys.readouterr().out


def test_cluster_sweep_leaves_no_process_behind(tmp_path):
    """The command's whole process group (scheduler, workers, their helpers) is gone when it ends."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.dirname(os.path.dirname(cs.__file__))] + sys.path))
    proc = subprocess.Popen(
        [sys.executable, "-m", "camsim_core.cli", "experiment", "sensors", "--scenes", "stripes", "--alphas", "0,1",
         "--sigmas", "0", "--workers", "1", "--no-progress", "--out", str(tmp_path / "out")],
        start_new_session=True, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "local Dask cluster of 1 worker" in out
    deadline = time.monotonic() + 20
    while True:  # start_new_session: the group id is the command's pid; exited children are reaped by init
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        assert time.monotonic() < deadline, "processes of the command are still running"
        time.sleep(0.2)


# -- the command line at 12 megapixels -------------------------------------------------
def test_cli_simulates_a_12_megapixel_raw(tmp_path, capsys):
    import tifffile

    from camsim_core.cli import main
    from camsim_core.simulation import resampled_size

    p = tmp_path / "scene.npz"
    rng = np.random.default_rng(8)
    np.savez(p, data=rng.uniform(0, 0.05, (160, 160, 31)).astype(np.float32), wavelengths=W31,
             distance=2.0, angular_resolution=[57.3, 57.3])
    # a distance at which the 160-pixel scene spans more than 4000 DCS-200 pixels
    d = 2.0 * 102.6 / 57.3 * 160 / 4300
    assert resampled_size(160, 57.3, 102.6, 2.0, d) > 4000
    out = tmp_path / "raw.tif"
    status = main(["simulate", "--scene", str(p), "--camera", "kodak-dcs200-ir", "--distance", f"{d:.6f}",
                   "--size", "3000x4000", "--exposure", "1", "--noise-sigma", "1", "--out", str(out)])
    assert status == 0
    raw = tifffile.imread(out)
    assert raw.shape == (3000, 4000) and raw.dtype == np.uint8
    assert "3000 x 4000" in capsys.readouterr().out


def test_cli_progress_bar_counts_the_steps(tmp_path, capsys, base, camera):
    from camsim_core.cli.simulate import _run_with_progress

    steps = [(s.__name__, lambda im, s=s: s(camera, im)) for s in camera.architecture]
    _run_with_progress(image_from_scene(base), steps, tmp_path / "r.tif", disable=False)
    err = capsys.readouterr().err
    assert "simulate" in err and "6/6" in err
    assert (tmp_path / "r.tif").exists()


def test_cli_size_is_checked(tmp_path, capsys):
    from camsim_core.cli import main

    with pytest.raises(SystemExit):
        main(["simulate", "--scene", "macbeth", "--camera", "kodak-dcs200-ir", "--size", "12by4", "--out", str(tmp_path / "x.tif")])
    assert "ROWSxCOLS" in capsys.readouterr().err
    assert not (tmp_path / "x.tif").exists()


@pytest.mark.parametrize("shape, size", [((50, 61), 5), ((7, 9), 3), ((40, 33), 7), ((3, 300), 5), ((6, 6), 4)])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_freeman_median_equals_scipy(shape, size, dtype):
    from camsim_core.demosaicing._median import median_filter

    x = np.random.default_rng(9).random(shape)
    x[::3] = np.round(x[::3], 1)  # ties
    x = x.astype(dtype)
    np.testing.assert_array_equal(median_filter(x, size), ndimage.median_filter(x, size=size, mode="mirror"))


def test_unrolled_median_module_is_the_generators_output():
    """``_median_unrolled.py`` is generated: the committed text is what the generator writes today."""
    from pathlib import Path

    from camsim_core.demosaicing import _median

    path = Path(_median.__file__).with_name("_median_unrolled.py")
    assert path.read_text() == _median.unrolled_source(), "regenerate _median_unrolled.py from unrolled_source()"


@pytest.mark.parametrize("size", [3, 5])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_unrolled_median_equals_the_row_network(size, dtype):
    """The straight-line kernel and the row-buffer kernel run the same comparators: the same values,
    with NaNs and infinities too (where scipy's median, which sorts differently, is no reference)."""
    from camsim_core.demosaicing import _median

    x = np.random.default_rng(12).standard_normal((37, 203)).astype(dtype)
    x[::5, ::7] = np.nan
    x[3::11, 2::13] = np.inf
    x[4::9, ::17] = -np.inf
    x[::2] = np.round(x[::2], 1)  # ties
    x[20:27, 100:110] = np.inf  # a clump whose medians are infinite
    padded = np.pad(x, size // 2, mode="reflect")
    unrolled, rows = np.full_like(x, 7.0), np.full_like(x, 7.0)
    _median._unrolled_kernel(size)(padded, unrolled)
    _median._kernel()(padded, size, _median.median_network(size * size), rows)
    assert np.isnan(rows).any() and np.isinf(rows).any()
    np.testing.assert_array_equal(unrolled, rows)


@pytest.mark.parametrize("tile", [
    BAYER["GRBG"][:, :, None],
    np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])[:, :, None],
    (np.arange(16).reshape(4, 4) % 4)[:, :, None],
    np.stack([BAYER["RGGB"], BAYER["RGGB"][::-1]], axis=2),  # tiered
])
@pytest.mark.parametrize("shape, size", [((41, 57), 5), ((9, 14), 3), ((30, 23), 7), ((70, 9), 5)])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("band_pixels", [None, 100])  # the default (one band here), and bands of a few rows
def test_freeman_by_bands_equals_whole_planes(tile, shape, size, dtype, band_pixels, monkeypatch):
    """Freeman's banded path (difference, median, sum and samples band by band) gives the numbers of
    the same steps on whole planes (scipy's median), bit for bit."""
    from camsim_core.demosaicing import freeman
    from camsim_core.demosaicing.freeman import _by_planes, demosaic_freeman, reference_class

    if band_pixels:
        monkeypatch.setattr(freeman, "BAND_PIXELS", band_pixels)

    k = int(tile.max()) + 1
    data = np.random.default_rng(11).uniform(0, 255, shape + (tile.shape[2],)).astype(dtype)
    data[::4] = np.round(data[::4], -1)  # ties in the medians
    raw = cs.raw_from_array(data if tile.shape[2] > 1 else data[:, :, 0], tile if tile.shape[2] > 1 else tile[:, :, 0])
    raw = raw.replace(data=np.asarray(raw.data).astype(dtype))
    est = bilinear_planes(data, tile, k)
    expected = _by_planes(est, tile, k, reference_class(tile, k), size)
    out = demosaic_freeman(raw, size)
    assert out.dtype == dtype
    np.testing.assert_array_equal(out, expected)


@pytest.mark.parametrize("tile, window", [
    (BAYER["GRBG"], None),  # 7 x 7 window: 49 taps, whole groups of seven
    (BAYER["RGGB"], 5),  # 25 taps: padded to 28
    (np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]]), None),  # 9 x 9 window: 81 taps, padded to 84
    (np.stack([BAYER["RGGB"], BAYER["RGGB"][::-1]], axis=2), None),  # tiered
])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_bayesian_three_sensor_kernel_equals_the_generic_one(tile, window, dtype, monkeypatch):
    """The kernel for three sensors (taps seven at a time) adds the same products in the same order
    as the generic one (a tap and a sensor at a time): the same values, bit for bit."""
    from camsim_core.demosaicing import bayesian

    shape = (45, 62) + ((tile.shape[2],) if tile.ndim == 3 else ())
    data = np.random.default_rng(13).uniform(0, 255, shape).astype(dtype)
    raw = cs.raw_from_array(data, tile)
    raw = raw.replace(data=np.asarray(raw.data).astype(dtype), noise_sigma=2.0)
    three = bayesian.demosaic_bayesian(raw, window=window)
    monkeypatch.setattr(bayesian, "_filter_kernel3", bayesian._filter_kernel)
    generic = bayesian.demosaic_bayesian(raw, window=window)
    assert three.dtype == dtype and np.isfinite(three).all()
    np.testing.assert_array_equal(three, generic)


def test_take_grid_equals_fancy_indexing():
    """Phase planes by slicing the evenly spaced middle equal ``src[np.ix_(rows, cols)]``, for the padded
    phase indices Bayesian demosaicing uses and for index arrays with no even middle."""
    from camsim_core.demosaicing._masks import phase_pad_index
    from camsim_core.demosaicing.bayesian import _take_grid

    rng = np.random.default_rng(14)
    src = rng.random((31, 40)).astype(np.float32)
    cases = []
    for n, m, half in ((2, 2, 3), (3, 3, 4), (2, 3, 2), (1, 1, 3)):
        iy, ix = phase_pad_index(31, half, n), phase_pad_index(40, half, m)
        cases += [(iy[q::n], ix[r::m]) for q in range(n) for r in range(m)]
    cases += [(rng.integers(0, 31, 9), rng.integers(0, 40, 12)), (np.array([5]), np.array([7, 7, 7])),
              (np.array([4, 2, 0]), np.arange(40)[::-3])]
    for rows, cols in cases:
        dst = np.full((rows.size, cols.size), -1.0, np.float32)
        _take_grid(src, rows, cols, dst)
        np.testing.assert_array_equal(dst, src[np.ix_(rows, cols)])


def test_to_screen_block_means():
    from camsim_core.screen import to_screen

    img = np.random.default_rng(10).uniform(0, 255, (3000, 4000, 3)).astype(np.float32)
    view, block = to_screen(img, (1000, 1600))
    assert block == 3 and view.shape == (1000, 1334, 3) and view.dtype == np.float32
    np.testing.assert_allclose(view[5, 7], img[15:18, 21:24].reshape(-1, 3).mean(axis=0), rtol=1e-5)
    np.testing.assert_allclose(view[-1, -1], img[2997:, 3999:].reshape(-1, 3).mean(axis=0), rtol=1e-5)  # partial block
    np.testing.assert_allclose(view.mean(), img[:, :4000].mean(), rtol=1e-3)
    # zoomed in: a region small enough is sent at full resolution
    detail, b = to_screen(img, (1000, 1600), region=(100, 200, 500, 800))
    assert b == 1 and np.array_equal(detail, img[100:600, 200:1000])
    small, b = to_screen(np.arange(12).reshape(3, 4), (2, 2))
    assert b == 2 and np.allclose(small, [[2.5, 4.5], [8.5, 10.5]])
    with pytest.raises(ParameterError, match="region"):
        to_screen(img, region=(0, 0, 0, 5))
    with pytest.raises(ParameterError, match="data"):
        to_screen(np.zeros(5))


@pytest.mark.parametrize("shape, max_shape, region", [((7, 9, 4), (3, 4), None), ((7, 9), (2, 2), None),
                                                      ((50, 31, 3), (6, 40), (3, 5, 40, 20)),
                                                      ((1, 1, 4), (1, 1), None), ((30, 20, 1), (1, 1), None)])
def test_to_screen_of_an_8_bit_picture_is_each_blocks_exact_mean(shape, max_shape, region):
    """8-bit pictures (the explorer's packed RGBA views) take a compiled path: each view pixel is the sum of its
    block's values (partial blocks at the edges included) over their count, divided in float32, checked here
    block by block with integer sums."""
    from camsim_core.screen import to_screen

    img = np.random.default_rng(sum(shape)).integers(0, 256, shape).astype(np.uint8)
    view, block = to_screen(img, max_shape, region)
    top, left, height, width = region or (0, 0) + shape[:2]
    part = img[top : top + height, left : left + width]
    assert view.dtype == np.float32 and view.shape[2:] == shape[2:]
    assert view.shape[:2] == (-(-part.shape[0] // block), -(-part.shape[1] // block))
    assert view.shape[0] <= max_shape[0] and view.shape[1] <= max_shape[1]
    for i in range(view.shape[0]):
        for j in range(view.shape[1]):
            cell = part[i * block : (i + 1) * block, j * block : (j + 1) * block].astype(np.int64)
            n = cell.shape[0] * cell.shape[1]
            expected = np.float32(cell.sum(axis=(0, 1))) / np.float32(n)
            assert np.array_equal(view[i, j], expected), (i, j)
