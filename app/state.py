"""The explorer's state: one ``param.Parameterized`` object per browser session.

It owns every user-visible parameter and the session's cached
:class:`~camsim_core.cache.Pipeline`; views depend on its ``result``. Scenes,
camera presets and monitors come from the engine's loaders, which read them
once per process and share them read-only between sessions.

A parameter combination the engine refuses (a tile naming a missing sensor,
an unparsable list of Gaussian centres, a bad upload) sets ``message``,
leaves ``result`` at the last good one and puts the parameters back to the
values of that result (``shown``): the page never goes dead and never shows
one camera's widgets over another camera's images.

In the server each session computes in a background thread of its own
(:class:`Runner`): the Tornado event loop stays free for other sessions, and a
change made while a result is being computed supersedes the queued ones (only
the newest parameters are computed). The sessions of a whole class share the
server's cores through :data:`COMPUTE_SLOTS` (one computing thread per core,
taken in turn, at :data:`COMPUTE_NICE`), so the event loop's thread is never
one of ten threads competing for two cores. ``computing`` is True meanwhile, so the
page can show that its results are out of date.
"""

from __future__ import annotations

import functools
import itertools
import json
import logging
import math
import os
import threading
import weakref
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import param

import camsim_core as cc
from camsim_core.cache import Pipeline
from camsim_core.errors import CamsimError, ParameterError
from camsim_core.io.upload import UploadLimits
from camsim_core.io.isolated import load_upload_isolated
from camsim_core.review import design as _design
from camsim_core.review.design import (CAMERA_CHOICES, GAUSSIAN_DEFAULTS, ILLUMINANT_CHOICES, METRIC_CHOICES,
                                       MOSAIC_CHOICES, OPTICS_CHOICES, RENDER_CHOICES, camera_from_params,
                                       check_pinned, processing_from_params)
from camsim_core.camera.physical import PHYSICAL_NAMES, sensor_values
from camsim_core.scene import scale_light
from camsim_core.review.sweep import check_sweep
from camsim_core.metrics.viewing import parse_viewing

__all__ = ["ExplorerState", "Runner", "CAMERA_CHOICES", "MOSAIC_CHOICES", "URL_PARAMETERS", "COMPARE_PARAMETERS",
           "VIEW_PARAMETERS", "PAGE_PARAMETERS", "TAB_NAMES",
           "parse_tile", "parse_numbers", "load_upload", "ServerLimits", "LIMITS", "json_depth", "exposure_warnings", "bright_end",
           "mean_level", "full_scale"]

#: Bits offered; 0 means unquantized.
BITS_CHOICES = {"8": 8, "10": 10, "12": 12, "16": 16, "unquantized": 0}


def bits_choices(bits):
    """The bits list's choices: :data:`BITS_CHOICES`, and ``bits`` among them when a link or a parameters file
    set another depth (any whole number 0-16 is a camera's): the list showed "8" for a link's 7 bits, and
    sent 8 back.

    Examples
    --------
    >>> list(bits_choices(12)) == list(BITS_CHOICES)
    True
    >>> bits_choices(7)
    {'7': 7, '8': 8, '10': 10, '12': 12, '16': 16, 'unquantized': 0}
    """
    if bits in BITS_CHOICES.values():
        return dict(BITS_CHOICES)
    return dict(sorted({**BITS_CHOICES, str(bits): bits}.items(), key=lambda kv: (kv[1] == 0, kv[1])))

#: The parameters a URL carries (name in the URL = parameter name).
URL_PARAMETERS = (
    "scene", "light", "camera", "alpha", "gaussian_centers", "gaussian_widths", "optics", "sensor", "mosaic", "custom_tile",
    "distance", "exposure", "f_stop", "noise_sigma", "bits", "seed",
    "demosaic_method", "render_method", "illuminant", "monitor", "metric", "viewing", "wavelength",
)
#: The comparison's part of the shareable state: pinned designs and the sweep (see app.compare).
COMPARE_PARAMETERS = ("pinned", "sweep")
#: How the result is shown, kept in links and parameters files beside the design (not part of it).
VIEW_PARAMETERS = tuple(_design.VIEW_SETTINGS)
#: The page's own part of a link (not in parameters files): the tab shown.
PAGE_PARAMETERS = ("tab",)
#: The tabs of the page, in order, by the names a link gives them (``?tab=compare``).
TAB_NAMES = ("results", "scene", "camera", "quality", "compare", "experiments", "optics")


from camsim_core.scene.charts import CHART_NAMES as _CHART_NAMES  # noqa: E402

#: Fraction of full scale at which a chart picked in the explorer puts its brightest 0.5 % (asked: 50-90 %).
CHART_EXPOSURE = 0.8

#: The charts the server's sessions hold, by name (``shared_chart``): held weakly, kept while a session holds one.
_SHARED_CHARTS = weakref.WeakValueDictionary()
_SHARED_CHARTS_LOCK = threading.Lock()


@functools.lru_cache(maxsize=32)  # the camera list's names
def sheet_bits(camera):
    """The bits of a shipped camera's ADC, as its sheet gives them (``imx174``: 12), or None (``mixture``, a
    camera that cannot be read).

    Examples
    --------
    >>> sheet_bits("imx174"), sheet_bits("kodak-dcs200-ir"), sheet_bits("mixture")
    (12, 8, None)
    """
    try:
        return int(cc.load_camera(camera).bits or 0) or None
    except CamsimError:
        return None


def shared_chart(name, max_values):
    """The test chart ``name`` (options and all, as :func:`camsim_core.scene.charts.chart_name` writes it): the one
    another session of this server holds, else made now (and offered to the others).

    A chart's name says everything it is made from, and scenes are read-only, so sessions showing the same chart
    share one: a class opening its teacher's link to a chart fitted to a camera made it once per page (1.3 s of
    each page's build and 138 MB for the default camera's frame). A chart held under other limits is checked
    against ``max_values`` (pixels x wavelengths) again.

    Examples
    --------
    >>> a = shared_chart("macbeth:patch_size=10", 10**7)
    >>> a is shared_chart("macbeth:patch_size=10", 10**7)
    True
    """
    from camsim_core.scene.charts import chart

    with _SHARED_CHARTS_LOCK:
        scene = _SHARED_CHARTS.get(name)
    if scene is not None and scene.data.size <= max_values:
        return scene
    scene = chart(name, max_values=max_values)
    with _SHARED_CHARTS_LOCK:
        _SHARED_CHARTS[name] = scene
    return scene


def demosaic_methods():
    """Demosaicing methods the engine offers (its ``METHODS`` if published)."""
    from camsim_core import demosaicing

    methods = getattr(demosaicing, "METHODS", None) or getattr(demosaicing, "DEMOSAIC_METHODS", None)
    if methods:
        return tuple(methods)
    return ("bilinear",)


@dataclass
class ServerLimits:
    """What one session may ask of the server (``camsim serve`` flags set them; docs/serving.md lists them).

    Attributes
    ----------
    upload : UploadLimits
        Bounds on an uploaded scene (size, zip members, scene values).
    max_sensors : int
        Most Gaussian sensors (entries of the centres or widths list), default 16.
    max_tile : int
        Largest side of a custom mosaic tile, default 8 (an 8 x 8 tile).
    max_text : int
        Longest text field or URL value, characters, default 256.
    max_json_bytes : int
        Largest parameters JSON, bytes, default 64 KiB.
    max_json_depth : int
        Deepest nesting of the parameters JSON, default 4 (it is flat: an object of values).
    max_uploads : int
        Uploaded scenes a session keeps (the oldest is dropped), default 3.
    max_chart_values : int
        Largest test chart a session may ask for, pixels x wavelengths, default 47.8 million: the
        default camera's whole 1012 x 1524 frame at 31 wavelengths (a chart picked in the explorer is
        sized to the frame, :meth:`ExplorerState.fit_chart`; the shipped charts are at most 512 x 512).
    max_view_side : int
        Most pixels along either side of the image an image view sends the browser, default 1280:
        a larger result is shown by block means of its pixels, and zooming in fetches the region
        in view at up to this detail (the full array is never sent).
    """

    upload: UploadLimits = field(default_factory=UploadLimits)
    max_sensors: int = 16
    max_tile: int = 8
    max_text: int = 256
    max_json_bytes: int = 64 * 1024
    max_json_depth: int = 4
    max_uploads: int = 3
    max_chart_values: int = 1012 * 1524 * 31
    max_view_side: int = 1280


#: The limits in force in this process (``camsim serve`` replaces them).
LIMITS = ServerLimits()

#: S-CIELAB samples per degree a viewing may give in the explorer: outside, the filters' sizes run to
#: gigabytes (``spd:1e-300``) or their time to seconds per change.
VIEWING_SAMPLES_PER_DEGREE = (0.01, 10_000.0)
#: The largest whole number a browser's number keeps exactly (JavaScript's ``Number.MAX_SAFE_INTEGER``, 2**53 - 1):
#: the page's boxes, its address and Bokeh's messages hold numbers as JavaScript's doubles.
MAX_EXACT_WHOLE = 2**53 - 1


def check_text(name, value):
    """A text parameter within ``LIMITS.max_text`` characters (ParameterError naming it otherwise)."""
    if isinstance(value, str) and len(value) > LIMITS.max_text:
        raise ParameterError(name, f"is {len(value)} characters long; at most {LIMITS.max_text} are allowed")
    return value


def check_viewing(text, camera):
    """The samples per degree the viewing ``text`` gives ``camera``, within :data:`VIEWING_SAMPLES_PER_DEGREE`."""
    rate = parse_viewing(text).rate(camera)
    lo, hi = VIEWING_SAMPLES_PER_DEGREE
    if not lo <= rate <= hi:
        raise ParameterError("viewing", f"{short_repr(text)} gives {rate:.3g} samples per degree; the explorer takes "
                                        f"{lo:g} to {hi:g}")
    return rate


def short_repr(value, limit=60):
    """``repr(value)`` cut to about ``limit`` characters (a message never quotes a 100,000-character text)."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(str(value))} characters)"


#: Checks of the text parameters the engine reads, each on its own (ParameterError): a link's unreadable text is
#: refused with the link's other bad values, not accepted and then refused with the whole link by the engine.
_TEXT_CHECKS = {
    "gaussian_centers": lambda text: parse_numbers(text, "gaussian_centers"),
    "gaussian_widths": lambda text: parse_numbers(text, "gaussian_widths"),
    "custom_tile": lambda text: parse_tile(text),
    "sensor": lambda text: _design.parse_sensor(text, max_text=LIMITS.max_text),
    "viewing": lambda text: parse_viewing(text),
}


class _NotFinite:
    """What the parameters file's reader makes of NaN, Infinity and numbers beyond a float's range or
    :func:`int`'s digit limit: refused by :meth:`ExplorerState.from_json`, naming the entry."""

    def __init__(self, text):
        self.text = text if len(text) <= 40 else f"a number of {len(text)} digits"


def _json_float(text):
    value = float(text)
    return value if math.isfinite(value) else _NotFinite(text)


def _json_int(text):
    return int(text) if len(text.lstrip("-")) <= 100 else _NotFinite(text)


def _not_finite_entry(value, path):
    """The path of the first :class:`_NotFinite` in ``value`` (a parsed parameters file), or None."""
    if isinstance(value, _NotFinite):
        return f"{path} ({value.text})"
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        found = _not_finite_entry(item, f"{path}[{key}]" if isinstance(key, int) else f"{path}.{key}" if path else key)
        if found:
            return found
    return None


def parse_numbers(text, name):
    """Comma- or space-separated finite numbers from a text field (at most ``LIMITS.max_sensors``)."""
    return _design.parse_numbers(text, name, max_count=LIMITS.max_sensors, max_text=LIMITS.max_text)


def parse_tile(text):
    """A tile from text: rows separated by ';' or new lines, entries by spaces or commas (0-based).

    At most ``LIMITS.max_tile`` rows and columns.
    """
    return _design.parse_tile(text, max_side=LIMITS.max_tile, max_text=LIMITS.max_text)


def json_depth(text):
    """Deepest nesting of brackets in JSON ``text``, counted without parsing (strings skipped).

    Written by hand so that a document nested 100,000 deep is measured in
    linear time instead of exhausting :func:`json.loads`'s recursion.
    """
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def load_upload(filename, content, limits=None):
    """A Scene from uploaded bytes, read in a bounded worker process (the engine's
    :func:`camsim_core.io.isolated.load_upload_isolated`, within ``LIMITS``): a file that crashes, hangs or
    bombs a reader costs only that read, never the server and its other sessions."""
    return load_upload_isolated(filename, content, limits or LIMITS.upload)


class ExplorerState(param.Parameterized):
    """Every parameter of one explorer session, and its cached pipeline."""

    # scene
    scene = param.Selector(default="cacaphony290", objects=list(cc.SCENE_NAMES), doc="Shipped scene, or an uploaded one")
    wavelength = param.Number(default=550.0, bounds=(1.0, 1e5),
                              doc="Wavelength (nm) of the plane shown in the scene view (finite: NaN is refused)")
    light = param.Number(default=1.0, bounds=(1e-3, 1e3), step=0.1,
                         doc="Light level: a factor of the scene's own (radiance and illuminant scaled)")
    # camera
    camera = param.Selector(default="kodak-dcs200-ir", objects=list(CAMERA_CHOICES), doc="Camera preset")
    alpha = param.Number(default=0.5, bounds=(0.0, 1.0), step=0.1, doc="Mixture: (1 - alpha) cones + alpha DCS-200")
    gaussian_centers = param.String(default="640, 520, 460", doc="Gaussian sensor centres, nm")
    gaussian_widths = param.String(default="27", doc="Gaussian standard deviations, nm (one or one per sensor)")
    optics = param.Selector(default="preset", objects=list(OPTICS_CHOICES),
                            doc="The lens: the camera's own (preset), none, or diffraction-limited blur at the f-number "
                                "(per wavelength)")
    sensor = param.String(default="", doc="Electron-level sensor fields changed from the camera's own, "
                          "'full_well_e=8000, read_noise_e=2' (see camsim_core.camera.physical.SENSOR_FIELDS)")
    mosaic = param.Selector(default="preset", objects=list(MOSAIC_CHOICES), doc="Mosaic layout")
    custom_tile = param.String(default="1 0; 2 1", doc="Custom tile: 0-based sensor indices, rows separated by ';'")
    distance = param.Number(default=3.32, bounds=(0.5, 20.0), step=0.01, doc="Camera to scene, m")
    exposure = param.Number(default=0.1, bounds=(1e-4, 10.0), step=0.005, doc="Exposure time, s")
    f_stop = param.Number(default=11.0, bounds=(1.0, 32.0), step=0.1, doc="f-number")
    noise_sigma = param.Number(default=0.0, bounds=(0.0, 50.0), step=0.5, doc="Noise standard deviation, digital units")
    bits = param.Integer(default=8, bounds=(0, 16), doc="Quantization bits; 0 = unquantized")
    seed = param.Integer(default=0, bounds=(0, MAX_EXACT_WHOLE), doc="Noise seed (at most 2**53 - 1: a larger "
                         "whole number is rounded by the browser, so the box would show another seed than the one used)")
    # processing
    demosaic_method = param.Selector(default="bilinear", objects=list(demosaic_methods()))
    render_method = param.Selector(default="baseline", objects=list(RENDER_CHOICES))
    illuminant = param.Selector(default="known", objects=list(ILLUMINANT_CHOICES))
    monitor = param.Selector(default="simtoolbox-test", objects=list(cc.MONITOR_NAMES))
    metric = param.Selector(default="CIELAB", objects=list(METRIC_CHOICES), doc="Error map and histogram shown")
    viewing = param.String(
        default="camera",
        doc="How the rendered image is viewed, which fixes S-CIELAB's samples per degree: 'camera' (the chapter's, "
        "the camera's angular resolution), 'camera/10' (the original's example), 'spd:S', 'display:PITCHmm@DISTANCEm'",
    )
    # the comparison (app.compare): pinned designs [{name, params}] and the sweep {parameter, values}
    pinned = param.List(default=[], precedence=-1, doc="Pinned designs (at most four)")
    sweep = param.Dict(default=None, allow_None=True, precedence=-1, doc="The sweep shown in the comparison")
    # the page: the tab shown, kept in the address so that a link (a comparison shared) opens where it was made
    tab = param.Selector(default="results", objects=list(TAB_NAMES), precedence=-1, doc="The tab shown")
    # outputs (not user parameters)
    result = param.Parameter(default=None, precedence=-1, doc="Last good pipeline result")
    message = param.String(default="", precedence=-1, doc="Last problem, for the page's alert")
    notice = param.String(default="", precedence=-1, doc="Steps not available (engine work in progress)")
    computing = param.Boolean(default=False, precedence=-1, doc="A result for newer parameters is being computed")
    shown = param.Dict(default={}, precedence=-1, doc="The parameters of ``result`` (what the page shows)")
    de_scale = param.Selector(default="data", objects=["data", "fixed 0-20"], precedence=-1,
                              doc="dE map colour scale: follow the data, or fixed (to compare designs)")

    def __init__(self, runner=None, start=True, **params):
        """``start=False``: compute nothing yet (the page first sets a runner, then calls ``recompute``)."""
        super().__init__(**params)
        self.pipeline = Pipeline()
        self._first_run = True
        self.runner = runner
        self._uploads = {}
        self._lit = None  # (scene, light level, the scene under that light)
        self._updating = False
        self._requests = itertools.count(1)
        self._latest = 0
        self._accepted = None  # parameters of the newest job accepted (computed or being computed)
        self._refused_while = None  # the newest job's id when a change was last refused (see ``_apply``)
        self._fitted = set()  # names of the charts fit_chart made (re-fitted when the frame changes)
        self._pending_fit = None  # a chart being fitted in the computing thread (see ``fit_chart``)
        # a notice the state's own change makes (a chart fitted here, an exposure or a mosaic put back), carried
        # by the next job to ``_apply`` (which shows the job's notice with its result)
        self._next_notice = ""
        self._result_metrics = ()  # the maps the result shown was computed with ("cielab", "scielab")
        #: ``(the exposure before, the chart's)`` while a chart's auto exposure is in force (put back when the
        #: scene leaves the charts: ``_exposure_after_charts``)
        self._exposure_before_chart = None
        self._built = None  # (name, chart) made in the computing thread and not yet shown (a newer job reuses it)
        #: ``prepare(result)`` callables run after each computation, in the computing thread (views put their
        #: display arrays there, so the event loop only hands them to the browser)
        self.preparers = []
        self.param.watch(self._on_change, [p for p in URL_PARAMETERS if p not in ("wavelength",)])
        if start:
            self.recompute()

    def set_runner(self, runner):
        """Compute in the background from now on (``runner.submit(job)``, see :class:`Runner`)."""
        self.runner = runner

    # -- building engine objects ------------------------------------------
    def scene_object(self):
        """The Scene: a shipped one (shared, read-only) or this session's upload, under the light level.

        The scene at a light level other than its own is kept (one at a time): the same object on
        every change, so the pipeline re-runs only what a change touches.
        """
        scene = self._uploads[self.scene] if self.scene in self._uploads else cc.load_scene(self.scene)
        held = self._lit
        if held is None or held[0] is not scene or held[1] != self.light:
            held = self._lit = (scene, self.light, scale_light(scene, self.light))
        return held[2]

    def design_params(self):
        """The live design's parameters (the explorer's own, as plain JSON values)."""
        return {p: getattr(self, p) for p in URL_PARAMETERS}

    def camera_object(self):
        """The Camera the parameters describe; raises CamsimError on a bad combination."""
        return camera_from_params(self.design_params(), max_sensors=LIMITS.max_sensors, max_tile=LIMITS.max_tile,
                                  max_text=LIMITS.max_text)

    def processing(self):
        """The live design's processing and the maps it makes: the one the page shows, or both CIELAB and
        S-CIELAB while the Compare designs tab is shown (its table, histograms and report score every design by
        both; in S-CIELAB the live design had no CIELAB map and left the comparison without a word). Only there:
        the second map costs every change 1.6-1.7 times its time (+165 ms on a frame-sized chart)."""
        return processing_from_params(self.design_params(),
                                      metrics=("cielab", "scielab") if self.tab == "compare" else None)

    @param.depends("tab", watch=True)
    def _maps_for_the_comparison(self):
        """The Compare tab shown: the result shown gets the map it lacks (computed, the rest of its pipeline kept).

        Once per result: a result computed with both maps asked for is not asked again (``_result_metrics``)."""
        if (self.tab == "compare" and self.result is not None and not self.computing
                and set(self._result_metrics) != {"cielab", "scielab"}):
            self.recompute()

    # -- running -------------------------------------------------------------
    def _on_change(self, *events):
        if self._updating:
            return
        names = {e.name for e in events}
        if "alpha" in names and round(self.alpha, 3) != self.alpha:  # mixtures are made in steps of 0.001
            asked, self._updating = self.alpha, True
            try:
                self.alpha = round(asked, 3)
            finally:
                self._updating = False
            self._add_notice(f"Alpha {asked:g} taken as {self.alpha:g}: mixtures are made in steps of 0.001.")
        if "camera" in names and "sensor" not in names and self.sensor:
            self._updating = True  # a new camera starts from its own sensor sheet
            try:
                self.sensor = ""
            finally:
                self._updating = False
        if "camera" in names and "bits" not in names:
            own = sheet_bits(self.camera)
            if own and self.bits and own != self.bits:  # said, not changed: the page's bits are the user's
                self._add_notice(f"{self.camera}'s sheet gives its ADC {own} bits; the raw is kept at {self.bits} bits "
                                 f"(Exposure and noise: Bits of the raw).")
        if "camera" in names and self.camera in GAUSSIAN_DEFAULTS:
            centers, widths = GAUSSIAN_DEFAULTS[self.camera]
            if len(parse_numbers_safe(self.gaussian_centers)) != len(parse_numbers_safe(centers)):
                self._updating = True
                try:
                    self.param.update(gaussian_centers=centers, gaussian_widths=widths)
                finally:
                    self._updating = False
        if "mosaic" in names and self.mosaic == "custom" and "custom_tile" not in names and self.result is not None:
            self._start_custom_tile()  # a tile set with the mosaic (a link, a file) is the user's: used or refused
        elif names & {"camera", "sensor"} and not names & {"mosaic", "custom_tile"} and self.mosaic == "custom":
            self._custom_tile_for_new_camera()
        self._exposure_after_charts(names)
        fit, expose = self._fit_wanted(names)
        # issue 37: a chart picked in the scene list fills the frame; a fitted chart follows the frame's changes
        fitted = self.fit_chart(fit, expose=expose) if fit else ""
        refused = self.message if fit and not fitted else ""
        self.recompute()
        if refused and not self.message:
            self.message = refused

    def _exposure_after_charts(self, names):
        """A scene that is not a chart, picked after a chart whose auto exposure is still the one in force, gets
        the exposure that was in force before the chart (with a notice saying so): a chart's exposure (0.8 s on
        the default camera, against 0.1 s) over-exposed the photo picked after it (69.5 % of its pixels
        clipped). An exposure the user sets meanwhile, or with the new scene, is kept."""
        if self._exposure_before_chart is None:
            return
        if "exposure" in names:
            self._exposure_before_chart = None  # the user's exposure from now on
            return
        if "scene" not in names or self.scene.partition(":")[0] in _CHART_NAMES:
            return
        before, chart = self._exposure_before_chart
        self._exposure_before_chart = None
        if self.exposure != chart:
            return
        updating, self._updating = self._updating, True
        try:
            self.exposure = before
        finally:
            self._updating = updating
        self._add_notice(f"Exposure {before:.4g} s again, as before the chart (its auto exposure, {chart:.4g} s, "
                         "was for the chart).")

    def _note_chart_exposure(self, before, chart):
        """A chart's auto exposure ``chart`` (s) replaced ``before`` (s): the exposure to put back when the scene
        leaves the charts is the one before the first of them."""
        if self._exposure_before_chart is not None:
            before = self._exposure_before_chart[0]
        self._exposure_before_chart = (float(before), float(chart))

    #: Parameters that change the camera's frame (its pixels, their angle, the distance): a fitted chart follows.
    _FRAME_PARAMETERS = frozenset({"camera", "distance", "sensor"})

    def _fit_wanted(self, names):
        """``(chart, expose)``: the chart to fit to the frame after changes ``names`` (None: none), and whether
        to expose it again.

        A chart picked in the scene list is fitted and exposed. A chart this session fitted (not one whose
        options were typed, :meth:`set_chart`) is fitted again when the frame changes: exposed again for a
        new camera or sensor (another sensitivity), keeping the exposure for a new distance (the chart's
        radiance does not change with it).
        """
        pending = self._pending_fit
        if "scene" in names:
            self._pending_fit = self._built = None
            if self.scene in _CHART_NAMES and not getattr(self, "_exact_chart", False):
                return self.scene, True
            return None, False
        if pending is not None and "exposure" in names:  # the user's exposure, set while the chart is made
            self._pending_fit = pending = dict(pending, expose=False)
        if not names & self._FRAME_PARAMETERS:
            return None, False
        if pending is not None and self.scene == pending["on"]:
            return pending["base"], pending["expose"] or bool(names & {"camera", "sensor"})
        if self.scene in self._fitted:
            try:
                self.camera_object()
            except CamsimError:  # the new frame is refused (recompute says why): the chart stays
                return None, False
            return self.scene.partition(":")[0], bool(names & {"camera", "sensor"})
        return None, False

    def _start_custom_tile(self):
        """A custom tile the camera cannot use (refused, or not sampling every sensor) starts from the
        tile shown instead (then edit it)."""
        if not self._tile_samples_every_sensor():
            tile = self.result.raw.tile
            if tile is not None and np.ndim(tile) == 2:
                self._updating = True
                try:
                    self.custom_tile = "; ".join(" ".join(str(int(v)) for v in row) for row in np.asarray(tile))
                finally:
                    self._updating = False

    def _tile_samples_every_sensor(self):
        """Whether the camera the parameters describe has a mosaic sampling each of its sensors (False: refused)."""
        try:
            cam = self.camera_object()
        except CamsimError:
            return False
        return set(np.unique(np.asarray(cam.mosaic)).tolist()) == set(range(len(cam.sensors)))

    def _custom_tile_for_new_camera(self):
        """A custom tile that does not sample every sensor of a new camera (0 1 2 on a camera of four) gives way to
        the camera's own mosaic, with a notice: it made every camera of more sensors refused until the mosaic
        was put back by hand."""
        tile = self.custom_tile
        if self._tile_samples_every_sensor():
            return
        updating, self._updating = self._updating, True
        try:
            self.mosaic = "preset"
        finally:
            self._updating = updating
        self._add_notice(f"Mosaic back to the camera's own: the custom tile {tile} does not sample each of "
                         f"{self.camera}'s sensors.")

    def recompute(self):
        """Compute the result for the current parameters (in the background when a runner is set).

        Parameters the engine refuses before running (an unparsable tile, a
        tile naming a missing sensor) are refused at once: ``message`` says
        why and the parameters go back to those of the result shown.
        """
        try:
            job = self._job()
        except CamsimError as exc:
            self._refuse(str(exc), self._accepted)
            return
        except Exception as exc:  # never a dead page
            self._refuse(f"{type(exc).__name__}: {exc}", self._accepted)
            return
        self._latest = job["id"]
        self._accepted = job["params"]
        if self.runner is None:
            self._apply(job, self._compute(job))
        else:
            self.computing = True
            self.runner.submit(job)

    def _job(self):
        """What to compute: the parameters and the engine objects they describe (cheap to build).

        Every text parameter is held to ``LIMITS.max_text`` characters (however it was set: a widget, a
        link, the address changed in the page) and the viewing to :data:`VIEWING_SAMPLES_PER_DEGREE`.
        """
        params = self.design_params()
        for name, value in params.items():
            if isinstance(self.param[name], param.String):
                check_text(name, value)
        camera = self.camera_object()
        check_viewing(self.viewing, camera)
        job = {"id": next(self._requests), "params": params, "camera": camera, "processing": self.processing()}
        if self._pending_fit is not None and self.scene == self._pending_fit["on"]:
            job["chart"] = dict(self._pending_fit, light=self.light)  # made in the computing thread (``_compute``)
            # the chart at its default size is needed only if the fit is refused: made then, in that thread too
            # (made here, a process's first pick of a chart held every page's event loop 230-330 ms)
            job["scene"] = None
        else:
            job["scene"] = self.scene_object()
        snapped = self.wavelength_in_scene(job["scene"])
        if snapped:
            job["params"]["wavelength"] = self.wavelength
            self._add_notice(snapped)
        job["notice"], self._next_notice = self._next_notice, ""
        return job

    def _add_notice(self, text):
        """Add ``text`` to the notice the next result carries (an upload's, a chart's exposure put back, a mosaic
        given back: one did not replace another)."""
        self._next_notice = " ".join(n for n in (self._next_notice, text) if n)

    def wavelength_in_scene(self, scene):
        """Put a wavelength beyond ``scene``'s bands (a link's ``wavelength=5000``, or the last scene's band past
        this one's range) on the scene's nearest band; returns the notice saying so, or "" (``scene`` None: "").

        Examples
        --------
        >>> s = ExplorerState(start=False, wavelength=5000.0)
        >>> s.wavelength_in_scene(s.scene_object()), s.wavelength
        ("Wavelength 5000 nm is outside the scene's 400-700 nm: the Scene tab shows its nearest band, 700 nm.", 700.0)
        >>> s.wavelength = 604.0; s.wavelength_in_scene(s.scene_object()), s.wavelength  # within: as it is
        ('', 604.0)
        """
        if scene is None:
            return ""
        bands = np.asarray(scene.wavelengths, float)
        asked = float(self.wavelength)
        if within_bands(asked, bands):
            return ""
        self.wavelength = nearest = float(bands[np.argmin(np.abs(bands - asked))])
        return (f"Wavelength {asked:g} nm is outside the scene's {bands[0]:g}-{bands[-1]:g} nm: the Scene tab shows "
                f"its nearest band, {nearest:g} nm.")

    def _compute(self, job):
        """Run the cached pipeline (the only slow part; safe in a worker thread: one pipeline per session).

        A session's first run starts from what an earlier session computed on
        the same shipped scene (``_WARM``, shared read-only): a new page's
        first result is then at hand instead of re-running every step.
        """
        try:
            name = job["params"]["scene"]  # the job's scene: the widget may have moved on meanwhile
            scene, camera = self._fitted_for(job) if "chart" in job else (job["scene"], job["camera"])
            shipped = ":" not in name and "chart" not in job  # never share an upload's arrays between sessions
            if shipped and self._first_run and name in _WARM:
                self.pipeline.start_from(_WARM[name])
            self._first_run = False
            res = self.pipeline.run(scene, camera, job["processing"])
            for prepare in self.preparers:
                try:
                    prepare(res)
                except Exception:  # the view computes it again when it shows the result, and says why there
                    pass
            if shipped and res.raw is not None and not res.errors and name not in _WARM:
                while len(_WARM) >= _WARM_SCENES:
                    _WARM.pop(next(iter(_WARM)), None)
                _WARM[name] = self.pipeline.snapshot()
            return res, None
        except CamsimError as exc:
            return None, str(exc)
        except Exception as exc:  # never a dead page
            return None, f"{type(exc).__name__}: {exc}"

    def _apply(self, job, outcome):
        """Show a computed outcome (on the session's event loop); older jobs than the newest are dropped."""
        if job["id"] != self._latest:
            return
        res, error = outcome
        if error is None and res.raw is None:
            error = "; ".join(f"{k}: {v}" for k, v in res.errors.items())
        if error is None:
            unavailable = {k: v for k, v in res.errors.items() if "NotImplementedError" in v}
            refused = {k: v for k, v in res.errors.items() if k not in unavailable}
            # the chart's own notice ("Chart sized to the frame ...") stays beside what the engine could not do
            notes = [job.get("notice", "")] + (["Not yet available in the engine: " + ", ".join(unavailable)]
                                               if unavailable else [])
            self.notice = " ".join(n for n in notes if n)
            if refused:  # a bad combination (e.g. a Bayer-only demosaicing on a 4-sensor grid)
                error = "; ".join(f"{k}: {v}" for k, v in refused.items())
        if error is not None:
            if "chart" in job:
                self._pending_fit = None
            self._refuse(error)
            self._accepted = self.shown
            self.computing = False
            return
        if job["id"] != self._refused_while:  # a refusal made while this job computed stays in sight
            self.message = ""
        if "chart" in job:
            self._show_fitted(job)
        res.params = job["params"]
        self.shown = dict(job["params"])
        self._result_metrics = tuple(job["processing"].metrics)
        self.param.update(result=res, computing=False)  # one batch: views redraw once
        self._maps_for_the_comparison()  # the Compare tab shown while it computed: the map it lacks

    def _refuse(self, reason, back_to=None):
        """Say why, and put the parameters back to ``back_to`` (default: those of the result shown)."""
        target = self.shown if back_to is None else back_to
        back = {k: v for k, v in target.items() if getattr(self, k) != v}
        changed = ", ".join(f"{k} {short_repr(getattr(self, k))} -> {short_repr(v)}" for k, v in back.items())
        self.message = f"Refused: {reason}" + (f" (put back: {changed})" if changed else "")
        self._refused_while = self._latest
        if back:
            self.defer(lambda: self._restore(back))

    def _restore(self, values):
        self._updating = True
        try:
            self.param.update(**values)
        finally:
            self._updating = False

    @staticmethod
    def defer(fn):
        """Run ``fn`` now; the page replaces this with "on the next tick of the event loop" (a widget
        changed from the browser ignores a change made within its own callback)."""
        fn()

    def set_value(self, name, value):
        """Set one parameter from a widget; a value out of range is refused with a message.

        Returns the value in force afterwards (for the widget to show).
        """
        p = self.param[name]
        whole = isinstance(p, param.Integer)
        if whole and isinstance(value, float) and math.isfinite(value) and value.is_integer():
            value = int(value)  # a whole number from a number box (which sends floats)
        try:
            setattr(self, name, value)
        except (ValueError, TypeError) as exc:
            bounds = getattr(p, "bounds", None)
            if whole and isinstance(value, float) and math.isfinite(value):
                why = "must be a whole number"
            else:
                why = (f"must lie in {_range_text(bounds)}" if bounds is not None else str(exc).split(". ")[0])
            self.message = f"Refused: {_LABELS.get(name, name)} {value!r} {why}; kept {getattr(self, name)!r}"
        return getattr(self, name)

    def sensor_fields(self):
        """The electron-level sensor's fields in their units ({name: value}; full_well_e None: no saturation),
        of the camera the parameters describe; None for a camera calibrated in digital units (or refused)."""
        try:
            cam = self.camera_object()
        except CamsimError:
            return None
        return sensor_values(cam) if cam.noise_model == "photon" else None

    def set_sensor_field(self, name, value):
        """Set one sensor field (its unit: :data:`SENSOR_FIELDS`); the camera's own value drops the change.

        A value the sensor refuses (out of range, a full well not above the
        read noise) is refused with a message naming the field. Returns the
        value in force afterwards (for the widget to show).
        """
        fields = self.sensor_fields()
        if fields is None:
            self.message = f"Refused: sensor fields belong to the electron-level cameras ({', '.join(PHYSICAL_NAMES)})"
            return None
        try:
            changed = _design.parse_sensor(self.sensor, max_text=LIMITS.max_text)
            own = sensor_values(camera_from_params(dict(self.design_params(), sensor="")))
            if value is None or (own[name] is not None and math.isclose(float(value), own[name], rel_tol=1e-9)):
                changed.pop(name, None)
            else:
                changed[name] = float(value)
            # checked on the camera now: the refusal names the field, and the widget goes back at once
            checked = camera_from_params(dict(self.design_params(), sensor=_design.sensor_text(changed)),
                                         max_text=LIMITS.max_text)
        except CamsimError as exc:
            self.message = f"Refused: {exc}; kept {fields[name]!r}"
            return fields[name]
        except (TypeError, ValueError):
            self.message = f"Refused: {name} {value!r} is not a number; kept {fields[name]!r}"
            return fields[name]
        self.sensor = _design.sensor_text(changed)
        return sensor_values(checked)[name]

    def auto_expose(self):
        """Set the exposure so that the scene's bright end (99.5th percentile of the brightest
        sensor, noiseless) sits at 90 % of full scale; ``notice`` says so."""
        try:
            value = float(cc.auto_exposure(self.scene_object(), self.camera_object()))
        except CamsimError as exc:
            self.message = f"Refused: {exc}"
            return
        lo, hi = self.param.exposure.bounds
        self.exposure = float(np.clip(value, lo, hi))
        if lo <= value <= hi:
            self.notice = (f"Auto exposure: {self.exposure:.4g} s puts the scene's brightest 0.5 % at 90 % of full "
                           "scale. It maximises signal, not colour fidelity: dE can rise.")
        else:  # the bright end where the limit puts it (responses are linear in the exposure), not the 90 % asked
            self.notice = (f"Auto exposure: {value:.4g} s would put the scene's brightest 0.5 % at 90 % of full scale; "
                           f"exposures run {lo:g}-{hi:g} s, so {self.exposure:.4g} s puts it at "
                           f"{90 * self.exposure / value:.3g} %. It maximises signal, not colour fidelity: dE can rise.")

    def add_upload(self, filename, content):
        """Validate and select an uploaded scene; on failure set ``message`` and keep the current scene.

        Reads and selects in turn (a script, a test); the explorer reads in a thread with
        :meth:`read_upload` and selects on its event loop with :meth:`accept_upload`.
        """
        return self.accept_upload(self.read_upload(filename, content))

    @staticmethod
    def read_upload(filename, content):
        """``(scene, None)`` or ``(None, message)`` for an uploaded file: the read alone, safe in any thread."""
        name = str(filename)
        if any(ord(c) < 32 or ord(c) == 127 for c in name):  # a NUL makes every file call raise ValueError
            return None, f"Upload refused: the file name {short_repr(name)} holds a control character"
        try:
            scene = load_upload(filename, content)
        except CamsimError as exc:
            return None, f"Upload refused: {exc}"
        except Exception as exc:  # never a server path or a traceback in the page
            return None, f"Upload refused: {Path(name).name}: could not be read ({type(exc).__name__})"
        bands = int(np.asarray(scene.wavelengths).size)
        if bands < MIN_UPLOAD_BANDS:  # said in these words, not as the singular matrix the rendering meets
            return None, (f"Upload refused: {Path(name).name}: {bands} wavelength band{'s' if bands != 1 else ''}; "
                          f"rendering its colours takes at least {MIN_UPLOAD_BANDS} (the camera's sensors and the "
                          "monitor's primaries are matched through the spectrum, Eq. 1.4)")
        return scene, None

    def accept_upload(self, outcome):
        """Select the scene of a :meth:`read_upload` outcome, or show its message; returns whether it was selected."""
        scene, message = outcome
        if scene is None:
            self.message = message
            return False
        self.message = ""
        notes = [n for n in scene.notices if n]
        if notes:  # what the reader assumed or changed (a distance, a unit, negative values clipped): said with it
            self._add_notice(f"Loaded {scene.name}: " + "; ".join(notes) + ".")
        key = f"upload:{scene.name}"
        again = self.scene == key
        self.add_scene(key, scene)
        if again:  # the same name again (a file edited and uploaded anew): computed with its new content
            self.param.trigger("scene")
        return True

    def set_chart(self, options):
        """Select the current test chart made with ``options`` ("angle=10, contrast=2"; empty: its defaults).

        See :meth:`offer_chart`. Returns whether the chart was selected.
        """
        from camsim_core.scene.charts import CHART_NAMES

        base = self.scene.partition(":")[0]
        if base not in CHART_NAMES:
            self.message = f"Chart options apply to a test chart ({', '.join(CHART_NAMES)}), not to {self.scene!r}"
            return False
        return self.offer_chart(f"{base}:{options}", select=True)

    def offer_chart(self, name, select=False):
        """Offer the chart ``name`` ("slanted-edge:angle=10,contrast=2") as a scene of this session.

        The chart is made once and kept like an upload, under the name
        ``load_scene`` reads back, so a link, the parameters file, pinned
        designs and the report reproduce it. Unknown or bad options, options
        the explorer does not offer (wavelengths, sampling) and charts larger
        than ``LIMITS.max_chart_values`` are refused with a message, before
        anything is made. Returns whether the chart is offered.
        """
        from camsim_core.scene.charts import CHART_NAMES, chart_name, parse_chart

        text = str(name)
        if text.partition(":")[0].strip().lower() not in CHART_NAMES:
            self.message = f"Scene {text[:80]!r} is neither one of this session's scenes nor a chart with options"
            return False
        if len(text) > LIMITS.max_text:
            self.message = f"Chart options are longer than {LIMITS.max_text} characters"
            return False
        try:
            base, opts = parse_chart(text.replace(";", ","))
            fixed = sorted(set(opts) & {"wavelengths"})
            if fixed:
                raise ParameterError("chart", f"the explorer's charts keep their {' and '.join(fixed)}")
            if "angular_resolution" in opts:  # a chart fitted to the frame names its sampling (see fit_chart)
                from camsim_core.camera.camera import ANGULAR_RESOLUTION_RANGE

                lo, hi = ANGULAR_RESOLUTION_RANGE
                ar = opts["angular_resolution"]
                if isinstance(ar, bool) or not isinstance(ar, (int, float)) or not lo <= ar <= hi:
                    raise ParameterError("angular_resolution", f"must be {lo:g} to {hi:g} pixels per degree, got {ar!r}")
            key = chart_name(base, opts)
            scene = None
            if opts and key not in self._uploads:
                scene = shared_chart(key, LIMITS.max_chart_values)
        except CamsimError as exc:
            self.message = f"Chart options refused: {exc}"
            return False
        if select:  # the options' chart as they say: not re-fitted when the frame changes
            self._fitted.discard(key)
            self._pending_fit = None
        if scene is not None:
            self.add_scene(key, scene, select=select)
        elif select:
            self._exact_chart = True  # the options' chart as they say (empty: its defaults), not fitted to the frame
            try:
                self.scene = key
            finally:
                self._exact_chart = False
        return True

    def fit_chart(self, name=None, expose=True):
        """Make test chart ``name`` (default: the scene) fill the camera's frame at the current distance,
        select it and expose it (``expose``). Returns the notice saying so, or "" (and ``message`` says why not).

        The chart is sized and sampled by
        :func:`~camsim_core.scene.charts.fitted_chart_options` (each side
        :data:`~camsim_core.scene.charts.FRAME_FILL` of the frame; the edge and
        the zone plate one sample per camera pixel: on the default camera 860 x
        1295 x 31 values, 138 MB in float32), at most ``LIMITS.max_chart_values`` values
        (coarser samples beyond), and kept under the name that makes
        it again (links, files, the report). The exposure puts the chart's
        brightest 0.5 % at :data:`CHART_EXPOSURE` of full scale (the default
        charts at 3.32 m were 39 x 39 pixels at 1 % of full scale). Picking a
        chart in the scene list calls it, and so does a change of the frame (camera, sensor, distance)
        while a chart it fitted is shown; a chart's options box
        (:meth:`set_chart`) makes exactly the chart its options say.

        With a runner (a server), making the chart (about 1 s) and its exposure is the computing
        thread's work, with the next result (:meth:`_compute`): the event loop only sizes it, the chart
        is selected and the notice shown when the result arrives (:meth:`_apply`), and this returns a
        notice saying that the chart is being sized. Without one, everything happens here.
        """
        base = str(name or self.scene).partition(":")[0]
        try:
            spec = self._fit_spec(base, expose)
        except CamsimError as exc:
            self.message = f"Chart {base} kept at its default size: {exc}"
            return ""
        if self.runner is not None:
            self._pending_fit = spec
            self.notice = f"Sizing chart {base} to the camera's frame..."
            return self.notice
        try:
            scene, lit, value = self._make_fitted(spec, self.camera_object())
        except CamsimError as exc:
            self.message = f"Chart {base} kept at its default size: {exc}"
            return ""
        lo, hi = self.param.exposure.bounds
        updating, self._updating = self._updating, True
        try:
            self.add_scene(spec["key"], scene)
            self._lit = (scene, spec["light"], lit)
            if value is not None:
                before = self.exposure
                self.exposure = float(np.clip(value, lo, hi))
                self._note_chart_exposure(before, self.exposure)
        finally:
            self._updating = updating
        self._fitted.add(spec["key"])
        self.notice = self._next_notice = self._fit_notice(spec, scene, value, self.exposure)
        return self.notice

    def _fit_spec(self, base, expose):
        """What fitting chart ``base`` to the current frame takes (cheap: no chart is made): its name, the
        frame, the light, whether to expose it, and the scene it replaces (``on``: the chart picked, or the
        chart fitted to the frame before). Raises CamsimError (a refused camera or chart)."""
        from camsim_core.scene.charts import chart_name, fitted_chart_options

        cam = self.camera_object()
        opts = fitted_chart_options(base, (cam.height, cam.width), cam.angular_resolution, cam.distance,
                                    max_values=LIMITS.max_chart_values)
        return {"base": base, "on": self.scene, "key": chart_name(base, opts), "sampling": float(opts["angular_resolution"]),
                "frame": (cam.height, cam.width), "angular_resolution": tuple(cam.angular_resolution),
                "distance": cam.distance, "light": self.light, "expose": bool(expose)}

    def _make_fitted(self, spec, camera, scene=None):
        """``(chart, chart under the light, exposure or None)`` of a :meth:`_fit_spec`: the slow part (the
        chart is made unless this session holds it, or it is given), safe in the computing thread."""
        if scene is None:
            scene = self._uploads.get(spec["key"]) or shared_chart(spec["key"], LIMITS.max_chart_values)
        lit = scale_light(scene, spec["light"])
        value = float(cc.auto_exposure(lit, camera, target=CHART_EXPOSURE)) if spec["expose"] else None
        return scene, lit, value

    def _fit_notice(self, spec, scene, value, exposure):
        """The notice of a fitted chart: its size, sampling, cover of the frame and exposure."""
        lo, hi = self.param.exposure.bounds
        h, w = scene.data.shape[:2]
        ar, (h_cam, w_cam), (phi_x, phi_y) = spec["sampling"], spec["frame"], spec["angular_resolution"]
        cover = (min(1.0, h * phi_y / ar / h_cam), min(1.0, w * phi_x / ar / w_cam))
        if value is None:
            exposed = f"exposure kept at {exposure:.4g} s."
        else:
            limited = "" if lo <= value <= hi else f" ({value:.4g} s is outside {lo:g}-{hi:g} s: limited)"
            exposed = (f"exposure {exposure:.4g} s puts its brightest 0.5 % at {CHART_EXPOSURE:.0%} of full "
                       f"scale{limited}.")
        return (f"Chart sized to the frame: {h} x {w} samples at {ar:g} px/deg, {spec['distance']:g} m away, "
                f"cover {cover[0]:.0%} x {cover[1]:.0%} of the camera's {h_cam} x {w_cam} pixels; {exposed}")

    def _fitted_for(self, job):
        """The scene and camera a job with a chart to fit computes (in the computing thread): the fitted
        chart under the light and the camera at its exposure; on a refusal the job's own (the chart at its
        default size) and the reason, for :meth:`_show_fitted`."""
        spec = job["chart"]
        held = self._built
        try:
            scene, lit, value = self._make_fitted(spec, job["camera"], held[1] if held and held[0] == spec["key"] else None)
            self._built = (spec["key"], scene)  # a job superseding this one (not shown) finds it made
        except CamsimError as exc:
            spec["error"] = f"Chart {spec['base']} kept at its default size: {exc}"
            return self._unfitted(job), job["camera"]
        except Exception as exc:  # never a dead page
            spec["error"] = f"Chart {spec['base']} kept at its default size: {type(exc).__name__}: {exc}"
            return self._unfitted(job), job["camera"]
        lo, hi = self.param.exposure.bounds
        exposure = job["camera"].exposure if value is None else float(np.clip(value, lo, hi))
        spec.update(scene=scene, lit=lit, exposure=exposure, exposed=value is not None)
        job["notice"] = self._fit_notice(spec, scene, value, exposure)
        return lit, job["camera"] if value is None else job["camera"].replace(exposure=exposure)

    def _unfitted(self, job):
        """The chart a job picked, at its default size under the job's light (a refused fit computes this);
        a chart this session holds (one fitted before, refitted for a new frame) is not made again."""
        name = job["params"]["scene"]
        return scale_light(self._uploads.get(name) or cc.load_scene(name), job["chart"]["light"])

    def _show_fitted(self, job):
        """On the event loop, with a job's result: select the chart fitted in the computing thread at its
        exposure (the job's parameters say so: they are the result's), or say why it was not."""
        spec = job["chart"]
        if self._pending_fit is not None and self._pending_fit["key"] == spec["key"]:
            self._pending_fit = None
        self._built = None  # held by the session's scenes from now on (or no longer wanted)
        if "error" in spec:
            self.message = spec["error"]
            return
        updating, self._updating = self._updating, True
        try:
            self.add_scene(spec["key"], spec["scene"], select=False)
            self._lit = (spec["scene"], spec["light"], spec["lit"])
            if spec.get("exposed"):
                self._note_chart_exposure(self.exposure, spec["exposure"])
            self.param.update(scene=spec["key"], exposure=spec["exposure"])
        finally:
            self._updating = updating
        self._fitted.add(spec["key"])
        job["params"].update(scene=spec["key"], exposure=spec["exposure"])

    def add_scene(self, key, scene, select=True):
        """Offer ``scene`` (a Scene object) under ``key`` in this session and select it (``select``).

        A session keeps at most ``LIMITS.max_uploads`` scenes of its own; the oldest is dropped.
        """
        self._uploads.pop(key, None)
        self._uploads[key] = scene
        objs = [o for o in self.param.scene.objects if o != key]
        while len(self._uploads) > max(1, LIMITS.max_uploads):
            old = next(iter(self._uploads))
            del self._uploads[old]
            objs = [o for o in objs if o != old]
        self.param.scene.objects = objs + [key]
        if select:
            self.scene = key

    # -- reproducible state ----------------------------------------------------
    def apply_valid(self, values):
        """Set the parameters of ``values`` ({name: value}) that their parameter accepts, as one change; return
        the refused ones ({name: value}).

        For a link whose batch of values Param refused as a whole: Param sets the values before the first bad one
        without telling the watchers, and none after it, so one bad value in a link (``seed=-3``) made the
        values after it refused too and left those before it set but not computed.

        Examples
        --------
        >>> s = ExplorerState(start=False)
        >>> s.apply_valid({"seed": -3, "noise_sigma": 1.0, "distance": 5.0})
        {'seed': -3}
        >>> (s.seed, s.noise_sigma, s.distance, s.shown["noise_sigma"], s.shown["distance"])
        (0, 1.0, 5.0, 1.0, 5.0)
        """
        refused, accepted = {}, []
        with param.discard_events(self):  # each checked by its own parameter; the watchers told once, below
            for name, value in values.items():
                try:
                    check = _TEXT_CHECKS.get(name)
                    if check is not None and isinstance(value, str):
                        check(value)  # a text the engine reads (numbers, a tile, sensor fields, a viewing)
                    setattr(self, name, value)
                except (ValueError, TypeError):  # Param's refusal, or the engine's reader's (a ParameterError)
                    refused[name] = value
                else:
                    accepted.append(name)
        if accepted:
            self.param.trigger(*accepted)
        return refused

    def start_over(self, scene=None):
        """Back to the design a new page opens with: ``scene`` (default: the parameter's default), the default
        camera and every other design and view setting at its default, the Results tab; one computation.

        What the session collected is kept: the pinned designs and the sweep (a comparison to go on with),
        and the scenes uploaded or charts made (still in the scene list). Returns True.

        Examples
        --------
        >>> s = ExplorerState(start=False)
        >>> _ = s.param.update(noise_sigma=5.0, camera="human-cones", de_scale="fixed 0-20")
        >>> s.start_over()
        True
        >>> (s.noise_sigma, s.camera, s.de_scale)
        (0.0, 'kodak-dcs200-ir', 'data')
        """
        names = URL_PARAMETERS + VIEW_PARAMETERS + ("tab",)
        values = {name: self.param[name].default for name in names}
        if scene is not None:
            values["scene"] = scene
        self._pending_fit = self._built = None  # a chart fitted for the old design is not wanted any more
        self._fitted.clear()
        self._exposure_before_chart = None
        try:
            self._updating = True  # one computation for all of it, not one per parameter
            self.param.update(**values, message="")
        finally:
            self._updating = False
        self.recompute()
        return True

    def to_dict(self):
        """The parameters as plain JSON values (with the pinned designs and the sweep)."""
        return {**self.design_params(), **{p: getattr(self, p) for p in VIEW_PARAMETERS},
                "pinned": list(self.pinned), "sweep": self.sweep}

    def to_json(self):
        return json.dumps(self.to_dict(), indent=2)

    def from_json(self, text):
        """Apply parameters from JSON text; unknown, invalid, oversized or too deep entries are refused with a message."""
        if isinstance(text, bytes):
            text = text.decode("utf-8", errors="replace")
        text = str(text)
        if len(text.encode("utf-8", errors="replace")) > LIMITS.max_json_bytes:
            self.message = f"Parameters file is larger than {LIMITS.max_json_bytes} bytes"
            return False
        if json_depth(text) > LIMITS.max_json_depth:
            self.message = f"Parameters file is nested deeper than {LIMITS.max_json_depth} levels"
            return False
        try:  # NaN, Infinity and numbers beyond a float (1e999) are not JSON numbers: refused below, by name
            values = json.loads(text, parse_constant=_NotFinite, parse_float=_json_float, parse_int=_json_int)
        except (ValueError, UnicodeDecodeError, RecursionError) as exc:
            self.message = f"Parameters file is not JSON: {exc}"
            return False
        if not isinstance(values, dict):
            self.message = "Parameters file must hold a JSON object {name: value}"
            return False
        bad = _not_finite_entry(values, "")
        if bad:
            self.message = (f"Parameters file refused: {bad[:200]}: numbers must be finite (no NaN or Infinity) "
                            "and of at most 100 digits")
            return False
        unknown = sorted(set(values) - set(URL_PARAMETERS) - set(COMPARE_PARAMETERS) - set(VIEW_PARAMETERS))
        if unknown:
            self.message = f"Parameters file has unknown entries: {', '.join(unknown)[:200]}"
            return False
        for key, value in values.items():
            if key in COMPARE_PARAMETERS:
                continue  # checked below, entry by entry
            if isinstance(value, (list, dict)) or (isinstance(value, str) and len(value) > LIMITS.max_text):
                self.message = f"Parameters file refused: {key} must be a single value of at most {LIMITS.max_text} characters"
                return False
        try:
            if values.get("pinned"):
                values["pinned"] = check_pinned(values["pinned"], "pinned")
            if values.get("sweep"):
                values["sweep"] = check_sweep(values["sweep"])
        except CamsimError as exc:
            self.message = f"Parameters file refused: {exc}"
            return False
        scene = values.get("scene")
        if isinstance(scene, str) and ":" in scene and scene not in self.param.scene.objects:
            if not self.offer_chart(scene):  # a chart with options is made here; anything else is refused below
                return False
        before = self.to_dict()
        try:
            self._updating = True
            self.param.update(**values)
        except (ValueError, TypeError) as exc:
            self.param.update(**before)
            self.message = f"Parameters file refused: {exc}"
            return False
        finally:
            self._updating = False
        self.recompute()
        return True


#: Per shipped scene, the pipeline memory of the first session that computed on it (at most ``_WARM_SCENES``).
_WARM = {}
_WARM_SCENES = 2


#: Sessions computing at once in the whole server: one per core. A class's changes arriving together queue
#: here (in arrival order) instead of running as a thread each: ten threads sharing two cores all finish late,
#: and they starve the event loop of the GIL (each of its callbacks then waits behind ten threads).
COMPUTE_SLOT_COUNT = max(1, os.cpu_count() or 1)
COMPUTE_SLOTS = threading.BoundedSemaphore(COMPUTE_SLOT_COUNT)

#: Niceness of a session's computing thread (Linux sets it per thread): the event loop's thread wins a core
#: from it at once, and a sweep's or a pin's thread (``camsim_core._parallel.BACKGROUND_NICE``) loses to it.
COMPUTE_NICE = 5


#: The threads that run the sessions' computations, kept between bursts. A thread started per burst made the
#: event loop wait for it to start (``Thread.start`` waits for the new thread to run, which needs the GIL
#: that computing threads hold): 243 ms in the hostile load test. More threads than slots: a session waiting
#: for a slot holds one, and every slot can still be taken.
SESSION_THREAD_COUNT = max(32, 4 * COMPUTE_SLOT_COUNT)
SESSION_THREADS = ThreadPoolExecutor(SESSION_THREAD_COUNT, thread_name_prefix="camsim-session")
#: The threads that wait for uploads being read (each read runs in a worker process of its own,
#: ``camsim_core.io.isolated``); more uploads at once queue for them.
UPLOAD_THREAD_COUNT = 4
UPLOAD_THREADS = ThreadPoolExecutor(UPLOAD_THREAD_COUNT, thread_name_prefix="camsim-upload")


def start_session_threads(timeout=30.0):
    """Start every thread of :data:`SESSION_THREADS` and :data:`UPLOAD_THREADS` now; a server calls this
    before it serves.

    A pool otherwise grows on the event loop, one thread per session
    computing (or upload read) at once for the first time, each start
    waiting for the GIL (174 ms for the first burst of ten sessions in the
    hostile load test, 103 ms for an upload).

    Returns
    -------
    int
        The number of threads started.
    """
    waits = []
    for pool, count in ((SESSION_THREADS, SESSION_THREAD_COUNT), (UPLOAD_THREADS, UPLOAD_THREAD_COUNT)):
        gate = threading.Barrier(count, timeout=timeout)
        waits += [pool.submit(gate.wait) for _ in range(count)]
    for w in waits:  # each task holds its thread until all of its pool's are in: the pool grows to its full size
        w.result()
    return SESSION_THREAD_COUNT + UPLOAD_THREAD_COUNT


class Runner:
    """Computes a session's results in a background thread; only the newest request is computed.

    ``submit(job)`` returns at once. A thread of :data:`SESSION_THREADS`
    runs ``compute(job)`` and hands ``(job, outcome)`` to ``deliver``; jobs
    submitted while it computes replace each other, so after a burst of
    changes only the last is computed, and an outcome that a newer job has
    made obsolete is not delivered.
    """

    def __init__(self, compute, deliver):
        self._compute = compute
        self._deliver = deliver
        self._lock = threading.Lock()
        self._pending = None
        self.busy = False

    def submit(self, job):
        with self._lock:
            self._pending = job
            if self.busy:
                return
            self.busy = True
        SESSION_THREADS.submit(self._run)

    def _run(self):
        try:
            self._loop()
        except Exception:  # a pool's thread would keep it silently, and the session would never compute again
            logging.getLogger("camsim.explorer").exception("a session's computation failed")
            with self._lock:
                self._pending, self.busy = None, False

    def _loop(self):
        try:  # below the event loop's thread: it serves every page, and its callbacks are short
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), COMPUTE_NICE)
        except (AttributeError, OSError):  # not Linux: the slots still hold
            pass
        while True:
            with COMPUTE_SLOTS:  # the newest job is taken once a slot is free: a burst waits as one job
                with self._lock:
                    job, self._pending = self._pending, None
                    if job is None:
                        self.busy = False
                        return
                outcome = self._compute(job)
            with self._lock:
                superseded = self._pending is not None
            if not superseded:
                self._deliver(job, outcome)


def within_bands(wavelength, bands):
    """Whether ``wavelength`` (nm) lies within a scene's ``bands`` (nm, increasing), to half a band beyond either end.

    Examples
    --------
    >>> within_bands(704.0, [400.0, 410.0, 700.0]), within_bands(5000.0, [400.0, 700.0])
    (True, False)
    """
    bands = np.asarray(bands, float)
    if bands.size < 2:
        return bands.size == 1 and wavelength == bands[0]
    return bands[0] - (bands[1] - bands[0]) / 2 <= wavelength <= bands[-1] + (bands[-1] - bands[-2]) / 2


#: Fewest wavelength bands of an uploaded scene: the camera-monitor transform (Eq. 1.4) of fewer is singular.
MIN_UPLOAD_BANDS = 3


def full_scale(raw, camera=None):
    """The value of a full pixel of ``raw`` (digital units, its pedestal included): the ADC's full scale when
    quantized; unquantized, the level of ``camera``'s full well for an electron-level sensor (the value it
    saturates at, :func:`~camsim_core.metrics.exposure.saturation_level` above the black level), else 255 (the
    engine's display convention for the chapter's cameras). With 255 for every unquantized raw, imx174 at 0
    bits (its full well at about 4095) read "35.5 % of pixels are clipped" on a frame whose brightest pixel was
    341, and a mean level of 934 % of full scale.

    Examples
    --------
    >>> import camsim_core as cc
    >>> scene, cam = cc.load_scene("uniform"), cc.load_camera("imx174").replace(bits=None, exposure=0.05)
    >>> raw = cc.simulate(scene, cam, seed=0)
    >>> full_scale(raw), round(full_scale(raw, cam))
    (255.0, 4092)
    """
    if raw.full_scale:
        return float(raw.full_scale)
    from camsim_core.metrics.exposure import saturation_level

    well = saturation_level(camera)
    if well is None:
        return 255.0
    return float(np.max(np.asarray(raw.black_level, float))) + float(well)


def exposure_warnings(raw, camera=None):
    """Shares of clipped pixels (at full scale, or at ``camera``'s full well when its sensor saturates below
    full scale) and of pixels in the lowest 2 % of the digital range (:func:`full_scale`).

    ``raw`` is a CameraImage in digital units; returns ``(clipped, dark)`` as fractions. An unquantized raw of a
    camera in digital units (the chapter's, no full well) clips nowhere: its 255 is the display's convention
    (the DCS-200 unquantized at 4x the exposure read "100 % of pixels are clipped: lower the exposure", with the
    dE of the auto exposure).
    """
    from camsim_core.metrics.exposure import exposure_measures

    data = np.asarray(raw.data, float)
    full = full_scale(raw, camera)
    if raw.quantized:
        clipped = float(np.mean(data >= full - 0.5))
    else:
        clipped = 0.0  # nothing clips unquantized but a full well, whose pixels the engine counts, below
    if camera is not None:
        clipped = max(clipped, float(exposure_measures(raw, camera).clipped))
    dark = float(np.mean(data <= 0.02 * full))
    return clipped, dark


def mean_level(raw, camera=None):
    """The raw image's mean value as a fraction of its full scale (:func:`full_scale`)."""
    return float(np.mean(np.asarray(raw.data, float))) / full_scale(raw, camera)


def bright_end(raw, camera=None, percentile=99.5):
    """Where the frame's bright end lies: the ``percentile`` of its values above the black level, as a fraction of
    the range above it (:func:`full_scale`); what auto exposure sets (to 0.9 of the range).

    A frame is under-exposed when its bright end is low, not when many of its pixels are dark: a Macbeth chart's
    black surround put 38 % of the pixels in the lowest 2 % of the range right after Auto exposure, and the page
    said "under-exposed (try Auto exposure)".

    Examples
    --------
    >>> import camsim_core as cc
    >>> scene, cam = cc.load_scene("macbeth"), cc.load_camera("kodak-dcs200")
    >>> raw = cc.simulate(scene, cam, exposure=cc.auto_exposure(scene, cam), seed=0)
    >>> round(bright_end(raw), 1)
    0.9
    """
    black = float(np.max(np.asarray(raw.black_level, float)))
    top = float(np.percentile(np.asarray(raw.data, np.float32), percentile))
    return (top - black) / max(full_scale(raw, camera) - black, 1e-12)


_LABELS = {"noise_sigma": "noise sigma", "f_stop": "f-stop", "exposure": "exposure (s)", "distance": "distance (m)",
           "seed": "seed", "alpha": "alpha", "bits": "bits", "light": "light level (x the scene's)"}


def _range_text(bounds):
    """``[lo, hi]`` as a refusal says it: whole bounds in full (a seed's 9007199254740991, not 9.0072e+15)."""
    lo, hi = (b if isinstance(b, int) or b is None else f"{b:g}" for b in bounds)
    if hi is None:
        return f"[{lo}, no upper limit)"
    return f"[{lo}, {hi}]"


def parse_numbers_safe(text):
    try:
        return parse_numbers(text, "numbers")
    except ParameterError:
        return []
