"""The effect of the mosaic: three versus four sensors, chapter section 5, Table 1.16 (Figure 1.15).

Two camera designs with Gaussian sensitivities of 27 nm standard deviation
(:func:`camsim_core.datasets.sensors.gaussian_sensors`, each curve with the
DCS-200's mean area) and the Kodak DCS-200's spatial parameters:

* **4 sensors** centred on 460, 520, 580 and 640 nm (classes 1-4) on the
  regular 2 x 2 grid of Figure 1.15 (:data:`~camsim_core.simulation.FOUR_SENSOR_GRID`);
* **3 sensors**: the same without class 2 (520 nm), on the DCS-200's GR/BG
  Bayer tile with R = 640, G = 580 and B = 460 nm.

The chapter names only the 520 nm centre; 460, 520, 580 and 640 nm are this
program's default (``centers=`` / ``--centers``), and the output says so.
Each raw image (8 bits, Gaussian noise sigma in digital units of the 0-255
range) is demosaiced by the Bayesian method (references 24, 25; statistics
from a bilinear demosaic of the image itself), rendered by the
illuminant-based method with the scene's known illuminant and a linear
model of the Munsell surfaces of as many dimensions as sensors (3-D, 4-D),
and compared with the noiseless ideal image (the chapter's reference of
section 4.3, ``reference="chapter"`` of :func:`camsim_core.ideal_image`) by
the mean S-CIELAB dE*ab.

As in :mod:`camsim_core.experiments.sensors`: one exposure per scene for
both designs and the ideal image (:func:`~camsim_core.experiments.grid.common_exposure`
of the cones and both designs), 3.32 m from the scene by default, the
shipped SimToolbox monitor, and the same noise field for both designs at a
given (scene, sigma, seed index). S-CIELAB's samples per degree follow the
``viewing`` (:mod:`camsim_core.metrics.viewing`; by default the chapter's,
the camera's angular resolution; ``"camera/10"`` the original's example).

Choices the chapter leaves unstated (issue 41), each a parameter with the
previous behaviour as default: ``exposure_fill`` (the share of the 0-255
range the brightest scene points reach, 0.9; it sets how large a noise sigma
of 5 is against the signal), ``normalization`` of the Gaussian curves
(``"area"``: each with the DCS-200's mean area; ``"white"``: per-channel
gains that give every class the same response to the scene illuminant),
the Bayesian demosaic's prior (``prior_detail``) and noise model
(``noise_model``: ``"known"`` sigma, ``"ignored"``, or the original mode's
``"fraction"``), the S-CIELAB ``viewing`` and the ``rendering``
(``"illuminant"`` or ``"baseline"``) with its surface model's
``surface_dimensions`` (the number of sensors, or 3).
:mod:`camsim_core.experiments.table_1_16_study` sweeps them.

Programmatic use::

    from camsim_core.experiments import mosaic
    records = mosaic.run(sigmas=[0, 5], seeds=1, workers=None)
    print(mosaic.table(mosaic.summarize(records)))
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
    check_centers,
    check_distance,
    check_monitor,
    check_scenes,
    check_seeds,
    check_sigmas,
    common_exposure,
    task_seed,
)
from .results import format_mean_std, summarize as _summarize, write_csv
from .runner import run_tasks
from ._evaluation import check_viewing, ideal_reference, monitor as _monitor_named, viewing_rate
from ..metrics.viewing import DEFAULT_VIEWING

__all__ = [
    "camera_rate",
    "MosaicConfig",
    "NORMALIZATIONS",
    "NOISE_MODELS",
    "RENDERINGS",
    "DEMOSAIC_METHODS",
    "check_options",
    "rendered_xyz",
    "DESIGNS",
    "SIGMAS",
    "CENTERS",
    "STD_NM",
    "CHAPTER_TABLE",
    "camera",
    "configurations",
    "evaluate",
    "run",
    "summarize",
    "table",
    "write_outputs",
]

#: Number of sensor classes of the two designs.
DESIGNS = (3, 4)
#: Default noise standard deviations, digital units (camera range 0-255).
SIGMAS = (0.0, 2.0, 5.0)
#: Default sensor centres, nm (the chapter gives only the 520 nm one).
CENTERS = (460.0, 520.0, 580.0, 640.0)
#: Standard deviation of the Gaussian sensitivities, nm.
STD_NM = 27.0
#: Default share of the 8-bit range reached by the 99.5th percentile of the brightest sensor (grid.common_exposure).
EXPOSURE_FILL = 0.9
#: How the Gaussian curves are scaled against each other: equal area (the DCS-200's mean) or white-balanced gains.
NORMALIZATIONS = ("area", "white")
#: The Bayesian demosaic's likelihood noise: the camera's sigma, none, or the original mode's fixed fraction.
NOISE_MODELS = ("known", "ignored", "fraction")
#: Rendering methods of chapter section 4.2.
RENDERINGS = ("illuminant", "baseline")
#: Demosaicing methods the experiment accepts (any tile).
DEMOSAIC_METHODS = ("bayesian", "bayesian-original", "bilinear", "freeman")
#: Table 1.16 of the chapter: mean S-CIELAB error at noise sigma 0, 2, 5.
CHAPTER_TABLE = {3: {0.0: 2.37, 2.0: 2.67, 5.0: 4.04}, 4: {0.0: 1.09, 2.0: 1.99, 5.0: 4.16}}

_RECORD_COLUMNS = ("scene", "sensors", "sigma", "seed", "noise_seed", "exposure", "distance", "monitor", "centers",
                   "std_nm", "demosaic", "viewing", "samples_per_degree", "exposure_fill", "normalization", "prior_detail",
                   "noise_model", "rendering", "surface_dimensions", "height", "width", "error", "seconds")


@dataclass(frozen=True)
class MosaicConfig:
    """One task of the mosaic experiment."""

    scene: str
    sensors: int
    sigma: float
    seed: int
    exposure: float
    distance: float | None = DEFAULT_DISTANCE
    monitor: str = DEFAULT_MONITOR
    centers: tuple = CENTERS
    std_nm: float = STD_NM
    demosaic: str = "bayesian"
    viewing: str = DEFAULT_VIEWING
    exposure_fill: float = EXPOSURE_FILL
    normalization: str = "area"
    prior_detail: float | None = None
    noise_model: str | None = None
    rendering: str = "illuminant"
    surface_dimensions: int | None = None

    @property
    def noise_seed(self):
        """Seed of the camera's noise: from (scene, sigma, seed index), the same for both designs."""
        return task_seed("mosaic", str(self.scene), float(self.sigma), int(self.seed))


def camera(n_sensors, sigma=0.0, seed=0, *, centers=CENTERS, std_nm=STD_NM, normalization="area", illuminant=None):
    """The 3-sensor Bayer or 4-sensor grid Gaussian camera with the DCS-200 geometry, 8 bits.

    Parameters
    ----------
    n_sensors : {3, 4}
    sigma : float
        Gaussian noise standard deviation, digital units of the 0-255 range.
    seed : int
        Seed of the noise.
    centers : sequence of 4 floats
        Peak wavelengths (nm) of classes 1-4; the 3-sensor design leaves out class 2.
    std_nm : float
        Standard deviation of the Gaussian curves, nm.
    normalization : {"area", "white"}
        ``"area"``: every curve has the DCS-200's mean area (equal-width
        Gaussians then differ only where 380-780 nm cuts their tails).
        ``"white"``: each curve is then multiplied by a gain that gives it
        the same response to ``illuminant`` (white balance in the analog
        gains, before the noise), their mean response unchanged.
    illuminant : Spectrum, optional
        Needed by ``normalization="white"``.

    Returns
    -------
    Camera
    """
    from ..camera import load_camera
    from ..datasets.sensors import Sensors, gaussian_sensors
    from ..errors import ParameterError
    from ..simulation import FOUR_SENSOR_GRID, bayer

    c = [float(v) for v in centers]
    if n_sensors == 4:
        sens = gaussian_sensors(c, std_nm, names=tuple(f"{v:g} nm" for v in c))
        tile = FOUR_SENSOR_GRID
    elif n_sensors == 3:
        rgb = [c[3], c[2], c[0]]  # R, G, B: class 2 left out
        sens = gaussian_sensors(rgb, std_nm, names=("R", "G", "B"))
        tile = bayer("GRBG")
    else:
        raise ParameterError("sensors", f"the designs have 3 or 4 sensors, got {n_sensors!r}")
    if normalization == "white":
        if illuminant is None:
            raise ParameterError("normalization", "'white' needs the scene illuminant (illuminant=)")
        e = np.asarray(illuminant.on(sens.wavelengths), float)
        response = sens.values @ e
        if not np.all(response > 0):
            raise ParameterError("normalization", "a sensor gives no response to the illuminant; cannot white-balance it")
        gains = response.mean() / response
        sens = Sensors(sens.wavelengths, sens.values * gains[:, None], sens.names, sens.unit, sens.name)
    elif normalization != "area":
        raise ParameterError("normalization", f"must be one of {', '.join(NORMALIZATIONS)}, got {normalization!r}")
    return load_camera("kodak-dcs200-ir").replace(
        name=f"gaussian-{n_sensors}", sensors=sens, mosaic=tile, noise_model="gaussian", noise_mean=0.0,
        noise_sigma=float(sigma), bits=8, seed=seed,
    )


def camera_rate():
    """The designs' angular resolution (px/deg): the samples per degree of the "camera" viewing."""
    from ..metrics import samples_per_degree

    return samples_per_degree(camera(4))


def check_options(*, demosaic="bayesian", exposure_fill=EXPOSURE_FILL, normalization="area", prior_detail=None,
                  noise_model=None, rendering="illuminant", surface_dimensions=None):
    """Validate the unstated choices (see the module docstring); returns them as a dict, canonical.

    Raises
    ------
    ParameterError
        Naming the option at fault.
    """
    from ..errors import ParameterError

    if demosaic not in DEMOSAIC_METHODS:
        raise ParameterError("demosaic", f"must be bayesian, bayesian-original, bilinear or freeman (any tile), got {demosaic!r}")
    if isinstance(exposure_fill, bool) or not isinstance(exposure_fill, (int, float, np.floating)) or not 0 < exposure_fill <= 1:
        raise ParameterError("exposure_fill", f"the share of the 0-255 range must lie in (0, 1], got {exposure_fill!r}")
    if normalization not in NORMALIZATIONS:
        raise ParameterError("normalization", f"must be one of {', '.join(NORMALIZATIONS)}, got {normalization!r}")
    bayes = demosaic.startswith("bayesian")
    if prior_detail is not None:
        if not bayes:
            raise ParameterError("prior_detail", f"applies to the Bayesian demosaics only, not {demosaic!r}")
        if isinstance(prior_detail, bool) or not isinstance(prior_detail, (int, float, np.floating)) or not 0 <= prior_detail < 100:
            raise ParameterError("prior_detail", f"must be a number >= 0 (share of the largest prior variance), got {prior_detail!r}")
        prior_detail = float(prior_detail)
    if noise_model is not None:
        allowed = {"bayesian": ("known", "ignored"), "bayesian-original": ("fraction",)}.get(demosaic, ())
        if noise_model not in allowed:
            raise ParameterError("noise_model", f"{demosaic!r} takes {', '.join(allowed) or 'no noise model'}, got {noise_model!r}")
    if rendering not in RENDERINGS:
        raise ParameterError("rendering", f"must be one of {', '.join(RENDERINGS)}, got {rendering!r}")
    if surface_dimensions is not None:
        if rendering != "illuminant":
            raise ParameterError("surface_dimensions", "applies to the illuminant-based rendering only")
        if surface_dimensions != 3:
            raise ParameterError("surface_dimensions", f"None (as many as sensors) or 3, got {surface_dimensions!r}")
        surface_dimensions = 3
    return dict(demosaic=demosaic, exposure_fill=float(exposure_fill), normalization=normalization, prior_detail=prior_detail,
                noise_model=noise_model, rendering=rendering, surface_dimensions=surface_dimensions)


def configurations(scenes=("cacaphony290",), sigmas=SIGMAS, seeds=1, *, designs=DESIGNS, centers=CENTERS, std_nm=STD_NM,
                   distance=DEFAULT_DISTANCE, monitor=DEFAULT_MONITOR, demosaic="bayesian", viewing=DEFAULT_VIEWING,
                   exposure_fill=EXPOSURE_FILL, normalization="area", prior_detail=None, noise_model=None,
                   rendering="illuminant", surface_dimensions=None):
    """Validate a grid and list its tasks (scene x design x sigma x seed index); ``viewing`` as in
    :func:`camsim_core.experiments.sensors.configurations`, the other choices as in :func:`check_options`."""
    viewing = check_viewing(viewing)
    options = check_options(demosaic=demosaic, exposure_fill=exposure_fill, normalization=normalization,
                            prior_detail=prior_detail, noise_model=noise_model, rendering=rendering,
                            surface_dimensions=surface_dimensions)
    from ..camera import load_camera
    from ..errors import ParameterError

    sigmas = check_sigmas(sigmas, "sigmas")
    seeds = check_seeds(seeds)
    centers = tuple(check_centers(centers, "centers"))
    if isinstance(std_nm, bool) or not isinstance(std_nm, (int, float)) or not 0 < std_nm < 400:
        raise ParameterError("std_nm", f"the Gaussian standard deviation must be a positive number of nm, got {std_nm!r}")
    designs = list(designs)
    if not designs or any(d not in DESIGNS for d in designs) or len(set(designs)) != len(designs):
        raise ParameterError("designs", f"choose among 3 and 4 sensors, got {designs}")
    distance = check_distance(distance)
    monitor = check_monitor(monitor)
    loaded = check_scenes(scenes)
    out = []
    for name, scene in loaded.items():
        exposure = design_exposure(scene, centers, std_nm, distance, options["exposure_fill"], options["normalization"])
        for n in designs:
            for sigma in sigmas:
                for s in range(seeds):
                    out.append(MosaicConfig(name, n, sigma, s, exposure, distance, monitor, centers, float(std_nm),
                                            viewing=viewing, **options))
    return out


def design_exposure(scene, centers=CENTERS, std_nm=STD_NM, distance=DEFAULT_DISTANCE, exposure_fill=EXPOSURE_FILL,
                    normalization="area"):
    """The common exposure (s) of the cones and both designs on ``scene`` (:func:`~.grid.common_exposure`,
    the brightest response at ``exposure_fill`` x 255)."""
    from ..camera import load_camera

    cams = [load_camera("human-cones")] + [camera(n, centers=centers, std_nm=std_nm, normalization=normalization,
                                                  illuminant=scene.illuminant) for n in DESIGNS]
    return common_exposure(scene, cams, distance, target=exposure_fill)


@lru_cache(maxsize=8)
def _ideal(scene_name, distance, exposure, monitor_name):
    """The ideal image's XYZ, white and samples per degree (cached per worker process)."""
    return ideal_reference(scene_name, camera(4), monitor_name, distance, exposure)


def demosaic_options(config):
    """Keyword options of :func:`camsim_core.demosaic` for ``config``'s prior and noise model."""
    options = {}
    if config.prior_detail is not None:
        options["detail"] = config.prior_detail
    if config.noise_model == "ignored":
        options["noise_sigma"] = 0.0
    return options


def rendered_xyz(config):
    """XYZ (H, W, 3) of one design's demosaiced, rendered image for ``config`` (simulate, demosaic, render).

    Parameters
    ----------
    config : MosaicConfig

    Returns
    -------
    numpy.ndarray
        The monitor image's XYZ (cd/m^2).
    """
    from .. import demosaic, render, simulate
    from ..scene import load_scene
    from ._evaluation import xyz_of

    scene = load_scene(config.scene)
    monitor = _monitor_named(config.monitor)
    cam = camera(config.sensors, config.sigma, config.noise_seed, centers=config.centers, std_nm=config.std_nm,
                 normalization=config.normalization, illuminant=scene.illuminant)
    raw = simulate(scene, cam, distance=config.distance, exposure=config.exposure)
    full = demosaic(raw, method=config.demosaic, **demosaic_options(config))
    if config.rendering == "baseline":
        shown = render(full, monitor, method="baseline")
    else:
        shown = render(full, monitor, method="illuminant", illuminant=scene.illuminant,
                       dimensions=config.surface_dimensions or config.sensors)
    return xyz_of(shown, monitor)


def ideal(config):
    """The ideal image's XYZ, the monitor white and the camera's samples per degree for ``config`` (cached)."""
    return _ideal(config.scene, config.distance, config.exposure, config.monitor)


def evaluate(config):
    """Mean S-CIELAB dE*ab of one design's demosaiced, rendered image against the ideal image.

    Returns a dict: the configuration's fields, ``noise_seed``, ``height``,
    ``width``, ``error`` and ``seconds``.
    """
    from ._evaluation import mean_scielab

    t0 = time.perf_counter()
    xyz = rendered_xyz(config)
    ideal_xyz, white, camera_rate = ideal(config)
    spd, _ = viewing_rate(config.viewing, camera_rate)
    error = mean_scielab(xyz, ideal_xyz, spd, white)
    rec = asdict(config)
    rec["centers"] = " ".join(f"{c:g}" for c in config.centers)
    return {**rec, "noise_seed": config.noise_seed, "samples_per_degree": spd, "height": int(xyz.shape[0]), "width": int(xyz.shape[1]),
            "error": error, "seconds": time.perf_counter() - t0}


def run(*, scenes=("cacaphony290",), sigmas=SIGMAS, seeds=1, designs=DESIGNS, centers=CENTERS, std_nm=STD_NM,
        distance=DEFAULT_DISTANCE, monitor=DEFAULT_MONITOR, demosaic="bayesian", viewing=DEFAULT_VIEWING, workers=None,
        scheduler=None, processes=True, progress=False, function=evaluate, **options):
    """Run the sweep; one record per configuration (see :func:`evaluate`), in grid order.

    ``options``: the unstated choices of :func:`check_options` (``exposure_fill``, ``normalization``, ...).
    """
    configs = configurations(scenes, sigmas, seeds, designs=designs, centers=centers, std_nm=std_nm, distance=distance,
                             monitor=monitor, demosaic=demosaic, viewing=viewing, **options)
    return run_tasks(function, configs, workers=workers, scheduler=scheduler, processes=processes, progress=progress,
                     desc="mosaic")


def summarize(records):
    """Mean and standard deviation over seeds: one row per (scene, sensors, sigma)."""
    rows = _summarize(records, ("scene", "sensors", "sigma"), ("error",), value_name="measure")
    for r in rows:
        del r["measure"]
    return rows


def table(summary, centers=CENTERS):
    """Table 1.16's layout (rows = number of sensors, columns = noise sigma), with the chapter's numbers beside."""
    lines = []
    n = max(r["n"] for r in summary)
    c = [float(v) for v in centers]
    lines.append(f"Gaussian sensors (27 nm std) centred on {', '.join(f'{v:g}' for v in c)} nm; the chapter names only "
                 f"520 nm (left out by the 3-sensor design), the other centres are camsim's choice.")
    for scene in dict.fromkeys(r["scene"] for r in summary):
        rows = [r for r in summary if r["scene"] == scene]
        sigmas = list(dict.fromkeys(r["sigma"] for r in rows))
        index = {(r["sensors"], r["sigma"]): r for r in rows}
        lines.append(f"Table 1.16: mean S-CIELAB dE*ab, scene {scene}, "
                     f"{'mean ± std over ' + str(n) + ' seeds' if n > 1 else '1 seed'} (chapter's value in brackets)")
        head = ["# Sensors \\ Noise sigma"] + [f"{s:g}" for s in sigmas]
        body = []
        for d in dict.fromkeys(r["sensors"] for r in rows):
            cells = []
            for s in sigmas:
                r = index[d, s]
                ref = CHAPTER_TABLE.get(d, {}).get(s)
                cells.append(format_mean_std(r["mean"], r["std"]) + (f" [{ref:.2f}]" if ref is not None else ""))
            body.append([f"{d} sensors"] + cells)
        widths = [max(len(x) for x in col) for col in zip(head, *body)]
        for row in [head] + body:
            lines.append("  ".join([row[0].ljust(widths[0])] + [x.rjust(w) for x, w in zip(row[1:], widths[1:])]))
        lines.append("")
    return "\n".join(lines)


def write_outputs(records, folder):
    """Write ``mosaic-records.csv`` (one row per task) and ``table-1-16.csv`` (the table's layout,
    mean and std columns per sigma); return the paths."""
    folder = Path(folder)
    summary = summarize(records)
    paths = [write_csv(records, folder / "mosaic-records.csv", _RECORD_COLUMNS)]
    wide = []
    sigmas = list(dict.fromkeys(r["sigma"] for r in summary))
    index = {(r["scene"], r["sensors"], r["sigma"]): r for r in summary}
    for scene in dict.fromkeys(r["scene"] for r in summary):
        for d in dict.fromkeys(r["sensors"] for r in summary if r["scene"] == scene):
            row = {"scene": scene, "sensors": d, "centers_nm": records[0]["centers"]}
            for s in sigmas:
                r = index.get((scene, d, s))
                row[f"mean_sigma_{s:g}"] = r["mean"] if r else ""
                row[f"std_sigma_{s:g}"] = r["std"] if r else ""
                row[f"chapter_sigma_{s:g}"] = CHAPTER_TABLE.get(d, {}).get(s, "")
            wide.append(row)
    paths.append(write_csv(wide, folder / "table-1-16.csv"))
    return paths
