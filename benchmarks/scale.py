"""camsim at sensor sizes: every engine step from 256^2 to 2048^2 x 31 float32 scenes, up to a 12-megapixel raw.

Run: ``python benchmarks/scale.py`` (about 2-4 minutes on 2 shared cores).

The scene at size N is the shipped Cacaphony scene tiled to N x N x 31,
float32 (real spectra, its illuminant and geometry). The camera is the Kodak
DCS-200 (IR filter, Bayer) moved to the distance at which the 2048-pixel
scene fills a 4000 x 3000 sensor, and at every N its pixel array is scaled
with N (N x 4000/2048 by N x 3000/2048), so the raw has ~2.86 N^2 pixels:
12 megapixels at N = 2048. Noise sigma 2 DU, 8 bits.

Printed:

1. Per step, the median time (ms) at each size over interleaved repeats (each
   repeat runs the bare product and then every step once, so all see the same
   machine load; five repeats at 1024^2 and above, ten below: at 12 MP a
   step's first run in a process, and now and then a later one, pays the
   kernel for fresh huge pages, 2-5x its time, and the median of five
   outlasts two such runs), the fitted exponent of time against pixel count (1.0 is
   linear), and the ratio to the bare ``cube.reshape(-1, 31) @ W`` in float32
   at the largest size.
2. The goals as ratios measured in the same run.
3. Peak resident memory of the full chain (scene, simulate, bilinear
   demosaic, baseline render, ideal image, CIELAB and S-CIELAB) per size,
   each in a fresh subprocess, against the scene's own bytes: peak RSS minus
   the RSS before the scene was made (and minus the RSS once it was made,
   plus its bytes). Twice: as a script chains the calls (intermediates
   released; the metrics given the rendered images and their monitor) and
   with every result kept (the raw, demosaiced and XYZ images too). The
   goal is the first; the second is printed beside its floor, the scene and
   the results themselves (at 12 MP the results alone are 1.7x the scene).
4. Explorer moves (the cached pipeline) on the default scene and on a
   1024 x 1024 tiled scene through the explorer's default camera.

BLAS is limited to one thread (``OPENBLAS_NUM_THREADS=1``) as ``make serve`` runs.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import resource  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

SIZES = (256, 512, 1024, 2048)
RAW_AT_2048 = (3000, 4000)  # rows, columns of the 12-megapixel raw


def _rss_mib():
    """Current resident set size, MiB (Linux /proc)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def tiled_cube(n, dtype=np.float32, base=None):
    """The Cacaphony scene tiled (mirrored, so no seams) to n x n x 31, in ``dtype``; and the scene.

    Written by blocks of 16 rows, so that making it leaves no temporaries of
    the cube's size on the heap (they would count in the chain's memory).
    """
    import camsim_core as cs

    base = base if base is not None else cs.load_scene("cacaphony290")
    h, w = base.data.shape[:2]

    def mirrored(count, period):  # 0..p-1, p-1..0, 0..p-1, ...
        i = np.arange(count) % (2 * period)
        return np.where(i < period, i, 2 * period - 1 - i)

    rows, cols = mirrored(n, h), mirrored(n, w)
    cube = np.empty((n, n, base.data.shape[2]), dtype)
    for y in range(0, n, 16):
        cube[y : y + 16] = base.data[rows[y : y + 16]][:, cols]
    cube.flags.writeable = False  # a read-only array: Scene keeps it without a copy
    return cube, base


def make_scene(n, base=None):
    from camsim_core.scene import Scene

    cube, base = tiled_cube(n, base=base)
    return Scene(cube, base.wavelengths, base.distance, base.angular_resolution, base.unit, base.illuminant, f"cacaphony tiled {n}")


def scaled_camera(n):
    """The DCS-200 at the distance where 2048 scene pixels span 4000 camera pixels, array scaled with n."""
    import camsim_core as cs
    from scipy.optimize import brentq

    from camsim_core.simulation import resampled_size

    cam = cs.load_camera("kodak-dcs200-ir")
    Phi, phi, D = 57.3, cam.angular_resolution[0], 2.375
    d = brentq(lambda d: resampled_size(2048, Phi, phi, D, d) - 4000.5, 0.5, 10.0)
    h, w = (max(1, round(n * s / 2048)) for s in RAW_AT_2048)
    return cam.replace(distance=d, exposure=0.1, f_stop=11.0, noise_sigma=2.0, seed=0, height=h, width=w)


def steps(scene, camera):
    """(name, function) of every engine step, each fed by the previous steps' outputs."""
    import colour_demosaicing

    import camsim_core as cs
    from camsim_core import metrics
    from camsim_core.image import image_from_scene
    from camsim_core.rendering import white_xyz
    from camsim_core.simulation import digitize, mosaic, noise, resample, sensor_responses

    mon = cs.load_monitor("simtoolbox-test")
    st = {}

    def put(key, f):
        def run():
            st[key] = f()
            return st[key]

        return run

    spd = metrics.samples_per_degree(camera)
    white = white_xyz(mon)
    other_tile = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])
    return [
        ("sensor_responses", put("s", lambda: sensor_responses(camera, image_from_scene(scene)))),
        ("resample", put("r", lambda: resample(camera, st["s"]))),
        ("mosaic", put("m", lambda: mosaic(camera, st["r"]))),
        ("noise", put("n", lambda: noise(camera, st["m"]))),
        ("digitize", put("raw", lambda: digitize(camera, st["n"]))),
        ("demosaic bilinear", put("dem", lambda: cs.demosaic(st["raw"], "bilinear"))),
        ("  colour-demosaicing bilinear", lambda: colour_demosaicing.demosaicing_CFA_Bayer_bilinear(st["raw"].data, "GRBG")),
        ("  bilinear, 3x3 tile", lambda: cs.demosaic(st["raw"].replace(tile=other_tile), "bilinear")),
        ("  demosaic freeman", lambda: cs.demosaic(st["raw"], "freeman")),
        ("  demosaic bayesian", lambda: cs.demosaic(st["raw"], "bayesian")),
        ("render baseline", put("ren", lambda: cs.render(st["dem"], mon))),
        ("ideal image", put("ideal", lambda: cs.ideal_image(scene, camera, mon))),
        ("xyz (both)", put("xyz", lambda: (cs.to_xyz(st["ren"], mon), cs.to_xyz(st["ideal"], mon)))),
        ("delta_e CIELAB", lambda: metrics.delta_e(st["xyz"][0], st["xyz"][1], white)),
        ("S-CIELAB", lambda: metrics.scielab(st["xyz"][0], st["xyz"][1], spd, white)),
    ]


CHAIN = ("sensor_responses", "resample", "mosaic", "noise", "digitize", "demosaic bilinear", "render baseline",
         "ideal image", "xyz (both)", "delta_e CIELAB", "S-CIELAB")
SIMULATE = CHAIN[:5]


def child_time(n, repeats):
    """Median ms per step at size n, interleaved with the bare product."""
    from camsim_core.simulation import sensor_weights

    scene = make_scene(n)
    camera = scaled_camera(n)
    weights = sensor_weights(camera, scene.wavelengths)[0].astype(np.float32)
    cube = scene.data
    todo = [("bare cube.reshape(-1, 31) @ W", lambda: cube.reshape(-1, cube.shape[2]) @ weights)] + steps(scene, camera)
    times = {name: [] for name, _ in todo}
    for _, f in todo:  # warm-up: compiled kernels, FFT plans, tables (not timed)
        f()
    for _ in range(repeats):
        for name, f in todo:
            t0 = time.perf_counter()
            out = f()
            times[name].append(time.perf_counter() - t0)
            del out
    return {"n": n, "ms": {k: 1e3 * float(np.median(v)) for k, v in times.items()}, "raw": [camera.height, camera.width],
            "dtype": str(scene.data.dtype)}


def _chain(scene, camera, mon, keep):
    """The full chain; ``keep="script"`` releases each intermediate once the next stage has it, ``"all"`` keeps
    every result (the raw, the demosaiced image and both XYZ images too). Returns the kept results."""
    import camsim_core as cs
    from camsim_core import metrics
    from camsim_core.rendering import white_xyz

    white, spd = white_xyz(mon), metrics.samples_per_degree(camera)
    if keep == "script":
        # as a script writes it: nothing names the raw or the demosaiced image, and the metrics take the
        # rendered images with their monitor (XYZ made band by band inside)
        ren = cs.render(cs.demosaic(cs.simulate(scene, camera), "bilinear"), mon)
        ideal = cs.ideal_image(scene, camera, mon)
        de = metrics.delta_e(ren, ideal, white, monitor=mon)
        sde = metrics.scielab(ren, ideal, spd, white, monitor=mon)
        return {"rendered": ren, "ideal": ideal, "de": de, "scielab": sde}
    raw = cs.simulate(scene, camera)
    dem = cs.demosaic(raw, "bilinear")
    ren = cs.render(dem, mon)
    ideal = cs.ideal_image(scene, camera, mon)
    xyz, ixyz = cs.to_xyz(ren, mon), cs.to_xyz(ideal, mon)
    de = metrics.delta_e(xyz, ixyz, white)
    sde = metrics.scielab(xyz, ixyz, spd, white)
    return {"raw": raw, "demosaiced": dem, "rendered": ren, "ideal": ideal, "xyz": (xyz, ixyz), "de": de, "scielab": sde}


def _nbytes(obj):
    """Bytes of the arrays a result holds (an image's data, an array, a tuple of them)."""
    if isinstance(obj, tuple):
        return sum(_nbytes(o) for o in obj)
    data = obj if isinstance(obj, np.ndarray) else getattr(obj, "data", None)  # an ndarray's own .data is a buffer
    if not isinstance(data, np.ndarray):
        raise TypeError(f"a chain result of type {type(obj).__name__} holds no array the benchmark can count")
    return int(data.nbytes)


def child_memory(n, frame, keep):
    """Peak RSS of the full chain: over the RSS before the scene existed, and over the RSS with the scene made.

    The chain (simulate, bilinear demosaic, baseline render, the ideal
    image, CIELAB and S-CIELAB) as :func:`_chain` runs it with ``keep``.
    Imports and what they cache (compiled kernels, FFT plans, colour tables)
    are not the chain's: the chain runs once on a 64 x 64 scene first.
    ``frame``: "scaled" (the 12-megapixel geometry) or "dcs200" (the
    camera's own 1012 x 1524 array).
    """
    import camsim_core as cs

    mon = cs.load_monitor("simtoolbox-test")
    base = cs.load_scene("cacaphony290")  # the scene the cube is tiled from is not the chain's either
    _chain(make_scene(64, base), scaled_camera(64), mon, keep)
    rss0 = _rss_mib()
    scene = make_scene(n, base)
    rss_scene = _rss_mib()  # the scene and what making it left on the heap (the tiling's temporaries)
    camera = scaled_camera(n)
    if frame == "dcs200":
        camera = camera.replace(height=1012, width=1524)
    scene_mib = scene.data.nbytes / 2**20
    kept = _chain(scene, camera, mon, keep)
    return {"n": n, "scene_mib": scene_mib, "rss0": rss0, "rss_scene": rss_scene, "peak_mib": _peak_mib(),
            "dtype": str(scene.data.dtype), "frame": list(kept["rendered"].data.shape[:2]),
            "mean_de": float(kept["de"].mean()), "mean_scielab": float(kept["scielab"].mean()),
            "kept_mib": sum(_nbytes(v) for v in kept.values()) / 2**20}


def child_explorer(repeats):
    """Median engine ms of explorer moves on the default scene and a 1024^2 tiled one."""
    import camsim_core as cs
    from camsim_core.cache import Pipeline, Processing

    camera = cs.load_camera("kodak-dcs200-ir").replace(distance=3.32, exposure=0.1, f_stop=11.0, noise_sigma=0.0, seed=0)
    # what the explorer computes with S-CIELAB shown: that map alone (processing_from_params)
    scielab = Processing(metrics=("scielab",))
    out = {}
    for label, scene in (("default scene 182x290", cs.load_scene("cacaphony290")), ("1024x1024 scene", make_scene(1024))):
        shape = cs.simulate(scene, camera).data.shape
        for move, pair in (
            ("noise 0<->2, CIELAB", [(camera, Processing(metrics=("cielab",))), (camera.replace(noise_sigma=2.0), Processing(metrics=("cielab",)))]),
            ("noise 0<->2, S-CIELAB", [(camera, scielab), (camera.replace(noise_sigma=2.0), scielab)]),
            ("exposure 0.1<->0.12, CIELAB", [(camera, Processing(metrics=("cielab",))), (camera.replace(exposure=0.12), Processing(metrics=("cielab",)))]),
            ("exposure 0.1<->0.12, S-CIELAB", [(camera, scielab), (camera.replace(exposure=0.12), scielab)]),
        ):
            pipe = Pipeline()
            pipe.run(scene, *pair[0])
            pipe.run(scene, *pair[1])
            ts = []
            for i in range(repeats):
                r = pipe.run(scene, *pair[i % 2])
                ts.append(r.elapsed)  # wall time: the ideal side may run beside the camera side
            out[f"{label} -> {shape[0]}x{shape[1]}: {move}"] = 1e3 * float(np.median(ts))
    return out


def _child(args):
    cmd = [sys.executable, __file__] + args
    res = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def exponent(pixels, ms):
    """Least-squares slope of log(time) against log(pixels)."""
    return float(np.polyfit(np.log(pixels), np.log(ms), 1)[0])


def main(args):
    print(f"camsim scale benchmark; BLAS threads {os.environ.get('OPENBLAS_NUM_THREADS')}; sizes {args.sizes}; "
          f"float32 scenes (Cacaphony tiled); medians of interleaved repeats")
    results = []
    for n in args.sizes:
        reps = args.repeats if n >= 1024 else 2 * args.repeats
        results.append(_child(["--child-time", str(n), "--repeats", str(reps)]))
        print(f"  timed {n}^2 ({reps} repeats)", file=sys.stderr)
    names = list(results[0]["ms"])
    pixels = [r["raw"][0] * r["raw"][1] for r in results]
    head = "".join(f"{'%d^2->%dx%d' % (r['n'], r['raw'][0], r['raw'][1]):>20s}" for r in results)
    print(f"\n{'step (ms)':34s}{head}{'exponent':>10s}{'x bare':>8s}")
    last = results[-1]["ms"]
    bare = last["bare cube.reshape(-1, 31) @ W"]
    for name in names:
        ms = [r["ms"][name] for r in results]
        print(f"{name:34s}" + "".join(f"{m:20.1f}" for m in ms) + f"{exponent(pixels, ms):10.2f}{last[name] / bare:8.2f}")
    for label, keys in (("simulate (5 stages)", SIMULATE), ("full chain", CHAIN)):
        ms = [sum(r["ms"][k] for k in keys) for r in results]
        print(f"{label:34s}" + "".join(f"{m:20.1f}" for m in ms) + f"{exponent(pixels, ms):10.2f}{ms[-1] / bare:8.2f}")

    big = results[-1]
    sim = sum(last[k] for k in SIMULATE)
    bil = last["demosaic bilinear"]
    print(f"\nGoals at {big['n']}^2 x 31 {big['dtype']} -> {big['raw'][0]} x {big['raw'][1]} raw (same run):")
    goals = [
        ("simulate / bare float32 matmul", sim / bare, 4.0),
        ("bilinear / colour-demosaicing bilinear (Bayer)", bil / last["  colour-demosaicing bilinear"], 1.0),
        ("bilinear 3x3 tile / colour-demosaicing bilinear (Bayer)", last["  bilinear, 3x3 tile"] / last["  colour-demosaicing bilinear"], 1.0),
        ("freeman / bilinear", last["  demosaic freeman"] / bil, 3.0),
        ("bayesian / bilinear", last["  demosaic bayesian"] / bil, 2.0),
    ]
    # camsim's own steps: the bare product and the colour-demosaicing reference are baselines, not steps
    own = [k for k in names if not k.startswith("bare") and "colour-demosaicing" not in k]
    worst = max(
        exponent(pixels, [r["ms"][k] for r in results]) for k in own)
    goals.append(("largest fitted exponent of any step", worst, 1.05))
    notes = []
    if not args.no_memory:
        print("\nPeak memory of the full chain (fresh subprocess per size). Over the RSS before the scene: peak RSS -"
              " RSS before it; over the RSS with it: peak RSS - RSS once made + the scene's bytes (leaves out what"
              " tiling the scene left on the heap). 'script': intermediates released as a script chains the calls,"
              " the metrics given the rendered images; 'all': every result kept, XYZ images too. 'floor': the scene"
              " and the results the chain returns, which any chain keeping them holds at its end.")
        print(f"{'keep':>7s}{'scene':>7s}{'raw':>12s}{'scene MiB':>11s}{'peak RSS MiB':>14s}{'chain MiB':>11s}"
              f"{'x scene':>9s}{'with scene':>12s}{'x scene':>9s}{'floor':>8s}")
        for keep in ("all", "script"):
            for frame in ("dcs200", "scaled"):
                for n in args.sizes:
                    m = _child(["--child-memory", str(n), "--frame", frame, "--keep", keep])
                    chain = m["peak_mib"] - m["rss0"]
                    over = m["peak_mib"] - m["rss_scene"] + m["scene_mib"]
                    raw = "x".join(str(v) for v in m["frame"])
                    floor = 1.0 + m["kept_mib"] / m["scene_mib"]
                    print(f"{keep:>7s}{f'{n}^2':>7s}{raw:>12s}{m['scene_mib']:11.0f}{m['peak_mib']:14.0f}{chain:11.0f}"
                          f"{chain / m['scene_mib']:9.2f}{over:12.0f}{over / m['scene_mib']:9.2f}"
                          f"{floor:8.2f}")
                if keep == "script":
                    goals.append((f"chain peak memory / scene bytes, {n}^2 -> {raw}", chain / m["scene_mib"], 2.0))
                else:  # beside the goal, not the goal's measure: at 12 MP its floor (the scene and every result) is 2.66x
                    notes.append(f"  every result kept, {n}^2 -> {raw}: peak {chain / m['scene_mib']:.2f} x the scene,"
                                 f" {chain / m['scene_mib'] - floor:.2f} over its floor of {floor:.2f} (the scene"
                                 f" {m['scene_mib']:.0f} MiB and the results {m['kept_mib']:.0f} MiB)")
    for label, value, target in goals:
        print(f"  {label:58s} {value:7.2f}   target <= {target:g}   {'ok' if value <= target else 'NOT MET'}")
    if notes:
        print("Measured beside the goals (the chain as a script keeps only what it names):")
        print("\n".join(notes))
    if not args.no_explorer:
        print("\nExplorer moves (engine ms, median; explorer default camera DCS-200 at 3.32 m):")
        for k, v in _child(["--child-explorer", str(args.repeats * 3)]).items():
            print(f"  {k:70s} {v:8.1f}")
        print("  targets: < 25 ms on the default scene, < 150 ms at 1024^2")
    return 0


def _parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    p.add_argument("--repeats", type=int, default=5, help="repeats at 1024^2 and above (twice as many below)")
    p.add_argument("--no-memory", action="store_true")
    p.add_argument("--no-explorer", action="store_true")
    p.add_argument("--child-time", type=int, help=argparse.SUPPRESS)
    p.add_argument("--child-memory", type=int, help=argparse.SUPPRESS)
    p.add_argument("--frame", default="scaled", help=argparse.SUPPRESS)
    p.add_argument("--keep", default="script", help=argparse.SUPPRESS)
    p.add_argument("--child-explorer", type=int, help=argparse.SUPPRESS)
    return p.parse_args()


if __name__ == "__main__":
    a = _parse()
    if a.child_time:
        print(json.dumps(child_time(a.child_time, a.repeats)))
    elif a.child_memory:
        print(json.dumps(child_memory(a.child_memory, a.frame, a.keep)))
    elif a.child_explorer:
        print(json.dumps(child_explorer(a.child_explorer)))
    else:
        sys.exit(main(a))
