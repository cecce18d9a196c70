"""Benchmark: the full default sensors sweep (Figure 1.14) on local Dask clusters of 1 and 2 workers.

Usage::

    .venv/bin/python benchmarks/experiments.py            # default sweep: 11 alphas x 3 sigmas x 1 seed, cacaphony290
    .venv/bin/python benchmarks/experiments.py --quick    # 3 alphas x 2 sigmas on macbeth (a smoke run)

Prints the wall time of the sweep in this process (no Dask, the reference)
and on local clusters of 1 and 2 single-thread worker processes, with the
cluster's start-up and a warm-up (one task's work on every worker: imports,
scene loading, the cached ideal image) shown apart from the sweep itself;
the speed-up of 2 workers over 1; and whether every run gave identical
numbers. ``--seeds 5`` gives a longer sweep (165 tasks).
It takes minutes; it is not part of the tests.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from camsim_core.experiments import sensors  # noqa: E402
from camsim_core.experiments.runner import local_cluster  # noqa: E402


def _timed_cluster_run(configs, workers):
    from distributed import Client

    t0 = time.perf_counter()
    cluster = local_cluster(workers, processes=True)
    client = Client(cluster)
    client.wait_for_workers(workers)
    t_start = time.perf_counter() - t0
    try:
        # warm-up: imports, scene loading and the cached ideal image on every worker (one task's work each)
        t1 = time.perf_counter()
        client.run(sensors.evaluate, configs[0])
        t_warm = time.perf_counter() - t1
        t1 = time.perf_counter()
        futures = client.map(sensors.evaluate, configs, pure=False)
        records = client.gather(futures)
        t_run = time.perf_counter() - t1
    finally:
        client.close()
        cluster.close()
    return records, t_start, t_warm, t_run


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a small sweep (3 alphas x 2 sigmas on macbeth)")
    ap.add_argument("--seeds", type=int, default=1, help="seeds per configuration (default 1, as the command)")
    ap.add_argument("--repeat", type=int, default=1, help="repeat every measurement, keep the fastest (a shared machine)")
    args = ap.parse_args(argv)
    if args.quick:
        configs = sensors.configurations(["macbeth"], [0, 0.5, 1], [0, 5], args.seeds)
    else:
        configs = sensors.configurations(seeds=args.seeds)  # otherwise the defaults of `camsim experiment sensors`
    c = configs[0]
    print(f"sensors sweep: {len(configs)} tasks (scene {c.scene}, {len({x.alpha for x in configs})} alphas x "
          f"{len({x.sigma for x in configs})} sigmas x {len({x.seed for x in configs})} seed), {os.cpu_count()} CPUs")

    keys = ("alpha", "sigma", "seed", "baseline", "illuminant")
    t0 = time.perf_counter()
    sensors.evaluate(configs[0])  # the same warm-up in this process
    t_warm = time.perf_counter() - t0
    t_serial = float("inf")
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        serial = [sensors.evaluate(x) for x in configs]
        t_serial = min(t_serial, time.perf_counter() - t0)
    ref = [tuple(r[k] for k in keys) for r in serial]

    rows = [("in this process (no Dask)", 0.0, t_warm, t_serial, True)]
    for n in (1, 2):
        runs = [_timed_cluster_run(configs, n) for _ in range(args.repeat)]
        records, t_start, t_w, t_run = min(runs, key=lambda r: r[3])
        rows.append((f"local cluster, {n} worker{'s' if n > 1 else ''}", t_start, t_w, t_run,
                     [tuple(r[k] for k in keys) for r in records] == ref))

    print()
    print(f"{'run':<28}{'start-up s':>11}{'warm-up s':>10}{'sweep s':>9}{'total s':>9}{'sweep vs serial':>17}  identical")
    for name, ts, tw, tr, same in rows:
        print(f"{name:<28}{ts:>11.2f}{tw:>10.2f}{tr:>9.2f}{ts + tw + tr:>9.2f}{t_serial / tr:>16.2f}x  {'yes' if same else 'NO'}")
    print()
    one, two = rows[1], rows[2]
    print(f"speed-up of 2 workers over 1: {one[3] / two[3]:.2f}x on the sweep, "
          f"{sum(one[1:4]) / sum(two[1:4]):.2f}x including cluster start-up and warm-up")
    print(f"mean task time in this process: {t_serial / len(configs):.3f} s"
          + (f"; fastest of {args.repeat} runs each" if args.repeat > 1 else ""))
    try:
        print(f"load average when done: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (other processes share these CPUs)")
    except OSError:
        pass


if __name__ == "__main__":
    main()
