"""A camera design: the explorer's parameters, the Camera and Processing they describe, and its measures.

A *design* is the plain dictionary of parameters the explorer shows and
writes to its JSON file (scene, camera preset, sensors, mosaic, geometry,
exposure, noise, bits, seed, demosaicing, rendering, monitor). This module
is the one place that turns such a dictionary into engine objects
(:func:`camera_from_params`, :func:`processing_from_params`), so that the
explorer, ``camsim report`` and the sweeps build the very same camera.

:func:`evaluate_design` runs a design through the cached pipeline
(:class:`camsim_core.cache.Pipeline`: simulation, demosaic, render, ideal
image, CIELAB and S-CIELAB error maps, chapter sections 3 to 4.3) and keeps
what a comparison needs: the rendered image, both error maps and their mean,
median and 95th percentile.

No GUI imports: this module is engine code.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..cache import Pipeline, Processing
from ..errors import CamsimError, FileFormatError, ParameterError

__all__ = [
    "DESIGN_DEFAULTS", "DESIGN_PARAMETERS", "CAMERA_CHOICES", "MOSAIC_CHOICES", "RENDER_CHOICES",
    "ILLUMINANT_CHOICES", "METRIC_CHOICES", "GAUSSIAN_DEFAULTS", "DesignResult",
    "check_params", "with_defaults", "camera_from_params", "processing_from_params", "scene_from_params",
    "evaluate_design", "measures", "quality_measures", "QUALITY_LABELS", "QUALITY_DIGITS", "check_pinned", "MAX_PINNED", "MAX_NAME", "read_design_file", "result_from_pipeline", "parse_numbers", "parse_tile", "applied_parameters", "differing_parameters", "parse_sensor", "sensor_text",
]


def _scene_names():
    from ..scene import SCENE_NAMES

    return tuple(SCENE_NAMES)


def _known_scene(value, label):
    """Whether ``value`` names a shipped scene, a chart with valid options, or an existing file.

    A chart's option names and size are checked here (a ParameterError names
    them), so a sweep or a pinned design on "slanted-edge:angle=10" is
    accepted and one on "slanted-edge:colour=red" or a chart too large is
    refused before anything runs.
    """
    from ..scene.charts import CHART_NAMES, MAX_CHART_VALUES, chart_shape

    low = value.lower()
    if low in _scene_names():
        return True
    if ":" in low and low.split(":", 1)[0] in CHART_NAMES:
        try:  # the options' names and the chart's size, allocating nothing; each value is checked as it is made
            h, w, n = chart_shape(value)
        except ParameterError as exc:
            raise ParameterError(label, str(exc)) from None
        if h * w * n > MAX_CHART_VALUES:
            raise ParameterError(label, f"the chart {value[:80]!r} would hold {h * w * n} values, more than the "
                                        f"{MAX_CHART_VALUES} a chart may have")
        return True
    return Path(value).is_file()


def _camera_names():
    from ..camera import CAMERA_NAMES

    return tuple(CAMERA_NAMES) + ("mixture",)


def _bayer_names():
    from ..simulation import BAYER

    return tuple(BAYER)


def _demosaic_names():
    from ..demosaicing import METHODS

    return tuple(METHODS)


def _monitor_names():
    from ..monitor import MONITOR_NAMES

    return tuple(MONITOR_NAMES)


#: Camera presets offered (``mixture`` uses ``alpha``).
CAMERA_CHOICES = _camera_names()
#: Mosaic layouts: the camera's own, Bayer phases, the 2 x 2 four-sensor grid, none, or a custom tile.
MOSAIC_CHOICES = ("preset",) + _bayer_names() + ("4-sensor grid", "none", "custom")
RENDER_CHOICES = ("baseline", "illuminant")
ILLUMINANT_CHOICES = ("known", "gray-world", "max-rgb")
METRIC_CHOICES = ("CIELAB", "S-CIELAB")
#: The lens: none (the chapter's five-stage camera) or diffraction-limited blur at the f-number.
#: "preset": the camera's own lens (diffraction at the f-number for the electron-level sheets, none for the
#: chapter's cameras), like the mosaic's "preset".
OPTICS_CHOICES = ("preset", "none", "diffraction")
#: Centres (nm) and widths (nm) a Gaussian preset starts from.
GAUSSIAN_DEFAULTS = {"gaussian-3": ("640, 520, 460", "27"), "gaussian-4": ("460, 520, 580, 640", "27")}

#: Every design parameter: (default, kind, choices or (low, high) bounds). The explorer's defaults:
#: the chapter's real-versus-simulated setting (Cacaphony through a DCS-200 at 3.32 m, 0.1 s, f/11).
DESIGN_PARAMETERS = {
    "scene": ("cacaphony290", "scene", None),
    "light": (1.0, "number", (1e-3, 1e3)),
    "camera": ("kodak-dcs200-ir", "choice", CAMERA_CHOICES),
    "alpha": (0.5, "number", (0.0, 1.0)),
    "gaussian_centers": ("640, 520, 460", "text", None),
    "gaussian_widths": ("27", "text", None),
    "optics": ("preset", "choice", OPTICS_CHOICES),
    "sensor": ("", "text", None),
    "mosaic": ("preset", "choice", MOSAIC_CHOICES),
    "custom_tile": ("1 0; 2 1", "text", None),
    "distance": (3.32, "number", (0.5, 20.0)),
    "exposure": (0.1, "number", (1e-4, 10.0)),
    "f_stop": (11.0, "number", (1.0, 32.0)),
    "noise_sigma": (0.0, "number", (0.0, 50.0)),
    "bits": (8, "integer", (0, 16)),
    "seed": (0, "integer", (0, 2**32 - 1)),
    "demosaic_method": ("bilinear", "choice", _demosaic_names()),
    "render_method": ("baseline", "choice", RENDER_CHOICES),
    "illuminant": ("known", "choice", ILLUMINANT_CHOICES),
    "monitor": ("simtoolbox-test", "choice", _monitor_names()),
    "metric": ("CIELAB", "choice", METRIC_CHOICES),
    "viewing": ("camera", "text", None),
    "wavelength": (550.0, "number", (0.0, 10000.0)),
}
DESIGN_DEFAULTS = {k: v[0] for k, v in DESIGN_PARAMETERS.items()}
#: Parameters a comparison shares between its designs (not stored with a pinned design).
_SHARED = ("scene", "light", "wavelength", "metric", "viewing")
#: Pinned designs in one comparison.
MAX_PINNED = 4
#: The longest name of a pinned design (characters).
MAX_NAME = 60


#: Default bounds on text-described parameters (the explorer's server may set its own).
MAX_SENSORS, MAX_TILE, MAX_TEXT = 16, 8, 256


def _check_text(text, name, max_text):
    text = str(text)
    if len(text) > max_text:
        raise ParameterError(name, f"is {len(text)} characters long; at most {max_text} are accepted")
    return text


def parse_numbers(text, name, *, max_count=MAX_SENSORS, max_text=MAX_TEXT, counted="sensors"):
    """Comma- or space-separated finite numbers from a text field (a ParameterError naming ``name`` otherwise).

    At most ``max_count`` numbers (``counted``: what each is, for the message) in at most ``max_text``
    characters.

    Examples
    --------
    >>> parse_numbers("450, 550 650", "gaussian_centers")
    [450.0, 550.0, 650.0]
    >>> parse_numbers("1 2 3", "sweep: values", max_count=2, counted="values")
    Traceback (most recent call last):
    ...
    camsim_core.errors.ParameterError: sweep: values: 3 numbers given; at most 2 values are allowed
    """
    text = _check_text(text, name, max_text)
    try:
        values = [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        raise ParameterError(name, f"expected numbers separated by commas, got {text!r}") from None
    if not values:
        raise ParameterError(name, "expected at least one number")
    if len(values) > max_count:
        raise ParameterError(name, f"{len(values)} numbers given; at most {max_count} {counted} are allowed")
    if not all(math.isfinite(v) for v in values):
        raise ParameterError(name, f"expected finite numbers, got {text!r}")
    return values


def parse_tile(text, *, max_side=MAX_TILE, max_text=MAX_TEXT):
    """A tile from text: rows separated by ';' or new lines, entries by spaces or commas (0-based).

    At most ``max_side`` rows and columns.
    """
    text = _check_text(text, "custom_tile", max_text)
    rows = [r for r in text.replace("\n", ";").split(";") if r.strip()]
    try:
        tile = [[int(v) for v in r.replace(",", " ").split()] for r in rows]
    except ValueError:
        raise ParameterError("custom_tile", f"entries must be whole sensor indices, got {text!r}") from None
    if not tile or len({len(r) for r in tile}) != 1 or not tile[0]:
        raise ParameterError("custom_tile", "rows must be non-empty and of equal length, e.g. '1 0; 2 1'")
    if len(tile) > max_side or len(tile[0]) > max_side:
        raise ParameterError("custom_tile", f"is {len(tile)} x {len(tile[0])}; at most {max_side} x {max_side} is allowed")
    if min(min(r) for r in tile) < 0:
        raise ParameterError("custom_tile", "sensor indices start at 0; negative entries are not allowed")
    return np.array(tile)


def parse_sensor(text, *, max_text=MAX_TEXT):
    """Sensor fields from text, ``"full_well_e=8000, read_noise_e=2.5"``: {name: value} (empty: the camera's own).

    Names and units are :data:`~camsim_core.camera.physical.SENSOR_FIELDS`;
    a ParameterError names ``sensor`` and what is wrong (the ranges are
    checked when the fields are applied, naming the field).
    """
    from ..camera.physical import SENSOR_FIELDS

    text = _check_text(text, "sensor", max_text)
    out = {}
    for item in (t.strip() for t in text.replace(";", ",").split(",")):
        if not item:
            continue
        name, eq, value = (v.strip() for v in item.partition("="))
        if not eq or name not in SENSOR_FIELDS:
            raise ParameterError("sensor", f"expected name=value pairs with names from {', '.join(SENSOR_FIELDS)}, "
                                           f"got {item[:40]!r}")
        try:
            number = float(value)
        except ValueError:
            raise ParameterError("sensor", f"{name}: expected a number, got {value[:40]!r}") from None
        if not math.isfinite(number):
            raise ParameterError("sensor", f"{name}: expected a finite number, got {value[:40]!r}")
        out[name] = number
    return out


def sensor_text(values):
    """The text :func:`parse_sensor` reads back (fields in :data:`SENSOR_FIELDS` order, shortest exact numbers)."""
    from ..camera.physical import SENSOR_FIELDS

    return ", ".join(f"{k}={_number_text(values[k])}" for k in SENSOR_FIELDS if k in values)


def _number_text(value):
    """``8000`` for a whole number, ``repr`` otherwise (reads back exactly)."""
    v = float(value)
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def with_defaults(params):
    """A design's parameters with each one it leaves out at its default.

    A Gaussian camera's sensor centres and widths default to that camera's own
    (:data:`GAUSSIAN_DEFAULTS`: the explorer sets them when the camera is
    chosen); every other parameter to :data:`DESIGN_DEFAULTS`. A design file
    that names ``gaussian-4`` and no centres was given the three-sensor
    preset's, and refused with "tile names sensor index 3, but the camera has
    3 sensors".

    Parameters
    ----------
    params : dict
        Design parameters by name (any subset of :data:`DESIGN_PARAMETERS`), not validated.

    Returns
    -------
    dict
        Every parameter of :data:`DESIGN_DEFAULTS`: those of ``params`` as given, the others at their default.

    Examples
    --------
    >>> with_defaults({"camera": "gaussian-4"})["gaussian_centers"]
    '460, 520, 580, 640'
    >>> with_defaults({"camera": "gaussian-4", "gaussian_widths": "30"})["gaussian_widths"]
    '30'
    >>> with_defaults({})["camera"], with_defaults({})["noise_sigma"]
    ('kodak-dcs200-ir', 0.0)
    """
    p = dict(DESIGN_DEFAULTS, **params)
    own = GAUSSIAN_DEFAULTS.get(p["camera"]) if isinstance(p["camera"], str) else None
    if own is not None:
        for name, value in zip(("gaussian_centers", "gaussian_widths"), own):
            if name not in params:
                p[name] = value
    return p


def check_params(values, where="design"):
    """The full, validated parameter dict of a design: ``values`` over their defaults (:func:`with_defaults`).

    Unknown names, wrong types and values out of range raise a ParameterError
    naming ``where`` (a file name, a pinned design's name) and the parameter.
    Scenes are checked by name only (a path is accepted when it exists).
    """
    if not isinstance(values, dict):
        raise ParameterError(where, f"expected an object {{parameter: value}}, got {type(values).__name__}")
    unknown = sorted(set(values) - set(DESIGN_PARAMETERS))
    if unknown:
        raise ParameterError(where, f"unknown parameter(s) {', '.join(map(str, unknown))}; "
                                    f"valid: {', '.join(DESIGN_PARAMETERS)}")
    out = {}
    for name, value in values.items():
        default, kind, spec = DESIGN_PARAMETERS[name]
        label = f"{where}: {name}"
        if kind == "choice":
            if value not in spec:
                raise ParameterError(label, f"expected one of {', '.join(spec)}, got {value!r}")
        elif kind == "scene":
            if not isinstance(value, str) or not _known_scene(value, label):
                raise ParameterError(label, f"unknown scene {value!r}: expected a shipped scene "
                                            f"({', '.join(_scene_names())}), a chart with options "
                                            "('slanted-edge:angle=10') or the path of a scene file")
        elif kind == "text":
            if not isinstance(value, str) or len(value) > MAX_TEXT:
                raise ParameterError(label, f"expected text of at most {MAX_TEXT} characters, got {str(value)[:40]!r}")
        else:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ParameterError(label, f"expected a number, got {value!r}")
            if kind == "integer":
                if float(value) != int(value):
                    raise ParameterError(label, f"expected a whole number, got {value!r}")
                value = int(value)
            else:
                value = float(value)
            low, high = spec
            if not low <= value <= high:
                raise ParameterError(label, f"must lie in [{low:g}, {high:g}], got {value!r}")
            if name == "alpha":  # the mixture the camera is made of (camera_from_params): what ran is what is listed
                value = round(value, 3)
        out[name] = value
    return with_defaults(out)  # the others at their defaults: a Gaussian camera left without centres takes its own


@lru_cache(maxsize=32)
def _preset(name):
    """A shipped camera (read once per process; cameras are immutable)."""
    from ..camera import camera_preset

    return camera_preset(name)


def _tile(params, cam, max_side=MAX_TILE, max_text=MAX_TEXT):
    """The mosaic tile the parameters choose (validated against the sensors by the simulation)."""
    from ..simulation import BAYER, FOUR_SENSOR_GRID

    mosaic = params["mosaic"]
    if mosaic == "preset":
        return cam.mosaic
    if mosaic in BAYER:
        return BAYER[mosaic]
    if mosaic == "4-sensor grid":
        return FOUR_SENSOR_GRID
    if mosaic == "none":
        return None
    return parse_tile(params["custom_tile"], max_side=max_side, max_text=max_text)


def camera_from_params(params, *, max_sensors=MAX_SENSORS, max_tile=MAX_TILE, max_text=MAX_TEXT):
    """The :class:`~camsim_core.Camera` a design describes.

    The preset (or ``mixture-ALPHA``: (1 - alpha) cones + alpha DCS-200,
    section 5), Gaussian sensors from ``gaussian_centers`` / ``gaussian_widths``
    (nm) for the Gaussian presets, the chosen mosaic, and distance (m),
    exposure (s), f-stop, Gaussian noise sigma (digital units, zero mean),
    bits (0 = unquantized) and seed. Raises CamsimError on a bad combination.
    ``max_sensors``, ``max_tile`` and ``max_text`` bound the text-described
    parameters (Gaussian centres and widths, the custom tile).
    """
    from ..camera.physical import with_settings
    from ..datasets.sensors import gaussian_sensors

    p = with_defaults(params)
    if p["camera"] == "mixture":
        cam = _preset(f"mixture-{round(float(p['alpha']), 3):g}")
    else:
        cam = _preset(p["camera"])
    changes = {}
    if p["camera"] in GAUSSIAN_DEFAULTS:
        centers = parse_numbers(p["gaussian_centers"], "gaussian_centers", max_count=max_sensors, max_text=max_text)
        widths = parse_numbers(p["gaussian_widths"], "gaussian_widths", max_count=max_sensors, max_text=max_text)
        if len(widths) not in (1, len(centers)):
            raise ParameterError("gaussian_widths", f"give one width or one per sensor ({len(centers)})")
        # R, G, B only for the three-sensor preset's red, green and blue peaks; otherwise the
        # peak wavelength (the engine's default "G520" reads as "green")
        rgb = p["camera"] == "gaussian-3" and list(centers) == [640.0, 520.0, 460.0]
        names = ("R", "G", "B") if rgb else tuple(f"{c:g} nm" for c in centers)
        changes["sensors"] = gaussian_sensors(centers, widths if len(widths) > 1 else widths[0], names=names)
    changes["mosaic"] = _tile(p, cam, max_tile, max_text)
    changes.update(
        distance=float(p["distance"]),
        exposure=float(p["exposure"]),
        f_stop=float(p["f_stop"]),
        noise_sigma=float(p["noise_sigma"]),
        noise_mean=0.0,
        seed=int(p["seed"]),
        optics=cam.optics if p["optics"] == "preset" else str(p["optics"]),
    )
    sensor = parse_sensor(p["sensor"], max_text=max_text)
    # an electron-level sensor stays a consistent device at other bits, pitch, full well or distance; the
    # command line builds its cameras through the same function
    return with_settings(cam, bits=int(p["bits"]) or None, sensor=sensor, **changes)


def processing_from_params(params, metrics=None):
    """The :class:`~camsim_core.cache.Processing` of a design.

    ``metrics`` defaults to the one map the design's ``metric`` shows (CIELAB
    or S-CIELAB: the explorer makes only what it shows, so an S-CIELAB move on
    a megapixel image does not also convert both images for a CIELAB map it
    hides; switching back computes that map then); comparisons pass
    ``("cielab", "scielab")``.
    """
    p = with_defaults(params)
    if metrics is None:
        metrics = ("cielab",) if p["metric"] == "CIELAB" else ("scielab",)
    return Processing(
        demosaic=p["demosaic_method"],
        render=p["render_method"],
        illuminant=None if p["illuminant"] == "known" else p["illuminant"],
        monitor=p["monitor"],
        metrics=tuple(metrics),
        viewing=p["viewing"],
    )


def scene_from_params(params):
    """The design's Scene: a shipped one (shared, read-only) or a file path, under the design's ``light``
    (a factor of the scene's own light level)."""
    from ..scene import load_scene, scale_light

    p = with_defaults(params)
    return scale_light(load_scene(p["scene"]), p["light"])


def measures(values):
    """Mean, median and 95th percentile of an error map (CIELAB Delta E units), NaNs ignored."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"mean": None, "median": None, "p95": None}
    median, p95 = np.percentile(v, [50, 95])  # one partition for both
    return {"mean": float(np.mean(v)), "median": float(median), "p95": float(p95)}


@dataclass
class DesignResult:
    """One design evaluated on its scene.

    ``rendered`` and ``ideal`` are the monitor images (H, W, 3, settings
    0..255); ``xyz`` the rendered image's XYZ on the monitor (cd/m^2) and
    ``white`` the monitor white; ``delta_e`` and ``scielab`` the (H, W)
    CIELAB and S-CIELAB dE maps against the ideal image; ``measures`` maps
    "cielab" and "scielab" to their mean, median and 95th percentile;
    ``quality`` the image-quality measures the scene allows (keys of
    :data:`QUALITY_LABELS`, see :func:`quality_measures`).
    """

    name: str
    params: dict
    camera: object = None
    processing: object = None
    scene_name: str = ""
    rendered: np.ndarray | None = None
    ideal: np.ndarray | None = None
    xyz: np.ndarray | None = None
    white: np.ndarray | None = None
    delta_e: np.ndarray | None = None
    scielab: np.ndarray | None = None
    measures: dict = field(default_factory=dict)
    quality: dict = field(default_factory=dict)
    seconds: float = 0.0
    #: The warnings its scores must carry (a black, empty or clipped frame: :attr:`camsim_core.cache.Result.exposure`'s
    #: ``flags``), shown beside them wherever they are shown.
    flags: tuple = ()
    #: What measures ``quality`` when it was left for later (``evaluate_design(quality="later")``): the pipeline's
    #: result and the monitor, held until :meth:`measure_quality` runs; None once measured (or never left).
    quality_inputs: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def quality_pending(self):
        """True while the image-quality measures were left for later and are not measured yet."""
        return self.quality_inputs is not None

    def measure_quality(self, background=False):
        """Measure the image-quality measures left for later (:func:`quality_measures`), into ``quality``.

        Returns ``quality``. Idempotent: a design measured already (or never left for later) is returned as
        it is. The pipeline result held for it is released. ``background``: measured as background work (one
        core, at lower priority, one background job at a time in the process), so that what the user waits for
        meanwhile (a browser drawing the design on the same machine, another session's moves) keeps the
        other cores; for a thread made for the work (the thread's priority stays lowered).

        Examples
        --------
        >>> r = evaluate_design({"scene": "macbeth", "camera": "kodak-dcs200"}, quality="later")
        >>> r.quality, r.quality_pending
        ({}, True)
        >>> sorted(r.measure_quality()) == ["macbeth_de2000", "psnr_db", "ssim"] and not r.quality_pending
        True
        """
        inputs = self.quality_inputs
        if inputs is not None:
            if background:
                from .._parallel import background as background_work

                with background_work():
                    self.quality = quality_measures(*inputs)
            else:
                self.quality = quality_measures(*inputs)
            self.quality_inputs = None
        return self.quality

    @property
    def shape(self):
        return None if self.delta_e is None else tuple(self.delta_e.shape)

    def error_map(self, metric="CIELAB"):
        """The dE map the metric names ("CIELAB" or "S-CIELAB")."""
        return self.scielab if metric == "S-CIELAB" else self.delta_e

    def measure(self, metric="CIELAB", statistic="mean"):
        return self.measures["scielab" if metric == "S-CIELAB" else "cielab"][statistic]

    @property
    def nbytes(self):
        arrays = (self.rendered, self.ideal, self.xyz, self.delta_e, self.scielab)
        return int(sum(a.nbytes for a in arrays if a is not None))


#: The image-quality measures of a design, with their units, in the order tables list them.
QUALITY_LABELS = {
    "psnr_db": "PSNR against the ideal image (dB)",
    "ssim": "SSIM against the ideal image",
    "mtf50": "MTF50, slanted edge (cycles/pixel)",
    "snr_db": "SNR of the raw, uniform field (dB, mean over sensors)",
    "macbeth_de2000": "Macbeth chart, mean CIEDE2000",
}
#: Decimals each measure is shown with.
QUALITY_DIGITS = {"psnr_db": 2, "ssim": 4, "mtf50": 3, "snr_db": 2, "macbeth_de2000": 2}


def quality_measures(res, monitor):
    """The image-quality measures a pipeline result allows, as numbers (keys of :data:`QUALITY_LABELS`).

    Every scene gets PSNR and SSIM of the rendered image against the ideal
    image; the slanted-edge chart adds the luminance MTF50 of the demosaiced
    image, the uniform field the raw's SNR on its central region (mean of the
    sensors' dB), the Macbeth chart the mean CIEDE2000 of its patches; all
    by :func:`camsim_core.metrics.report.measure_images`, as the explorer's
    Image quality tab and ``camsim measure`` compute them. A measure the
    images do not allow (an edge too short to fit) is left out.
    """
    from ..metrics.report import default_measures, measure_images
    from ..metrics.similarity import psnr, ssim

    # PSNR and SSIM directly: the report's "similarity" also converts both images to XYZ for a mean dE
    # that the design's own CIELAB measures already hold
    out = {"psnr_db": psnr(res.rendered, res.ideal), "ssim": ssim(res.rendered, res.ideal)}
    for what in (m for m in default_measures(getattr(res.scene, "name", "")) if m != "similarity"):
        try:
            m = measure_images((what,), raw=res.raw, demosaiced=res.demosaiced, rendered=res.rendered,
                               ideal=res.ideal, monitor=monitor)
        except CamsimError:
            continue
        if what == "mtf":
            mtf = m["mtf"].get("luminance") or next(iter(m["mtf"].values()))
            out["mtf50"] = mtf["mtf50"]
        elif what == "snr":
            out["snr_db"] = float(np.mean([c["snr_db"] for c in m["snr"]["channels"].values()]))
        elif what == "color":
            out["macbeth_de2000"] = m["color"]["mean"]
    return {k: float(v) for k, v in out.items() if v is not None}


def evaluate_design(params, name="design", *, scene=None, pipeline=None, metrics=("cielab", "scielab"), quality=True):
    """Simulate, process and score one design on its scene.

    Parameters
    ----------
    params : dict
        Design parameters (missing ones take :data:`DESIGN_DEFAULTS`); checked by :func:`check_params`.
    name : str
        The design's name (for messages and reports).
    scene : Scene, optional
        The scene to use instead of loading ``params["scene"]`` (an upload).
    pipeline : Pipeline, optional
        A cached pipeline to re-use (one per thread); a fresh one by default.
        The result is exactly that of a fresh run either way.
    metrics : tuple
        Error maps to compute: "cielab" and/or "scielab".
    quality : bool or "later"
        Also the image-quality measures (:func:`quality_measures`; sweeps leave them out). ``"later"``: not
        now, but held so that :meth:`DesignResult.measure_quality` measures them (a view shows the design
        first, its 0.3-0.7 s of quality measures after).

    Returns
    -------
    DesignResult

    Raises
    ------
    CamsimError
        When the engine refuses the design; the message names the design and the failed step.
    """
    if quality not in (True, False, "later"):
        raise ParameterError("quality", f"True, False or 'later' (got {repr(quality)[:40]})")
    if scene is None:
        p = check_params(params, name)
        scene_obj = scene_from_params(p)
    else:  # a scene object (an upload): its name in the parameters is only a label
        p = check_params({k: v for k, v in params.items() if k != "scene"}, name)
        p["scene"] = params.get("scene", getattr(scene, "name", ""))
        scene_obj = scene
    try:
        camera = camera_from_params(p)
    except CamsimError as exc:
        raise CamsimError(f"{name}: {exc}") from None
    proc = processing_from_params(p, metrics=metrics)
    res = (pipeline or Pipeline()).run(scene_obj, camera, proc)
    out = result_from_pipeline(res, p, name, proc, quality=quality is True)
    if quality == "later":
        out.quality_inputs = (res, proc.monitor)
    return out


def result_from_pipeline(res, params, name, processing, quality=True):
    """A :class:`DesignResult` from a :class:`~camsim_core.cache.Result` (a CamsimError if a step failed);
    ``quality``: with the image-quality measures."""
    if res.errors or res.delta_e is None:
        detail = "; ".join(f"{k}: {v}" for k, v in res.errors.items()) or "no error map was computed"
        raise CamsimError(f"{name}: {detail}")
    scene_name = getattr(res.scene, "name", "") or str(params.get("scene", ""))
    out = DesignResult(
        name=name, params=dict(params), camera=res.camera, processing=processing, scene_name=scene_name,
        rendered=np.asarray(res.rendered.data), ideal=np.asarray(res.ideal.data),
        xyz=np.asarray(getattr(res.xyz, "data", res.xyz), float), white=np.asarray(res.white, float),
        delta_e=np.asarray(res.delta_e, float),
        scielab=None if res.scielab is None else np.asarray(res.scielab, float),
        seconds=res.seconds,
        flags=tuple(res.exposure.flags) if res.exposure is not None else (),
    )
    out.measures = {"cielab": measures(out.delta_e)}
    if out.scielab is not None:
        out.measures["scielab"] = measures(out.scielab)
    if quality:
        out.quality = quality_measures(res, processing.monitor)
    return out


def applied_parameters(params):
    """A design's parameters (defaults filled in) with those that do not apply to its camera as None: the
    Gaussian centres and widths beside a camera other than the Gaussian presets, ``alpha`` beside one other
    than the mixture, the custom tile beside another mosaic.

    A student who has visited gaussian-4 carries its centres on to every later camera; listed as differing,
    they read as if the DCS-200 and the cones differed in centres.

    Examples
    --------
    >>> p = applied_parameters({"camera": "kodak-dcs200", "gaussian_centers": "460, 520, 580, 640"})
    >>> p["gaussian_centers"], p["alpha"], p["custom_tile"], p["camera"]
    (None, None, None, 'kodak-dcs200')
    >>> applied_parameters({"camera": "gaussian-4", "gaussian_centers": "460, 520, 580, 640"})["gaussian_centers"]
    '460, 520, 580, 640'
    """
    p = with_defaults(params)
    if p["camera"] not in GAUSSIAN_DEFAULTS:
        p["gaussian_centers"] = p["gaussian_widths"] = None
    if p["camera"] != "mixture":
        p["alpha"] = None
    if p["mosaic"] != "custom":
        p["custom_tile"] = None
    return p


def differing_parameters(designs, skip=("wavelength", "metric")):
    """Names of the parameters whose values differ between the given parameter dicts (in parameter order), among
    those that apply to each design (:func:`applied_parameters`).

    Examples
    --------
    >>> differing_parameters([{"camera": "kodak-dcs200", "gaussian_centers": "460, 520, 580, 640"},
    ...                       {"camera": "human-cones", "noise_sigma": 2.0}])
    ['camera', 'noise_sigma']
    """
    full = [applied_parameters(d) for d in designs]
    return [k for k in DESIGN_PARAMETERS if k not in skip and len({json.dumps(f[k]) for f in full}) > 1]


#: How an explorer parameters file says its result is shown, beside the design (not part of it): each name
#: with the values it may take. Read and checked, then left out of the designs.
VIEW_SETTINGS = {"de_scale": ("data", "fixed 0-20")}


def read_design_file(path):
    """The designs and the sweep an explorer parameter file holds.

    Returns ``(designs, sweep)``: ``designs`` a list of ``(name, params)``,
    first the file's own design (named after the file), then its pinned
    designs (their own names) — the file's own design is left out when it
    equals a pinned one; ``sweep`` the file's sweep (``{"parameter", "values"}``)
    or None. Raises FileFormatError (missing file, not JSON) or
    ParameterError (unknown entry, bad value, unknown scene) naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(path, "no such file (expected an explorer parameters .json file)")
    try:
        values = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise FileFormatError(path, f"not a JSON parameters file: {str(exc).splitlines()[0]}") from None
    if not isinstance(values, dict):
        raise FileFormatError(path, "expected a JSON object {parameter: value}")
    values = dict(values)
    pinned = values.pop("pinned", None) or []
    sweep = values.pop("sweep", None) or None
    for name, allowed in VIEW_SETTINGS.items():
        if name in values and values.pop(name) not in allowed:
            raise ParameterError(f"{path}: {name}", f"expected one of {', '.join(allowed)}")
    own = check_params(values, str(path))
    shared = {k: own[k] for k in _SHARED}  # the scene and viewing of the file's comparison
    designs = [(e["name"], {**e["params"], **shared}) for e in check_pinned(pinned, f"{path}: pinned")]
    if not any(_same_design(own, d) for _, d in designs):
        designs.insert(0, (path.stem, own))
    if sweep is not None:
        from .sweep import check_sweep

        sweep = check_sweep(sweep, where=f"{path}: sweep")
    return designs, sweep


def check_pinned(pinned, where="pinned"):
    """Validated pinned designs: a list of at most :data:`MAX_PINNED` ``{"name", "params"}`` objects.

    ``params`` are a design's camera and processing settings that differ from
    :data:`DESIGN_DEFAULTS` (the scene and the viewing are shared by the
    comparison and not stored); names must be unique text.
    """
    if not isinstance(pinned, list):
        raise ParameterError(where, "expected a list of {name, params} objects")
    if len(pinned) > MAX_PINNED:
        raise ParameterError(where, f"at most {MAX_PINNED} pinned designs, got {len(pinned)}")
    out, names = [], set()
    for i, entry in enumerate(pinned):
        if not isinstance(entry, dict) or set(entry) - {"name", "params"} or not isinstance(entry.get("params"), dict):
            raise ParameterError(f"{where}[{i}]", "expected an object {name, params}")
        name = entry.get("name")
        if not isinstance(name, str) or not name.strip() or len(name) > MAX_NAME or name in names:
            raise ParameterError(f"{where}[{i}]: name",
                                 f"expected a unique, non-empty name of at most {MAX_NAME} characters, got {name!r}")
        names.add(name)
        params = {k: v for k, v in entry["params"].items() if k not in _SHARED}
        full = check_params(params, f"{where}: {name}")
        # only what differs from the defaults: short links, and the same entry however it was written
        out.append({"name": name, "params": {k: v for k, v in full.items()
                                             if k not in _SHARED and v != DESIGN_DEFAULTS[k]}})
    return out


def _same_design(a, b, skip=_SHARED):
    a, b = with_defaults(a), with_defaults(b)
    return all(a[k] == b[k] for k in DESIGN_PARAMETERS if k not in skip)
