"""Benchmark: the engine side of an explorer slider move.

For each parameter a user can move, the cached pipeline
(:class:`camsim_core.cache.Pipeline`) is warmed on the default scene
(cacaphony290 seen by the kodak-dcs200-ir at 3.32 m, 0.1 s at f/11, about
233 x 372 pixels), then the parameter is toggled between two values
``--repeats`` times. Printed per parameter: the steps that re-ran, the median
engine time of a move, the slowest step, and the ratio to a full (uncached)
run measured in the same process. The target is < 100 ms per move.

Usage: ``python benchmarks/explorer.py [--repeats N] [--threads N]``.
BLAS is limited to one thread by default (``--threads``): the matrices are
small, and on a shared machine BLAS threads only add contention.
"""

from __future__ import annotations

import argparse
import os
import sys


def _parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=7, help="moves per parameter (median reported)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (set before numpy loads)")
    return p.parse_args()


ARGS = _parse() if __name__ == "__main__" else None
if ARGS is not None:
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, str(ARGS.threads))

import time  # noqa: E402

import numpy as np  # noqa: E402

import camsim_core as cc  # noqa: E402
from camsim_core.cache import Pipeline, Processing  # noqa: E402
from camsim_core.datasets.sensors import mixture  # noqa: E402
from camsim_core.simulation import BAYER  # noqa: E402

TARGET_MS = 100.0


def default_setup():
    scene = cc.load_scene("cacaphony290")
    camera = cc.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0, seed=0)
    return scene, camera, Processing(metrics=("cielab",))


def moves(camera, proc):
    """(label, [(camera, processing), (camera, processing)]) pairs toggled by the benchmark."""
    c, p = camera, proc
    s_a, s_b = mixture(0.5), mixture(0.6)
    sc = Processing(metrics=("cielab", "scielab"))
    return [
        ("noise_sigma 0 <-> 2", [(c, p), (c.replace(noise_sigma=2.0), p)]),
        ("seed 0 <-> 1 (sigma 2)", [(c.replace(noise_sigma=2.0, seed=0), p), (c.replace(noise_sigma=2.0, seed=1), p)]),
        ("bits 8 <-> 10", [(c, p), (c.replace(bits=10), p)]),
        ("mosaic GRBG <-> RGGB", [(c, p), (c.replace(mosaic=BAYER["RGGB"]), p)]),
        ("exposure 0.1 <-> 0.12 s", [(c, p), (c.replace(exposure=0.12), p)]),
        ("f_stop 11 <-> 8", [(c, p), (c.replace(f_stop=8.0), p)]),
        ("alpha 0.5 <-> 0.6 (sensors)", [(c.replace(sensors=s_a), p), (c.replace(sensors=s_b), p)]),
        ("distance 3.32 <-> 3.0 m", [(c, p), (c.replace(distance=3.0), p)]),
        ("demosaic bilinear <-> freeman", [(c, p), (c, Processing(demosaic="freeman", metrics=p.metrics))]),
        ("render baseline <-> illuminant", [(c, p), (c, Processing(render="illuminant", metrics=p.metrics))]),
        ("monitor simtoolbox-test <-> brainard-crt", [(c, p), (c, Processing(monitor="brainard-crt", metrics=p.metrics))]),
        ("noise_sigma 0 <-> 2, S-CIELAB shown", [(c, sc), (c.replace(noise_sigma=2.0), sc)]),
    ]


def full_run_ms(scene, camera, proc, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = Pipeline().run(scene, camera, proc)
        times.append(time.perf_counter() - t0)
        if r.errors:
            raise SystemExit(f"full run failed: {r.errors}")
    return 1000 * float(np.median(times))


def measure(scene, pair, repeats):
    """Median engine ms of a move, the steps that ran, and median ms per step."""
    pipe = Pipeline()
    pipe.run(scene, *pair[0])
    pipe.run(scene, *pair[1])
    totals, per_step, steps, errors = [], {}, None, {}
    for i in range(repeats):
        cam, proc = pair[i % 2]
        t0 = time.perf_counter()
        r = pipe.run(scene, cam, proc)
        totals.append(time.perf_counter() - t0)
        errors.update(r.errors)
        steps = [s.removeprefix("stage:") for s in r.ran_steps]
        for name, t in r.ran:
            per_step.setdefault(name.removeprefix("stage:"), []).append(t)
    return 1000 * float(np.median(totals)), steps, {k: 1000 * float(np.median(v)) for k, v in per_step.items()}, errors


def main(args):
    scene, camera, proc = default_setup()
    shape = cc.simulate(scene, camera).data.shape
    print(f"scene {scene.name} {scene.data.shape[0]}x{scene.data.shape[1]}x{scene.data.shape[2]}; "
          f"camera {camera.name} at {camera.distance} m, {camera.exposure} s f/{camera.f_stop:g}: "
          f"{shape[0]} x {shape[1]} pixels; BLAS threads {os.environ.get('OPENBLAS_NUM_THREADS')}; "
          f"{args.repeats} moves per parameter (median)")
    full = full_run_ms(scene, camera, proc, max(3, args.repeats // 2))
    full_sc = full_run_ms(scene, camera, Processing(metrics=("cielab", "scielab")), max(3, args.repeats // 2))
    print(f"baseline: full uncached run {full:.1f} ms (CIELAB), {full_sc:.1f} ms (CIELAB + S-CIELAB)\n")
    rows = []
    for label, pair in moves(camera, proc):
        ms, steps, per_step, errors = measure(scene, pair, args.repeats)
        slow = max(per_step, key=per_step.get)
        base = full_sc if "S-CIELAB" in label else full
        rows.append((label, " > ".join(steps), ms, f"{slow} {per_step[slow]:.1f}", ms / base, errors))
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    print(f"{'parameter':<{w0}}  {'steps re-run':<{w1}}  {'engine ms':>9}  {'slowest step ms':<22}  {'vs full':>7}  <100ms")
    print("-" * (w0 + w1 + 56))
    for label, steps, ms, slow, ratio, errors in rows:
        ok = "yes" if ms < TARGET_MS else "NO"
        print(f"{label:<{w0}}  {steps:<{w1}}  {ms:9.1f}  {slow:<22}  {ratio:7.2f}  {ok}")
        for k, v in errors.items():
            print(f"{'':<{w0}}  ! {k}: {v}")
    within = sum(r[2] < TARGET_MS for r in rows)
    print(f"\n{within}/{len(rows)} moves under {TARGET_MS:.0f} ms.")
    return 0


if __name__ == "__main__":
    sys.exit(main(ARGS))
