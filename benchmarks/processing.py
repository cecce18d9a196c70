"""Benchmark of image processing: every demosaicing method, and rendering, on a 1024 x 1024 Bayer raw.

Prints a table of the best-of-N wall time and the ratio to bilinear
demosaicing measured in the same run. The raw is scikit-image's astronaut
upsampled to 1024 x 1024, scaled to 8-bit digital units and GR/BG-mosaicked,
with the DCS-200's sensitivities so that it can also be rendered.

Run: ``.venv/bin/python benchmarks/processing.py [--repeat N] [--size S]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def best_time(func, repeat):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t0)
    return best


def make_raw(size):
    import colour_demosaicing as cdm
    import skimage.data
    import skimage.transform

    import camsim_core as cs
    from camsim_core.camera import camera_preset

    rgb = skimage.transform.resize(skimage.data.astronaut(), (size, size), order=1) * 255.0
    cfa = np.rint(cdm.mosaicing_CFA_Bayer(rgb, "GRBG")).astype(np.uint8)
    cam = camera_preset("kodak-dcs200")
    from camsim_core.datasets.illuminants import illuminant

    return cs.raw_from_array(cfa, "GRBG", sensitivities=cam.sensors, illuminant=illuminant("D65"), name="astronaut")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--size", type=int, default=1024)
    args = p.parse_args(argv)

    import camsim_core as cs
    from camsim_core.demosaicing import METHODS

    raw = make_raw(args.size)
    monitor = cs.load_monitor("simtoolbox-test")
    demosaiced = cs.demosaic(raw)
    rows = []
    for method in METHODS:
        rows.append((f"demosaic {method}", best_time(lambda: cs.demosaic(raw, method), args.repeat)))
    for method in ("baseline", "illuminant"):
        rows.append((f"render {method}", best_time(lambda: cs.render(demosaiced, monitor, method), args.repeat)))
    rows.append(("render illuminant gray-world",
                 best_time(lambda: cs.render(demosaiced, monitor, "illuminant", illuminant="gray-world"), args.repeat)))
    base = rows[0][1]
    print(f"{args.size} x {args.size} GR/BG Bayer raw, best of {args.repeat}")
    print(f"{'step':32s} {'time (ms)':>10s} {'x bilinear':>11s}")
    for name, t in rows:
        print(f"{name:32s} {t * 1e3:10.1f} {t / base:11.2f}")


if __name__ == "__main__":
    main()
