"""Time of each simulation stage, beside a bare ``cube.reshape(-1, 31) @ weights`` measured in the same run.

Run: ``.venv/bin/python benchmarks/pipeline.py``. Prints one table per scene:
the default scene (cacaphony290 through kodak-dcs200-ir at 3.32 m) and a
synthetic 1024 x 1024 x 31 scene; each stage's best-of-N time, and the sensor
stage's ratio to the bare matrix product (target <= 1.5x); and the lens at
f/11 against the sensor stage: the fused lens-and-sensor stage a camera with
optics runs (the lens's own cost, fused minus sensor, target <= 3x the sensor
stage) and the per-wavelength optics stage.
"""

from __future__ import annotations

import os

# one BLAS thread, as `make serve` runs the explorer: threads only contend on these small products
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import time  # noqa: E402

import numpy as np  # noqa: E402

import camsim_core as cs
from camsim_core.image import image_from_scene
from camsim_core.scene import Scene
from camsim_core.simulation import sensor_weights


def best_of(func, repeat, number=1):
    """Best over ``repeat`` samples of the mean time of ``number`` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            out = func()
        times.append((time.perf_counter() - t0) / number)
    return min(times), out


def bench(scene, camera, repeat, number):
    """Best-of-``repeat`` times; the bare product is timed alternately with the stages,
    so that both see the same machine load."""
    rows = []
    weights, _ = sensor_weights(camera, scene.wavelengths)
    cube = scene.data
    weights = np.asarray(weights, cube.dtype)  # the product in the scene's dtype (a float64 matrix would upcast it)
    bare = lambda: cube.reshape(-1, cube.shape[2]) @ weights  # noqa: E731
    t_bare = np.inf
    image = image_from_scene(scene)
    stage_rows = []
    for stage in camera.architecture:
        t_stage = np.inf
        for _ in range(repeat):
            t_bare = min(t_bare, best_of(bare, 1, number)[0])
            t, out = best_of(lambda s=stage, im=image: s(camera, im), 1, number)
            t_stage = min(t_stage, t)
        image = out
        stage_rows.append((stage.__name__, t_stage))
    rows.append(("bare cube.reshape(-1, 31) @ weights", t_bare, 1.0))
    rows += [(name, t, t / t_bare) for name, t in stage_rows]
    total, _ = best_of(lambda: cs.simulate(scene, camera), repeat, number)
    rows.append(("simulate (all stages)", total, total / t_bare))
    return rows, image.data.shape


def optics_row(scene, camera, repeat, number):
    """The lens at f/11 three ways, timed alternately: the sensor stage alone, the fused lens-and-sensor
    stage a camera with optics runs, and the per-wavelength optics stage (spectral planes at the sensor)."""
    from camsim_core.optics import lens_sensor_responses, optics
    from camsim_core.simulation import sensor_responses

    cam = camera.replace(optics="diffraction")
    image = image_from_scene(scene)
    lens_sensor_responses(cam, image)  # the low-rank OTF is computed once per grid and kept
    t_optics = t_sensor = t_fused = np.inf
    for _ in range(repeat):
        t_sensor = min(t_sensor, best_of(lambda: sensor_responses(cam, image), 1, number)[0])
        t_fused = min(t_fused, best_of(lambda: lens_sensor_responses(cam, image), 1, number)[0])
        t_optics = min(t_optics, best_of(lambda: optics(cam, image), 1, number)[0])
    return t_optics, t_sensor, t_fused


def main():
    default_scene = cs.load_scene("cacaphony290")
    camera = cs.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=2.0)
    rng = np.random.default_rng(0)
    big = Scene(rng.uniform(0, 0.05, (1024, 1024, 31)), np.arange(400, 701, 10.0), distance=3.32, angular_resolution=(102.6, 102.6))
    for label, scene, repeat, number in (("default scene cacaphony290 (182 x 290 x 31)", default_scene, 10, 20),
                                         ("synthetic 1024 x 1024 x 31", big, 5, 1)):
        rows, shape = bench(scene, camera, repeat, number)
        print(f"\n{label} -> camera image {shape}, best of {repeat} x {number} calls")
        print(f"{'stage':40s} {'time (ms)':>10s} {'x bare':>8s}")
        for name, t, ratio in rows:
            print(f"{name:40s} {t * 1e3:10.2f} {ratio:8.2f}")
        sensor = dict((r[0], r[2]) for r in rows)["sensor_responses"]
        print(f"sensor stage / bare product = {sensor:.2f} (target <= 1.5)")
        for dtype in (np.dtype(np.float64), np.dtype(np.float32)):  # the shipped scenes load as float32
            typed = Scene(scene.data.astype(dtype, copy=False), scene.wavelengths, distance=scene.distance,
                          angular_resolution=scene.angular_resolution)
            t_optics, t_sensor, t_fused = optics_row(typed, camera, repeat, max(1, number // 4))
            kind = np.dtype(dtype).name
            print(f"{'sensor stage, ' + kind:40s} {t_sensor * 1e3:10.2f} {1.0:8.2f}")
            print(f"{'lens + sensor stage (fused), ' + kind:40s} {t_fused * 1e3:10.2f} {t_fused / t_sensor:8.2f}   "
                  f"the lens's own cost = {(t_fused - t_sensor) / t_sensor:.2f} x the sensor stage (target <= 3)")
            print(f"{'optics stage, 31 planes, ' + kind:40s} {t_optics * 1e3:10.2f} {t_optics / t_sensor:8.2f}   "
                  f"(per wavelength: the spectral planes at the sensor)")


if __name__ == "__main__":
    main()
