"""``camsim compare-real``: the real versus simulated Kodak DCS-200 comparison (Figure 1.13).

Simulates ``kodak-dcs200-ir`` from ``cacaphony290`` at the real image's
settings, fits one overall gain, demosaics and renders real and simulated
alike, registers them, prints the median block Delta E*ab and writes the
histogram as a PNG. See :mod:`camsim_core.metrics.real`.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["register", "run"]


def register(subparsers):
    p = subparsers.add_parser(
        "compare-real",
        help="compare the real DCS-200 raw with its simulation (block CIELAB, Figure 1.13)",
        description="Simulate the Kodak DCS-200 (IR filter) from the Cacaphony scene at the real image's settings, "
        "fit one gain, demosaic (bilinear) and render both alike, register, and compare N x N block means in CIELAB.",
    )
    p.add_argument("--raw", default=None, help="real raw Bayer TIFF (default: the shipped DCS200TestIR.tif)")
    p.add_argument("--block", type=int, default=16, help="block side in pixels of the real image (default 16)")
    p.add_argument("--out", default="compare-real-histogram.png", help="histogram PNG to write (default %(default)s)")
    p.add_argument("--monitor", default="simtoolbox-test", help="monitor to render on (default %(default)s)")
    p.add_argument("--distance", type=float, default=3.32, help="m (default %(default)s)")
    p.add_argument("--exposure", type=float, default=0.1, help="s, before the fitted gain (default %(default)s)")
    p.add_argument("--f-stop", type=float, default=11.0, help="(default %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="noise seed of the simulation (default 0)")
    p.set_defaults(func=run)


def run(args):
    from ..errors import ParameterError
    from ..metrics.real import CHAPTER_MEDIAN, compare_real, histogram_png

    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise ParameterError("--out", f"the histogram is written as PNG; give a .png path, got {out}")
    if args.block < 1:
        raise ParameterError("--block", f"must be a positive number of pixels, got {args.block}")
    r = compare_real(
        raw_path=args.raw, monitor=args.monitor, distance=args.distance, exposure=args.exposure,
        f_stop=args.f_stop, block=args.block, seed=args.seed,
    )
    reg, cmp_ = r.registration, r.comparison
    st = r.settings
    print(
        f"simulated {st['camera']} from {st['scene']} at {st['distance']} m, {st['exposure']} s, f/{st['f_stop']:g}: "
        f"{r.sim_shape[0]} x {r.sim_shape[1]} pixels; real raw {Path(st['raw']).name}: {r.real_shape[0]} x {r.real_shape[1]}"
    )
    for name, fit in r.phase_fits.items():
        mark = "*" if name == r.phase else " "
        cg = ", ".join(f"{v:.3f}" for v in fit["channel_gains"])
        print(f" {mark} Bayer phase {name}: gain {fit['gain']:.4f}, relative residual {fit['residual']:.3f}, per-channel gains (R, G, B) {cg}")
    print(f"Bayer phase of the real raw (best fit): {r.phase}")
    print(
        f"registration: real pixel (r, c) -> simulated {reg.scale:.4f} * (r, c) + ({reg.shift[0]:.2f}, {reg.shift[1]:.2f}) "
        f"(NCC {reg.score:.4f}); the simulated image is {reg.scale:.3f} x larger than the real one"
    )
    print(f"fitted gain (real / simulated raw): {r.gain:.4f} -> simulated again at {r.exposure:.4f} s")
    aff = r.phase_fits[r.phase]["affine"]
    print(
        "diagnostic only (not applied): per-channel real = a * sim + b: "
        + ", ".join(f"{c} a={a:.3f} b={b:.1f} DU" for c, (a, b) in zip("RGB", aff))
    )
    r0, r1, c0, c1 = cmp_.overlap
    print(
        f"compared region: real rows {r0}-{r1 - 1}, cols {c0}-{c1 - 1}; {cmp_.n_blocks} blocks of {cmp_.block} x {cmp_.block} pixels "
        f"({cmp_.delta_e.shape[0]} x {cmp_.delta_e.shape[1]})"
    )
    print(f"median block dE*ab = {cmp_.median:.2f} (mean {cmp_.mean:.2f}; chapter: {CHAPTER_MEDIAN})")
    histogram_png(r, out)
    print(f"histogram written to {out}")
    return 0
