"""``camsim compare-real``: the real versus simulated Kodak DCS-200 comparison (Figure 1.13), three ways.

Simulates ``kodak-dcs200-ir`` from ``cacaphony290`` at the real image's
settings, registers real and simulated, and compares N x N block means in
CIELAB three ways: (1) the chapter's protocol, one overall gain; (2) the real
raw's black level estimated from its darkest pixels plus the one gain; (3)
black level plus per-channel gains, cross-validated. Prints the medians (or,
with ``--json``, one JSON object on standard output and the report on
standard error) and writes the three histograms as one PNG. See
:mod:`camsim_core.metrics.real`.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

__all__ = ["register", "run", "MAX_F_STOP"]

#: Highest f-number compared: the real image was taken at f/11; far beyond, the simulation is black and
#: there is nothing to register.
MAX_F_STOP = 1000.0


def register(subparsers):
    p = subparsers.add_parser(
        "compare-real",
        help="compare the real DCS-200 raw with its simulation, three ways (block CIELAB, Figure 1.13)",
        description="Simulate the Kodak DCS-200 (IR filter) from the Cacaphony scene at the real image's settings, "
        "register, demosaic (bilinear) and render both alike, and compare N x N block means in CIELAB: (1) the "
        "chapter's protocol (one gain), (2) the raw's black level from its darkest pixels plus one gain, "
        "(3) black level plus per-channel gains fitted on half the blocks and scored on the other half.",
    )
    p.add_argument("--raw", default=None, help="real raw Bayer TIFF (default: the shipped DCS200TestIR.tif)")
    p.add_argument("--block", type=int, action="append", default=None, metavar="N",
                   help="block side in pixels of the real image; repeat for several, the first is the default "
                   "reported as the median (default: 16 and 50)")
    p.add_argument("--render", default="baseline", choices=("baseline", "illuminant"),
                   help="rendering of both images: baseline (Eq. 1.4) or illuminant-based with the known "
                   "illuminant, as the original's DCS-200 example (default %(default)s)")
    p.add_argument("--black-percentile", type=float, default=0.1,
                   help="percentile of each sensor class's raw values that estimates the black level (default %(default)s)")
    p.add_argument("--black-per-class", action="store_true",
                   help="subtract each class's own estimate instead of the smallest (one common pedestal)")
    p.add_argument("--out", default="compare-real-histogram.png", help="histogram PNG to write (default %(default)s)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object on standard output (the report goes to standard error)")
    p.add_argument("--monitor", default="simtoolbox-test", help="monitor to render on (default %(default)s)")
    p.add_argument("--distance", type=float, default=3.32, help="m (default %(default)s)")
    p.add_argument("--exposure", type=float, default=0.1, help="s, before the fitted gain (default %(default)s)")
    p.add_argument("--f-stop", type=float, default=11.0, help="(default %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="noise seed of the simulation (default 0)")
    p.set_defaults(func=run)


def run(args):
    from ..errors import ParameterError
    from ..metrics.real import CHAPTER_MEDIAN, compare_real, histogram_png, scale_explanation

    from . import check_output

    out = Path(args.out)
    if out.suffix.lower() != ".png":
        raise ParameterError("--out", f"the histogram is written as PNG; give a .png path, got {out}")
    check_output(out, "--out")  # a folder, or a missing one: refused now, not after the report is printed
    blocks = args.block or [16, 50]
    for b in blocks:
        if b < 1:
            raise ParameterError("--block", f"must be a positive number of pixels, got {b}")
    # checked before the simulation runs (a second of work before a NaN or an f/1e308 would be refused)
    from ..optics.diffraction import MIN_F_NUMBER

    for flag, v in (("--distance", args.distance), ("--exposure", args.exposure)):
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(flag, f"must be a positive finite number, got {v}")
    if not (math.isfinite(args.f_stop) and MIN_F_NUMBER <= args.f_stop <= MAX_F_STOP):
        raise ParameterError("--f-stop", f"must be an f-number from {MIN_F_NUMBER:g} to {MAX_F_STOP:g}, got {args.f_stop}")
    if not 0 <= args.black_percentile <= 100:  # NaN fails too
        raise ParameterError("--black-percentile", f"must be a percentile from 0 to 100, got {args.black_percentile}")
    if args.seed < 0:
        raise ParameterError("--seed", f"must be a whole number >= 0, got {args.seed}")
    r = compare_real(
        raw_path=args.raw, monitor=args.monitor, distance=args.distance, exposure=args.exposure,
        f_stop=args.f_stop, blocks=blocks, render=args.render, black_percentile=args.black_percentile,
        black_per_class=args.black_per_class, seed=args.seed,
    )
    report = sys.stderr if args.json else sys.stdout

    def say(text):
        print(text, file=report)

    reg = r.registration
    st = r.settings
    say(
        f"simulated {st['camera']} from {st['scene']} at {st['distance']} m, {st['exposure']} s, f/{st['f_stop']:g}: "
        f"{r.sim_shape[0]} x {r.sim_shape[1]} pixels (Eq. 1.2: {r.eq_1_2_size[0]:.1f} x {r.eq_1_2_size[1]:.1f}); "
        f"real raw {Path(st['raw']).name}: {r.real_shape[0]} x {r.real_shape[1]}; rendering: {st['render']}"
    )
    for name, fit in r.phase_fits.items():
        mark = "*" if name == r.phase else " "
        cg = ", ".join(f"{v:.3f}" for v in fit["channel_gains"])
        say(f" {mark} Bayer phase {name}: gain {fit['gain']:.4f}, relative residual {fit['residual']:.3f}, per-channel gains (R, G, B) {cg}")
    say(f"Bayer phase of the real raw (best fit): {r.phase}")
    say(
        f"registration: real pixel (r, c) -> simulated {reg.scale:.4f} * (r, c) + ({reg.shift[0]:.2f}, {reg.shift[1]:.2f}) "
        f"(NCC {reg.score:.4f}); the simulated image is {reg.scale:.3f} x larger than the real one"
    )
    say("  why: " + scale_explanation(reg.scale, st))
    say(f"fitted gain (real / simulated raw): {r.gain:.4f} -> simulated again at {r.exposure:.4f} s (chapter protocol)")
    aff = r.phase_fits[r.phase]["affine"]
    say(
        "diagnostic only (not applied): per-channel real = a * sim + b: "
        + ", ".join(f"{c} a={a:.3f} b={b:.1f} DU" for c, (a, b) in zip("RGB", aff))
    )
    say(
        f"black level from the raw's darkest pixels: {r.black_statistic}: "
        f"per class (R, G, B) {', '.join(f'{v:g}' for v in r.black_per_class)} DU -> subtracted "
        f"{', '.join(f'{v:g}' for v in r.black_estimate)} DU"
    )
    cmp_ = r.comparison
    r0, r1, c0, c1 = cmp_.overlap
    say(
        f"compared region: real rows {r0}-{r1 - 1}, cols {c0}-{c1 - 1}; {cmp_.n_blocks} blocks of {cmp_.block} x {cmp_.block} pixels "
        f"({cmp_.delta_e.shape[0]} x {cmp_.delta_e.shape[1]})"
    )
    for name, v in r.variants.items():
        by_block = "; ".join(f"{b} px: {c.median:.2f}" for b, c in v.comparisons.items())
        extra = f"gain {v.gain:.4f}"
        if name == "cross_validated":
            folds = v.channel_gains[r.block]
            extra += ", per-channel gains / overall, per fold: " + " | ".join(
                "(" + ", ".join(f"{x:.3f}" for x in f) + ")" for f in folds
            )
        say(f"{v.label}: median block dE*ab {by_block} ({extra})")
    say(f"median block dE*ab = {cmp_.median:.2f} (mean {cmp_.mean:.2f}; chapter protocol, {cmp_.block} px; chapter: {CHAPTER_MEDIAN})")
    histogram_png(r, out)
    say(f"histograms written to {out}")
    if args.json:
        print(json.dumps(r.to_json(), indent=1))
    return 0
