"""The effect of sensor choice: chapter section 5, Figure 1.14.

Cameras whose sensitivities are ``(1 - alpha) x human cones + alpha x
Kodak DCS-200`` (:func:`camsim_core.datasets.sensors.mixture`: Smith-Pokorny
cones and the IR-filtered DCS-200, both brought to a common scale) with the
DCS-200's spatial parameters, 8 bits, and Gaussian noise of standard
deviation sigma (digital units, camera range 0-255). Each camera image is
rendered on an 8-bit monitor by both methods of section 4.2 (baseline,
Eq. 1.4; illuminant-based, Eqs. 1.5-1.7 with a 3-D linear model of the
Munsell reflectances and the scene's known illuminant) and compared with
the noiseless ideal image (section 4.3: the chapter's reference, the 8-bit
cone camera at the experiment's exposure, ``reference="chapter"`` of
:func:`camsim_core.ideal_image`) by the mean S-CIELAB dE*ab.

Choices the chapter leaves open, and why
----------------------------------------
* **No mosaic by default.** The chapter gives the cameras "the spatial
  parameters of a Kodak DCS-200, so that the simulated image had the spatial
  structure shown in Figure 1.8", and says that for alpha = 0 without noise
  "both methods provide perfect performance ... both methods are guaranteed
  to produce the correct result". The ideal image is "a non-mosaiced camera
  ... [without] mosaic or color correction artifacts". With a Bayer mosaic
  and its demosaicing the alpha = 0 error would be that of the demosaicing,
  not zero (bilinear: a mean of 0.20 dE on cacaphony290 at 3.32 m, large at
  edges); so this experiment isolates colour: the cameras have the DCS-200's
  size, angular resolution and resampling but every sensor at every pixel.
  ``mosaic=True`` (``--mosaic`` on the command line) adds the DCS-200's GR/BG
  Bayer tile and bilinear demosaicing (the plainest method; the chapter
  names none for this example) for whoever wants the mosaic in the loop.
* **One exposure per scene** for every camera and the ideal image:
  :func:`~camsim_core.experiments.grid.common_exposure` of the alpha = 0 and
  alpha = 1 cameras. Responses are linear in alpha, so a mixture's response
  never exceeds the larger of the two ends and no camera of the sweep clips;
  the bright end of the most sensitive camera sits at 90 % of the range.
* **Geometry**: by default 3.32 m from the scene (Figure 1.8's distance:
  cacaphony290 becomes 233 x 372 pixels at 102.6 pixels per degree);
  ``distance=None`` keeps each scene's own.
* **Monitor**: the shipped SimToolbox test calibration (the chapter's Apple
  20" calibration is not available).
* **S-CIELAB viewing** (:mod:`camsim_core.metrics.viewing`): by default the
  chapter's, samples per degree = the camera's angular resolution (102.6:
  the 372-pixel image spans 3.6 degrees); ``viewing="camera/10"`` is the
  original simulator's S-CIELAB example (10.26), ``viewing=S`` any rate.
  The white point is the monitor's white. The records carry the viewing
  and the samples per degree used; the printed table names them.
* **Noise seeds**: the same noise field for every alpha at a given (scene,
  sigma, seed index) (:mod:`camsim_core.experiments.grid`).

Programmatic use (the explorer's Experiments tab)::

    from camsim_core.experiments import sensors
    records = sensors.run(alphas=[0, 0.5, 1], sigmas=[0, 5], seeds=1, workers=None)
    rows = sensors.summarize(records)      # mean, std over seeds per (scene, alpha, sigma, method)
    fig = plot.sensors_figure(rows)       # matplotlib Figure (two panels)
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .grid import (
    DEFAULT_DISTANCE,
    DEFAULT_MONITOR,
    check_distance,
    check_monitor,
    check_scenes,
    check_seeds,
    check_sigmas,
    check_unit_interval,
    common_exposure,
    task_seed,
)
from .results import format_mean_std, summarize as _summarize, write_csv
from .runner import run_tasks
from ._evaluation import check_viewing, ideal_reference, monitor as _monitor_named, viewing_rate
from ..metrics.viewing import DEFAULT_VIEWING

__all__ = [
    "camera_rate",
    "SensorsConfig",
    "ALPHAS",
    "SIGMAS",
    "METHODS",
    "camera",
    "configurations",
    "evaluate",
    "run",
    "summarize",
    "table",
    "write_outputs",
]

#: Default mixture weights: 0, 0.1, ..., 1 (11 values).
ALPHAS = tuple(round(a, 10) for a in np.linspace(0.0, 1.0, 11))
#: Default noise standard deviations, digital units (camera range 0-255).
SIGMAS = (0.0, 2.0, 5.0)
#: Rendering methods compared (section 4.2), in the figure's panel order.
METHODS = ("baseline", "illuminant")
#: Dimension of the Munsell linear model of surfaces for the illuminant-based method.
SURFACE_DIMENSIONS = 3

_RECORD_COLUMNS = ("scene", "alpha", "sigma", "seed", "noise_seed", "exposure", "distance", "monitor", "mosaic",
                   "viewing", "samples_per_degree", "height", "width") + METHODS + ("seconds",)


@dataclass(frozen=True)
class SensorsConfig:
    """One task of the sensors experiment (everything a worker needs)."""

    scene: str
    alpha: float
    sigma: float
    seed: int
    exposure: float
    distance: float | None = DEFAULT_DISTANCE
    monitor: str = DEFAULT_MONITOR
    mosaic: bool = False
    viewing: str = DEFAULT_VIEWING

    @property
    def noise_seed(self):
        """Seed of the camera's noise: from (scene, sigma, seed index), the same for every alpha."""
        return task_seed("sensors", str(self.scene), float(self.sigma), int(self.seed))


def camera(alpha, sigma=0.0, seed=0, *, mosaic=False):
    """The Kodak DCS-200 (IR-filtered) geometry with mixture sensors, 8 bits, Gaussian noise ``sigma`` DU."""
    from ..camera import load_camera
    from ..datasets.sensors import mixture

    base = load_camera("kodak-dcs200-ir")
    return base.replace(
        name=f"mixture-{alpha:g}",
        sensors=mixture(alpha),
        mosaic=base.mosaic if mosaic else None,
        noise_model="gaussian",
        noise_mean=0.0,
        noise_sigma=float(sigma),
        bits=8,
        seed=seed,
    )


def camera_rate():
    """The designs' angular resolution (px/deg): the samples per degree of the "camera" viewing."""
    from ..metrics import samples_per_degree

    return samples_per_degree(camera(0.0))


def configurations(scenes=("cacaphony290",), alphas=ALPHAS, sigmas=SIGMAS, seeds=1, *, distance=DEFAULT_DISTANCE,
                   monitor=DEFAULT_MONITOR, mosaic=False, viewing=DEFAULT_VIEWING):
    """Validate a grid and list its tasks (scene x alpha x sigma x seed index).

    Raises :class:`~camsim_core.errors.ParameterError` before anything runs
    for alpha outside [0, 1], a negative or non-finite sigma, seeds < 1, an
    unknown scene or monitor, a non-positive distance, a bad ``viewing``
    (:func:`camsim_core.metrics.parse_viewing`: ``"camera"``, ``"camera/10"``,
    a number of samples per degree, ...).
    """
    viewing = check_viewing(viewing)
    alphas = check_unit_interval(alphas, "alphas")
    sigmas = check_sigmas(sigmas, "sigmas")
    seeds = check_seeds(seeds)
    distance = check_distance(distance)
    monitor = check_monitor(monitor)
    loaded = check_scenes(scenes)
    ends = [camera(0.0, mosaic=mosaic), camera(1.0, mosaic=mosaic)]
    out = []
    for name, scene in loaded.items():
        exposure = common_exposure(scene, ends, distance)
        for alpha in alphas:
            for sigma in sigmas:
                for s in range(seeds):
                    out.append(SensorsConfig(name, alpha, sigma, s, exposure, distance, monitor, bool(mosaic), viewing))
    return out


@lru_cache(maxsize=8)
def _ideal(scene_name, distance, exposure, monitor_name, mosaic):
    """XYZ of the ideal image, its white point and samples per degree (cached per worker process)."""
    return ideal_reference(scene_name, camera(0.0, mosaic=mosaic), monitor_name, distance, exposure)


def evaluate(config):
    """Mean S-CIELAB dE*ab of both renderings of one camera image against the ideal image.

    Returns a dict: the configuration's fields, ``noise_seed``, the image
    ``height`` and ``width``, ``baseline`` and ``illuminant`` (mean S-CIELAB
    dE*ab, CIE 1976) and ``seconds`` (time of this task).
    """
    from .. import demosaic, render, simulate
    from ..scene import load_scene
    from ._evaluation import mean_scielab, xyz_of

    t0 = time.perf_counter()
    scene = load_scene(config.scene)
    monitor = _monitor_named(config.monitor)
    cam = camera(config.alpha, config.sigma, config.noise_seed, mosaic=config.mosaic)
    image = simulate(scene, cam, distance=config.distance, exposure=config.exposure)
    if config.mosaic:
        image = demosaic(image, method="bilinear")
    ideal_xyz, white, camera_rate = _ideal(config.scene, config.distance, config.exposure, config.monitor, config.mosaic)
    spd, _ = viewing_rate(config.viewing, camera_rate)
    errors = {}
    for method in METHODS:
        if method == "illuminant":
            shown = render(image, monitor, method="illuminant", illuminant=scene.illuminant, dimensions=SURFACE_DIMENSIONS)
        else:
            shown = render(image, monitor, method="baseline")
        errors[method] = mean_scielab(xyz_of(shown, monitor), ideal_xyz, spd, white)
    return {
        **asdict(config),
        "noise_seed": config.noise_seed,
        "samples_per_degree": spd,
        "height": int(image.data.shape[0]),
        "width": int(image.data.shape[1]),
        **errors,
        "seconds": time.perf_counter() - t0,
    }


def run(*, scenes=("cacaphony290",), alphas=ALPHAS, sigmas=SIGMAS, seeds=1, distance=DEFAULT_DISTANCE,
        monitor=DEFAULT_MONITOR, mosaic=False, viewing=DEFAULT_VIEWING, workers=None, scheduler=None, processes=True,
        progress=False, function=evaluate):
    """Run the sweep and return one record (dict, see :func:`evaluate`) per configuration, in grid order.

    ``workers=None`` (and no ``scheduler``) runs in this process without
    Dask; ``workers=N`` starts a local Dask cluster of N single-thread
    workers; ``scheduler="tcp://..."`` uses an existing cluster. The grid is
    validated before any task starts. ``function`` replaces the evaluation
    (for tests).
    """
    configs = configurations(scenes, alphas, sigmas, seeds, distance=distance, monitor=monitor, mosaic=mosaic,
                             viewing=viewing)
    return run_tasks(function, configs, workers=workers, scheduler=scheduler, processes=processes, progress=progress,
                     desc="sensors")


def summarize(records):
    """Mean and standard deviation over seeds: one row per (scene, alpha, sigma, method)."""
    return _summarize(records, ("scene", "alpha", "sigma"), METHODS, value_name="method")


def table(summary):
    """Text table: one line per (scene, alpha), a column per (method, sigma), mean ± std over seeds."""
    scenes = list(dict.fromkeys(r["scene"] for r in summary))
    sigmas = list(dict.fromkeys(r["sigma"] for r in summary))
    index = {(r["scene"], r["alpha"], r["sigma"], r["method"]): r for r in summary}
    lines = []
    n = max(r["n"] for r in summary)
    for scene in scenes:
        alphas = list(dict.fromkeys(r["alpha"] for r in summary if r["scene"] == scene))
        lines.append(f"Figure 1.14: mean S-CIELAB dE*ab against the ideal image, scene {scene}, "
                     f"{'mean ± std over ' + str(n) + ' seeds' if n > 1 else '1 seed'}")
        head = ["alpha"] + [f"{m} s={s:g}" for m in METHODS for s in sigmas]
        rows = [[f"{a:g}"] + [format_mean_std(index[scene, a, s, m]["mean"], index[scene, a, s, m]["std"])
                              for m in METHODS for s in sigmas] for a in alphas]
        widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
        for row in [head] + rows:
            lines.append("  ".join(str(x).rjust(w) for x, w in zip(row, widths)))
        lines.append("")
    return "\n".join(lines)


def write_outputs(records, folder):
    """Write ``sensors-records.csv`` (one row per task), ``sensors-summary.csv`` and one
    ``figure-1-14[-SCENE].png`` per scene into ``folder``; return the paths."""
    from .plot import save_png, sensors_figure

    folder = Path(folder)
    summary = summarize(records)
    paths = [write_csv(records, folder / "sensors-records.csv", _RECORD_COLUMNS),
             write_csv(summary, folder / "sensors-summary.csv", ("scene", "alpha", "sigma", "method", "mean", "std", "n"))]
    scenes = list(dict.fromkeys(r["scene"] for r in summary))
    for scene in scenes:
        suffix = "" if len(scenes) == 1 else "-" + Path(scene).stem
        views = {(r["viewing"], r["samples_per_degree"]) for r in records if r["scene"] == scene and "viewing" in r}
        view = "; ".join(f"S-CIELAB {spd:.4g} samples/deg ({v})" for v, spd in sorted(views))
        fig = sensors_figure([r for r in summary if r["scene"] == scene], title=f"scene {scene}" + (f"\n{view}" if view else ""))
        paths.append(save_png(fig, folder / f"figure-1-14{suffix}.png"))
    return paths
