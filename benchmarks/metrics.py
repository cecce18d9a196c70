"""Benchmark S-CIELAB: a 512 x 512 pair at 102.6 samples per degree.

The explorer recomputes S-CIELAB on every slider move, so the aim is under
0.1 s. camsim filters each opponent channel by one FFT product with its summed
2-D kernel (cached spectrum); the baseline measured in the same run is the plain
separable filtering of the same 1-D kernels with ``scipy.ndimage.correlate1d``
(horizontal with the signed kernel, then vertical, summed over the Gaussians;
``mode="reflect"`` is the same mirrored edge as S-CIELAB's while the kernel is
less than half the image). Both are timed alone (filtering) and within the
whole metric (opponent transform, filtering, back to XYZ, L*a*b*, Delta E).

Run: ``.venv/bin/python benchmarks/metrics.py [--repeat N]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import scipy.ndimage as ndi

from camsim_core.metrics import cielab, s_cielab
from camsim_core.metrics import scielab as scielab_fn

SPD = 102.6
WHITE = np.array([95.047, 100.0, 108.883])


def ndimage_filter_channels(planes, spd):
    """Baseline: separable passes with scipy.ndimage, planes (..., 3, H, W)."""
    out = np.empty_like(planes)
    for c, (kx, ky) in enumerate(s_cielab._kernels(spd)):
        for idx in np.ndindex(planes.shape[:-3]):
            plane = planes[idx + (c,)]
            acc = 0.0
            for k in range(kx.shape[0]):
                h = ndi.correlate1d(plane, kx[k][::-1], axis=1, mode="reflect")
                acc = acc + ndi.correlate1d(h, ky[k][::-1], axis=0, mode="reflect")
            out[idx + (c,)] = acc
    return out


def camsim_filter_channels(planes, spd):
    """camsim's filtering (:func:`s_cielab.filter_opponent`) of planes (N, 3, H, W), image by image."""
    return np.stack([np.moveaxis(s_cielab.filter_opponent(np.moveaxis(p, 0, -1), spd), -1, 0) for p in planes])


def ndimage_scielab(xyz1, xyz2, spd, white):
    """The whole metric with the baseline filtering (same colorimetry as camsim's)."""
    x = np.stack([xyz1, xyz2])
    opp = np.einsum("ij,...hwj->...ihw", s_cielab.XYZ_TO_OPPONENT, x)
    f = ndimage_filter_channels(opp, spd)
    back = np.einsum("ij,...jhw->...hwi", s_cielab.OPPONENT_TO_XYZ, f)
    lab = cielab.xyz_to_lab(back, white, checked=True)
    return cielab.delta_e_lab(lab[0], lab[1])


def timeit(fn, repeat):
    fn()  # warm-up (kernel spectra cached, FFT plans)
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)

    rng = np.random.default_rng(0)
    rows = []
    for shape in [(512, 512), (233, 372)]:
        xyz1 = rng.uniform(5, 90, size=shape + (3,))
        xyz2 = xyz1 + rng.normal(0, 2, size=xyz1.shape)
        opp = np.einsum("ij,...hwj->...ihw", s_cielab.XYZ_TO_OPPONENT, np.stack([xyz1, xyz2]))

        fast = camsim_filter_channels(opp, SPD)
        slow = ndimage_filter_channels(opp, SPD)
        agree = float(np.max(np.abs(fast - slow)))
        d_fast = scielab_fn(xyz1, xyz2, SPD, WHITE)
        d_slow = ndimage_scielab(xyz1, xyz2, SPD, WHITE)
        agree_de = float(np.max(np.abs(d_fast - d_slow)))

        t_nd_f = timeit(lambda: ndimage_filter_channels(opp, SPD), max(2, args.repeat // 2))
        t_ff_f = timeit(lambda: camsim_filter_channels(opp, SPD), args.repeat)
        t_nd = timeit(lambda: ndimage_scielab(xyz1, xyz2, SPD, WHITE), max(2, args.repeat // 2))
        t_ff = timeit(lambda: scielab_fn(xyz1, xyz2, SPD, WHITE), args.repeat)
        name = f"{shape[0]}x{shape[1]}"
        rows.append((name, "filtering (2 images x 3 channels)", "scipy.ndimage separable", t_nd_f, t_nd_f, agree))
        rows.append((name, "filtering (2 images x 3 channels)", "camsim FFT, cached kernel", t_ff_f, t_nd_f, agree))
        rows.append((name, "whole S-CIELAB map", "with scipy.ndimage filtering", t_nd, t_nd, agree_de))
        rows.append((name, "whole S-CIELAB map", "camsim scielab()", t_ff, t_nd, agree_de))

    n_taps = s_cielab._kernels(SPD)[0][0].shape[1]
    print(f"S-CIELAB at {SPD} samples/deg: kernels of {n_taps} taps (built at {SPD * 3:.1f}/deg, u = 3); "
          f"median of {args.repeat} runs; ratio = baseline time / this time")
    print(f"{'image':<9} {'what':<35} {'method':<30} {'time (ms)':>10} {'speed-up':>9} {'max |diff|':>11}")
    for name, what, method, t, base, agree in rows:
        print(f"{name:<9} {what:<35} {method:<30} {1e3 * t:>10.1f} {base / t:>8.1f}x {agree:>11.2e}")
    t512 = rows[3][3]
    print(f"target < 100 ms for the 512x512 pair: {'met' if t512 < 0.1 else 'NOT met'} ({1e3 * t512:.1f} ms)")


if __name__ == "__main__":
    main()
