"""``camsim experiment sensors|mosaic|pixel-size|table-1-16-study``: the chapter's section 5 experiments (Figure 1.14,
Table 1.16) and its section 6 question (pixel size for a fixed sensor).

Each configuration (scene x design x noise sigma x seed) is one task:
in this process for a small sweep (under 50 tasks) or with ``--workers 0``,
else on a local Dask cluster of ``--workers`` single-thread workers (the
CPU count by default), or on an existing cluster with ``--scheduler
ADDRESS``. Outputs go to ``--out`` (CSV files, the figure as PNG) and the
table is printed.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from ..errors import ParameterError

__all__ = ["register", "run", "MAX_VALUES"]

PITCHES_DEFAULT = (1.0, 1.2, 1.4, 1.75, 2.0, 2.4, 2.8, 3.45, 4.0, 4.8, 5.6)  # camsim_core.experiments.pixel_size.PITCHES_UM
LUX_DEFAULT = (5.0, 20.0, 100.0, 1000.0, 10000.0)  # ... .LUX (not imported here: the CLI starts fast)


#: Most values in one list of a sweep (``--alphas``, ``--sigmas``, ``--centers``, ``--pitches``, ``--lux``) and
#: most ``--seeds``: a guard against a typo's hours of work or a billion-value ``START:STOP:COUNT``.
MAX_VALUES = 1000


def _values(text, name):
    """The numbers of a list option (see :func:`~camsim_core.experiments.grid.parse_values`), at most :data:`MAX_VALUES`.

    A ``START:STOP:COUNT`` whose count is beyond the limit (or infinite) is refused before any array is made.
    """
    from ..experiments import grid

    parts = str(text).strip().split(":")
    if len(parts) == 3:
        try:
            count = float(parts[2])
        except ValueError:
            count = 0.0  # not a number: parse_values says what is expected
        if not count <= MAX_VALUES:  # NaN and infinity too
            raise ParameterError(name, f"{text!r} asks for {parts[2]} values; at most {MAX_VALUES}")
    values = grid.parse_values(text, name)
    if len(values) > MAX_VALUES:
        raise ParameterError(name, f"{len(values)} values given; at most {MAX_VALUES}")
    return values


def _seeds(args):
    if not 1 <= args.seeds <= MAX_VALUES:
        raise ParameterError("--seeds", f"must be a whole number from 1 to {MAX_VALUES}, got {args.seeds}")
    return args.seeds


def _distance(text):
    if str(text).lower() == "scene":
        return None
    try:
        return float(text)
    except ValueError:
        raise ParameterError("--distance", f"expected metres or 'scene', got {text!r}") from None


def _common(p, default_out):
    p.add_argument("--scenes", nargs="+", default=["cacaphony290"], metavar="SCENE",
                   help="shipped scene names or .Simg/.npz paths (default: cacaphony290)")
    p.add_argument("--sigmas", default="0,2,5", help="noise standard deviations, digital units of 0-255 (default: 0,2,5)")
    p.add_argument("--seeds", type=int, default=1, help="noise seeds per configuration; results are mean and std over them (default: 1)")
    p.add_argument("--distance", default="3.32", help="metres from the scene, or 'scene' for each scene's own (default: 3.32, Figure 1.8)")
    p.add_argument("--monitor", default="simtoolbox-test", help="monitor calibration (default: simtoolbox-test)")
    p.add_argument("--out", default=default_out, help=f"output folder, created if missing (default: {default_out})")
    p.add_argument("--workers", type=int, default=None,
                   help=f"local Dask cluster of N single-thread workers; 0 = no Dask, run in this process (default: this process "
                        f"below 50 tasks, else the CPU count, {os.cpu_count()})")
    p.add_argument("--scheduler", metavar="ADDRESS", help="use an existing Dask scheduler, e.g. tcp://host:8786 (its workers must have camsim)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    view = p.add_mutually_exclusive_group()
    view.add_argument("--samples-per-degree", type=float, metavar="S",
                      help="S-CIELAB samples per degree of visual angle, given directly (e.g. 10.26)")
    view.add_argument("--viewing", default=None,
                      help="how the rendered image is viewed, which fixes S-CIELAB's samples per degree: 'camera' (the "
                      "default, the chapter's: the camera's angular resolution, 102.6 for the DCS-200), 'camera/10' (the "
                      "original simulator's S-CIELAB example), or 'display:PITCHmm@DISTANCEm' (e.g. display:0.25mm@0.6m)")


def register(subparsers):
    p = subparsers.add_parser("experiment", help="run the chapter's section 5 experiments and its section 6 pixel-size question",
                              description="Run the chapter's experiments on Dask: 'sensors' (Figure 1.14), 'mosaic' (Table 1.16) and 'pixel-size' (section 6).")
    sub = p.add_subparsers(dest="experiment", metavar="EXPERIMENT", required=True)

    s = sub.add_parser("sensors", help="Figure 1.14: S-CIELAB error against the cone/DCS-200 mixture alpha",
                       description="Cameras with (1-alpha) human cones + alpha Kodak DCS-200 sensitivities, DCS-200 geometry, 8 bits; "
                       "baseline and illuminant-based (3-D Munsell model, known illuminant) rendering; mean S-CIELAB error against "
                       "the noiseless ideal image. Writes sensors-records.csv, sensors-summary.csv and figure-1-14.png.")
    _common(s, "experiments/sensors")
    s.add_argument("--alphas", default="0:1:11", help="mixture weights in [0, 1]: list 0,0.5,1 or START:STOP:COUNT (default: 0:1:11)")
    s.add_argument("--mosaic", action="store_true", help="add the DCS-200 Bayer mosaic and bilinear demosaicing (default: every sensor at every pixel, see the docs)")
    s.set_defaults(func=run)

    m = sub.add_parser("mosaic", help="Table 1.16: 3 sensors on a Bayer tile versus 4 on a 2 x 2 grid",
                       description="Gaussian sensors (27 nm std) at --centers: four on a 2 x 2 grid, three (without the second) on a Bayer "
                       "tile; Bayesian demosaicing, illuminant-based rendering (3-D / 4-D surface model); mean S-CIELAB error "
                       "against the ideal image. Writes mosaic-records.csv and table-1-16.csv.")
    _common(m, "experiments/mosaic")
    m.add_argument("--centers", default="460,520,580,640",
                   help="the four sensor centres, nm; the 3-sensor design leaves out the second (default: 460,520,580,640; the chapter names only 520)")
    m.add_argument("--std", type=float, default=27.0, help="standard deviation of the Gaussian sensors, nm (default: 27)")
    m.add_argument("--demosaic", default="bayesian", help="demosaicing method (default: bayesian)")
    # the choices the chapter leaves unstated (issue 41); defaults = camsim's readings
    m.add_argument("--exposure-fill", type=float, default=0.9,
                   help="share of the 0-255 range the brightest scene points reach (99.5th percentile of the brightest "
                        "sensor), which sets how large a noise sigma is against the signal (default: 0.9)")
    m.add_argument("--normalization", default="area", choices=("area", "white"),
                   help="Gaussian curves with equal areas, or white-balanced gains (equal response to the illuminant) (default: area)")
    m.add_argument("--prior-detail", type=float, default=None,
                   help="Bayesian demosaic: variance of the achromatic detail prior relative to the largest principal "
                        "variance (default: the method's, 0.1 for bayesian, 0 for bayesian-original)")
    m.add_argument("--noise-model", default=None, choices=("known", "ignored", "fraction"),
                   help="Bayesian demosaic's likelihood noise: the camera's sigma (known, bayesian's default), none "
                        "(ignored), or a fixed fraction of the prior variance (fraction, bayesian-original's)")
    m.add_argument("--rendering", default="illuminant", choices=("illuminant", "baseline"),
                   help="rendering method (default: illuminant, the chapter's)")
    m.add_argument("--surface-dimensions", type=int, default=None,
                   help="illuminant rendering: surface linear model of 3 dimensions for both designs (default: as many as sensors)")
    m.set_defaults(func=run)

    t = sub.add_parser("table-1-16-study", help="Table 1.16's unstated choices swept on Dask (resumable)",
                       description="Sweep exposure, sensor centres and normalization, the demosaic's prior and noise model, the "
                       "rendering's surface model and the S-CIELAB viewing; for each combination the six cells of Table 1.16, "
                       "their error against the chapter's and whether the crossover appears. Results are appended to "
                       "OUT/study.jsonl task by task and finished tasks are skipped on a rerun; the report (CSV, figure) is "
                       "written from all results so far.")
    t.add_argument("--scene", default="cacaphony290", help="scene (default: cacaphony290, the chapter's)")
    t.add_argument("--fills", default=None, help="exposure fills, list or START:STOP:COUNT (default: 0.9,0.6,0.4,0.3,0.2,0.15,0.1,0.05)")
    t.add_argument("--out", default="experiments/table-1-16-study", help="output folder (default: experiments/table-1-16-study)")
    t.add_argument("--workers", type=int, default=2, help="local Dask cluster of N single-thread workers; 0 = this process (default: 2)")
    t.add_argument("--scheduler", metavar="ADDRESS", help="use an existing Dask scheduler, e.g. tcp://127.0.0.1:8786")
    t.add_argument("--limit", type=int, default=None, help="run at most N of the pending tasks")
    t.add_argument("--no-progress", action="store_true", help="no progress bar")
    t.add_argument("--no-report", action="store_true", help="only run the tasks")
    t.set_defaults(func=run)

    x = sub.add_parser("pixel-size", help="section 6: S-CIELAB error against pixel pitch for a fixed 4.8 x 3.6 mm sensor, at several light levels",
                       description="A 4.8 x 3.6 mm sensor behind a 4 mm f/2.8 diffraction-limited lens, pixel pitch from 1 to 5.6 um "
                       "(full well, fill factor and dark current scaling with the pixel), a scene of fine coloured gratings at several "
                       "illuminances; bilinear demosaicing, a least-squares colour matrix, mean S-CIELAB error against the ideal image. "
                       "Writes pixel-size-records.csv, pixel-size-summary.csv and pixel-size.png.")
    x.add_argument("--pitches", default=",".join(f"{v:g}" for v in PITCHES_DEFAULT),
                   help="pixel pitches, um: list or START:STOP:COUNT (default: %(default)s)")
    x.add_argument("--lux", default=",".join(f"{v:g}" for v in LUX_DEFAULT), help="scene illuminances, lux (default: %(default)s)")
    x.add_argument("--seeds", type=int, default=1, help="noise seeds per configuration (default: 1)")
    x.add_argument("--demosaic", default="bilinear", help="demosaicing method for the Bayer tile (default: bilinear)")
    x.add_argument("--out", default="experiments/pixel-size", help="output folder, created if missing (default: experiments/pixel-size)")
    x.add_argument("--workers", type=int, default=None,
                   help=f"local Dask cluster of N single-thread workers; 0 = no Dask, run in this process (default: this process "
                        f"below 50 tasks, else the CPU count, {os.cpu_count()})")
    x.add_argument("--scheduler", metavar="ADDRESS", help="use an existing Dask scheduler, e.g. tcp://host:8786")
    x.add_argument("--no-progress", action="store_true", help="no progress bar")
    x.set_defaults(func=run)


def _workers(args, n_tasks):
    """Local cluster size for ``n_tasks`` tasks, or None (this process, or the ``--scheduler``)."""
    from ..experiments.runner import choose_workers

    if args.workers is not None and args.workers < 0:
        raise ParameterError("--workers", f"must be >= 0, got {args.workers}")
    return None if args.scheduler else choose_workers(n_tasks, args.workers)


def _out(args):
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ParameterError("--out", f"{out} exists and is not a folder")
    return out


def run_pixel_size(args):
    from ..experiments import pixel_size
    from ..experiments.runner import run_tasks

    out = _out(args)
    t0 = time.perf_counter()
    configs = pixel_size.configurations(_values(args.pitches, "--pitches"), _values(args.lux, "--lux"),
                                        _seeds(args), demosaic=args.demosaic)
    workers = _workers(args, len(configs))
    where = f"scheduler {args.scheduler}" if args.scheduler else (f"local Dask cluster of {workers} worker(s)" if workers else "this process")
    print(f"camsim experiment pixel-size: {len(configs)} tasks on {where}")
    records = run_tasks(pixel_size.evaluate, configs, workers=workers, scheduler=args.scheduler,
                        progress=False if args.no_progress else None, desc="pixel-size")
    out.mkdir(parents=True, exist_ok=True)
    paths = pixel_size.write_outputs(records, out)
    summary = pixel_size.summarize(records)
    print(pixel_size.table(summary))
    print("best pitch: " + ", ".join(f"{lux:g} lux -> {p:g} um" for lux, p in pixel_size.optimum(summary).items())
          + f"; wall time {time.perf_counter() - t0:.1f} s")
    for p in paths:
        print(f"wrote {p}")
    return 0


def run_study(args):
    from ..experiments import table_1_16_study as study

    out = _out(args)
    if args.workers < 0:
        raise ParameterError("--workers", f"must be >= 0, got {args.workers}")
    if args.limit is not None and args.limit < 1:
        raise ParameterError("--limit", f"must be >= 1, got {args.limit}")
    kw = {} if args.fills is None else {"fills": _values(args.fills, "--fills")}
    task_list = study.tasks(scene=args.scene, **kw)
    where = f"scheduler {args.scheduler}" if args.scheduler else (
        f"local Dask cluster of {args.workers} worker(s)" if args.workers else "this process")
    print(f"camsim experiment table-1-16-study: {len(task_list)} tasks ({len(task_list) * len(study.VIEWINGS)} combinations) on {where}")
    info = study.run(task_list, out, workers=args.workers, scheduler=args.scheduler, limit=args.limit,
                     progress=False if args.no_progress else None)
    rows = study.load(out)
    print(f"ran {info['ran']} task(s), skipped {info['skipped']} already done; wall time {info['seconds']:.1f} s; "
          f"{len(rows)} combinations in {out / study.RESULTS_NAME}")
    if rows and not args.no_report:
        for p in study.write_report(rows, out):
            print(f"wrote {p}")
        print(study.summary_text(rows))
    return 0


def run(args):
    from ..experiments import mosaic, sensors

    if args.experiment == "pixel-size":
        return run_pixel_size(args)
    if args.experiment == "table-1-16-study":
        return run_study(args)
    sigmas = _values(args.sigmas, "--sigmas")
    _seeds(args)
    distance = _distance(args.distance)
    if args.workers is not None and args.workers < 0:
        raise ParameterError("--workers", f"must be >= 0, got {args.workers}")
    progress = False if args.no_progress else None
    from ..metrics.viewing import DEFAULT_VIEWING, parse_viewing

    if args.samples_per_degree is not None:
        viewing = parse_viewing(args.samples_per_degree)
    else:
        viewing = parse_viewing(args.viewing if args.viewing is not None else DEFAULT_VIEWING)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ParameterError("--out", f"{out} exists and is not a folder")
    t0 = time.perf_counter()
    if args.experiment == "sensors":
        alphas = _values(args.alphas, "--alphas")
        # validation (and scene loading) happens here, before any worker starts
        configs = sensors.configurations(args.scenes, alphas, sigmas, args.seeds, distance=distance,
                                         monitor=args.monitor, mosaic=args.mosaic, viewing=viewing)
        module = sensors
    else:
        centers = _values(args.centers, "--centers")
        configs = mosaic.configurations(args.scenes, sigmas, args.seeds, centers=centers, std_nm=args.std,
                                        distance=distance, monitor=args.monitor, demosaic=args.demosaic, viewing=viewing,
                                        exposure_fill=args.exposure_fill, normalization=args.normalization,
                                        prior_detail=args.prior_detail, noise_model=args.noise_model,
                                        rendering=args.rendering, surface_dimensions=args.surface_dimensions)
        module = mosaic
    from ..experiments.runner import choose_workers, run_tasks

    workers = None if args.scheduler else choose_workers(len(configs), args.workers)
    where = f"scheduler {args.scheduler}" if args.scheduler else (f"local Dask cluster of {workers} worker(s)" if workers else "this process")
    print(f"camsim experiment {args.experiment}: {len(configs)} tasks on {where}")
    print(viewing.describe(module.camera_rate()) if viewing.kind == "camera" else viewing.describe())

    records = run_tasks(module.evaluate, configs, workers=workers, scheduler=args.scheduler, progress=progress,
                        desc=args.experiment)
    out.mkdir(parents=True, exist_ok=True)
    paths = module.write_outputs(records, out)
    summary = module.summarize(records)
    print(module.table(summary) if module is sensors else module.table(summary, centers=configs[0].centers))
    print(f"exposure: " + ", ".join(f"{c.scene} {c.exposure:.4g} s" for c in {c.scene: c for c in configs}.values())
          + f"; wall time {time.perf_counter() - t0:.1f} s")
    for p in paths:
        print(f"wrote {p}")
    return 0
