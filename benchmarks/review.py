"""Benchmark: design review (the Compare designs tab and ``camsim report``).

On the default scene (cacaphony290 through the DCS-200 geometry at 3.32 m,
233 x 372 pixels), measured in one process:

* pinning a design: one :func:`~camsim_core.review.design.evaluate_design`
  (simulation, demosaic, render, ideal image, CIELAB and S-CIELAB);
* a sweep of noise sigma over 5 values for 2 designs (DCS-200, human cones),
  CIELAB dE: the baseline is 10 separate evaluations (what a user did by hand); the
  sweep re-uses each design's sensor responses, resampling and ideal image
  (one cached pipeline per design), on 1 or 2 threads;
* writing the HTML report of 2 designs with that sweep;
* a noise move of the live design, the explorer's state alone and with the
  Compare tab holding 2 pinned designs (what the comparison adds to a move).

Ratios are against the baseline measured in the same run. Usage:
``python benchmarks/review.py [--repeats N] [--threads N]`` (BLAS threads, default 1).
"""

from __future__ import annotations

import argparse
import os


def _parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3, help="runs per measurement (median reported)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (set before numpy loads)")
    return p.parse_args()


ARGS = _parse() if __name__ == "__main__" else None
if ARGS is not None:
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, str(ARGS.threads))

import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import camsim_core as cc  # noqa: E402
from camsim_core.review import evaluate_design, run_sweep  # noqa: E402
from camsim_core.review.report import write_report  # noqa: E402

DESIGNS = [("DCS-200", {"camera": "kodak-dcs200-ir"}), ("cones", {"camera": "human-cones"})]
SIGMAS = [0.0, 2.0, 4.0, 6.0, 8.0]


def _median_seconds(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(repeats=3):
    cc.load_scene("cacaphony290")  # read once, outside the timings
    evaluate_design(DESIGNS[0][1], "warm-up")

    def separate():
        return [evaluate_design({**p, "noise_sigma": s}, n, metrics=("cielab",)) for n, p in DESIGNS for s in SIGMAS]

    baseline = _median_seconds(separate, repeats)
    rows = [("10 separate evaluations, CIELAB (baseline)", baseline)]
    rows.append(("pin one design (CIELAB and S-CIELAB)", _median_seconds(lambda: evaluate_design(DESIGNS[0][1], "pin"), repeats)))
    points = None
    for workers in (1, 2):
        def sweep(workers=workers):
            nonlocal points
            points = run_sweep(DESIGNS, "noise_sigma", SIGMAS, max_workers=workers, metrics=("cielab",))

        rows.append((f"sweep 2 designs x 5 sigmas, CIELAB, {workers} thread(s)", _median_seconds(sweep, repeats)))
    results = [evaluate_design(p, n) for n, p in DESIGNS]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "report.html"
        rows.append(("write the report (2 designs + sweep)", _median_seconds(
            lambda: write_report(out, results, sweep={"parameter": "noise_sigma", "values": SIGMAS}, points=points),
            repeats)))
        size = out.stat().st_size
    print(f"design review on cacaphony290 (233 x 372), median of {repeats}, load {os.getloadavg()[0]:.1f}")
    print(f"| {'what':<50} | {'seconds':>8} | {'ratio to baseline':>17} |")
    print(f"|{'-' * 52}|{'-' * 10}|{'-' * 19}|")
    for label, t in rows:
        print(f"| {label:<50} | {t:8.2f} | {t / baseline:17.2f} |")
    print(f"report size: {size / 1e6:.2f} MB (every image embedded)")
    live_move(repeats)


def live_move(repeats):
    """A noise move of the live design: the explorer alone, and with the Compare tab holding 2 pinned designs."""
    from camsim_explorer.compare import CompareView
    from camsim_explorer.state import ExplorerState

    def moves(state, n=4 * repeats + 1):
        times = []
        for k in range(n):
            t0 = time.perf_counter()
            state.noise_sigma = float(1 + k % 2)
            times.append(time.perf_counter() - t0)
        return statistics.median(times[1:])

    alone = moves(ExplorerState())
    state = ExplorerState()
    view = CompareView(state)
    view.pin("DCS-200")
    state.camera = "human-cones"
    view.pin("cones")
    state.camera = "kodak-dcs200-ir"
    compared = moves(state)
    print("live noise move (engine + views), median")
    print(f"| {'what':<50} | {'ms':>8} | {'ratio':>17} |")
    print(f"|{'-' * 52}|{'-' * 10}|{'-' * 19}|")
    print(f"| {'explorer state alone (baseline)':<50} | {1000 * alone:8.0f} | {1.0:17.2f} |")
    print(f"| {'with the Compare tab, 2 pinned designs':<50} | {1000 * compared:8.0f} | {compared / alone:17.2f} |")


if __name__ == "__main__":
    main(ARGS.repeats)
