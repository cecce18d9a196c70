"""The "Compare designs" tab: pinned camera designs side by side, A/B difference, a live sweep, a report.

The science is the engine's (:mod:`camsim_core.review`): a pinned design is
evaluated by :func:`~camsim_core.review.design.evaluate_design` (rendered
image, CIELAB and S-CIELAB maps and their statistics), a sweep by
:func:`~camsim_core.review.sweep.iter_sweep`, the A/B map by
:func:`~camsim_core.review.difference.ab_difference` and the report by
:func:`~camsim_core.review.report.report_html`. This module only keeps the
results and shows them.

* The designs compared are the pinned ones (at most four, in the state's
  ``pinned`` list, so a link or the JSON file carries them) and the live
  design, unless it equals a pinned one.
* Each pinned design is computed once per scene and kept (a small LRU of
  results, no pipelines: memory is bounded); a change of scene recomputes
  them in a background thread with a visible progress state. The live design
  is the explorer's own result: comparing costs it nothing.
* The plots are Bokeh figures made once (:class:`ImageView`, :class:`SweepPlot`,
  :class:`HistogramPlot`); new results replace their data in place. Image
  views share one coordinate system (scene widths: designs of other pixel
  counts line up), so their zoom and pan are linked; all dE maps use one
  colour mapper, so one scale.
* The sweep runs in background threads; points arrive on the page as they
  are computed; a click on a point loads that configuration into the live design.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import threading
import time
import weakref
from collections import OrderedDict
from functools import partial

import numpy as np
import panel as pn
from bokeh.models import ColorBar, ColumnDataSource, HoverTool, Image, ImageRGBA, LinearColorMapper, Range1d
from bokeh.palettes import Inferno256
from bokeh.plotting import figure

from camsim_core.cache import Pipeline
from camsim_core.errors import CamsimError
from camsim_core.review.design import (DESIGN_DEFAULTS, MAX_NAME, MAX_PINNED, QUALITY_LABELS, _SHARED,
                                       applied_parameters, check_pinned, differing_parameters, evaluate_design, quality_measures,
                                       result_from_pipeline)
from camsim_core.review.difference import ab_difference
from camsim_core.review.report import (DESIGN_COLOURS, design_colours, map_top, quality_cell, report_html, scale_top,
                                      shared_scale)
from camsim_core.review.sweep import SWEEP_PARAMETERS, check_sweep, iter_sweep

from .curves import CurvesPlot
from .safe_text import PlainText, html_text, md_text
from .shown import next_tick, now, off_the_loop, page_being_built
from . import state as state_module
from .state import short_repr
from .views import (ASPECT_TOLERANCE, _rgb_hover, fit_ranges, monitor_rgba, once, rgba32, screen_part,
                    when_page_ready)

__all__ = ["CompareView", "DesignStore", "compare_tab"]

LIVE = "live"
SLOTS = MAX_PINNED + 1
#: The image-quality measures every scene allows: their rows show "measuring..." while a design's are computed.
_ALWAYS_MEASURED = ("psnr_db", "ssim")
#: While pinned designs are computed, the tab shows those done at most this often (seconds): designs that come
#: quickly are shown together (each update lays the whole tab out again in the browser).
UPDATE_EVERY_S = 1.0
#: An image's frame is this wide (pixels), or narrower for a tall image ...
FRAME_WIDTH = 250
#: ... whose frame is this high at most.
MAX_FRAME_HEIGHT = 375


def _frame(aspect):
    """The frame (width, height) in pixels of images of ``aspect`` (height / width): ``FRAME_WIDTH`` wide, or
    ``MAX_FRAME_HEIGHT`` high. A frame of the images' shape is filled by them (a square frame left a wide
    scene's images between white bands)."""
    width, height = FRAME_WIDTH, FRAME_WIDTH * aspect
    if height > MAX_FRAME_HEIGHT:
        width, height = MAX_FRAME_HEIGHT / aspect, MAX_FRAME_HEIGHT
    return max(1, round(width)), max(1, round(height))


_WIN_COLOURS = np.array([[31, 119, 180], [255, 127, 14], [200, 200, 200]]) / 255.0


#: A row that goes on below when it does not fit the window's width (the rest of a row of fixed-size views).
_WRAP = {"flex-wrap": "wrap"}


def _aspect(image):
    """An image's height / width (1 for an empty one)."""
    h, w = np.shape(image)[:2]
    return h / w if h and w else 1.0


def _design_only(params):
    """A design's own settings, every one (defaults filled in), but what the comparison shares (scene, viewing...)."""
    return {k: v for k, v in dict(DESIGN_DEFAULTS, **params).items() if k not in _SHARED}


class DesignStore:
    """Evaluated designs by (scene, parameters): each computed once, at most ``size`` kept (least recently used out)."""

    def __init__(self, size=2 * MAX_PINNED):
        self.size = size
        self._items = OrderedDict()
        self._lock = threading.Lock()

    @staticmethod
    def key(scene_key, params):
        return (scene_key, json.dumps(_design_only(params), sort_keys=True))

    def get(self, scene_key, params):
        with self._lock:
            k = self.key(scene_key, params)
            if k in self._items:
                self._items.move_to_end(k)
                return self._items[k]
            return None

    def put(self, scene_key, params, result):
        with self._lock:
            self._items[self.key(scene_key, params)] = result
            while len(self._items) > self.size:
                self._items.popitem(last=False)

    def __len__(self):
        return len(self._items)

    @property
    def nbytes(self):
        return sum(r.nbytes for r in self._items.values())


class SharedDesigns:
    """The evaluated designs the server's sessions hold, by (scene, parameters): one session finds a design another
    has computed instead of computing it again.

    A class opens the link its teacher shares: each page restored the teacher's pinned designs by computing them
    anew (four designs of a frame-sized chart: 5-8 s a page, and 71 MB a design held by each page). Held weakly:
    a design stays here only while a session keeps it (nothing is kept for a server with no page open). Designs of
    shipped scenes and charts only: an uploaded scene is its session's alone (its key names the object).
    """

    def __init__(self):
        self._items = weakref.WeakValueDictionary()
        self._lock = threading.Lock()

    @staticmethod
    def shareable(scene_key):
        return "@" not in scene_key[0]

    def get(self, scene_key, params):
        if not self.shareable(scene_key):
            return None
        with self._lock:
            return self._items.get(DesignStore.key(scene_key, params))

    def put(self, scene_key, params, result):
        if self.shareable(scene_key):
            with self._lock:
                self._items[DesignStore.key(scene_key, params)] = result

    def __len__(self):
        return len(self._items)


class SharedViews:
    """What the tab shows of arrays several sessions share (shared designs' images and dE maps, an A/B pair of
    them), for every session of the server: ``(kind, arrays) -> value``, kept while the arrays live.

    Designs taken from :data:`SHARED_DESIGNS` are the same arrays in every page that shows them; their image
    views' data, histograms and A/B difference were made again by each page (0.7-1 s of a link's build with
    four designs of a frame-sized chart). Keyed by the arrays' identity, held through weak references: a value
    is found only while all of its arrays are alive and the same objects.

    Examples
    --------
    >>> views, a = SharedViews(), np.zeros(3)
    >>> views.get("sum", (a,)) is None
    True
    >>> views.put("sum", (a,), 0.0); views.get("sum", (a,))
    0.0
    >>> views.get("sum", (np.zeros(3),)) is None  # equal values, another array
    True
    >>> del a; len(views)  # the array freed, its entry with it
    0
    """

    def __init__(self):
        self._items = {}  # (kind, ids) -> (weak references to the arrays, value)
        self._lock = threading.Lock()

    def get(self, kind, arrays):
        with self._lock:
            held = self._items.get((kind, tuple(map(id, arrays))))
        if held is not None and all(ref() is a for ref, a in zip(held[0], arrays)):
            return held[1]
        return None

    def put(self, kind, arrays, value):
        key = (kind, tuple(map(id, arrays)))
        items = self._items

        def gone(ref):  # an array of the entry is freed: the entry goes with it (its id may be reused)
            held = items.get(key)
            if held is not None and any(r is ref for r in held[0]):
                items.pop(key, None)  # one dict operation: no lock needed (and none taken in a collection)

        refs = tuple(weakref.ref(a, gone) for a in arrays)
        with self._lock:
            items[key] = (refs, value)

    def __len__(self):
        return len(self._items)


#: What the Compare tabs show of shared designs (:class:`SharedViews`).
SHARED_VIEWS = SharedViews()

#: The designs held by the sessions of this server (:class:`SharedDesigns`).
SHARED_DESIGNS = SharedDesigns()


#: The title of an image view before it shows an image: not empty, so that the browser keeps the title's room (a
#: title set later on a figure made with an empty one was never drawn).
_NO_TITLE = " "


class ImageView:
    """One image of the tab: a Bokeh figure made once, whose image is replaced in place.

    The image lies in scene widths, from (0, 0) to (1, h / w), on ranges
    shared with the tab's other image views: they zoom and pan together and
    show the same part of the scene, whatever each design's pixel count. A
    colour image is sent as packed RGBA (:func:`~camsim_explorer.views.rgba32`);
    a dE map as its values, coloured in the browser by ``mapper`` (one mapper
    for the maps that share a scale, with its colour bar). An image larger
    than ``--max-view-side`` is sent as block means.

    Plain Bokeh, not HoloViews: a HoloViews plot is made anew for each new
    image and each new frame shape, and with four designs pinned that held
    the session's event loop for seconds (1.56 s making plots, 1.37 s sending
    images, when a link restored them).

    Parameters
    ----------
    x_range, y_range : bokeh.models.Range1d
        The ranges shared by the tab's image views (scene widths).
    aspect : float
        Height / width of the images it will show: the frame's shape (:func:`_frame`).
    css : str
        The figure's CSS class (tests and the page's styles find it by it).
    mapper : bokeh.models.LinearColorMapper, optional
        For a dE map: the mapper colouring its values (and drawn as its colour bar). Without it the view
        shows packed RGBA.

    Examples
    --------
    >>> from bokeh.models import Range1d
    >>> view = ImageView(Range1d(0, 1), Range1d(0, 0.5), 0.5, "camsim-example")
    >>> view.figure.frame_width, view.figure.frame_height
    (250, 125)
    >>> view.show(np.zeros((100, 200), np.uint32), "a black image")
    >>> view.source.data["dh"], view.figure.title.text
    ([0.5], 'a black image')
    """

    def __init__(self, x_range, y_range, aspect, css, mapper=None):
        width, height = _frame(aspect)
        self.aspect = aspect
        self.figure = figure(x_range=x_range, y_range=y_range, frame_width=width, frame_height=height,
                             tools="pan,wheel_zoom,reset,save", active_scroll="wheel_zoom",
                             toolbar_location="right", x_axis_type=None, y_axis_type=None, min_border=4,
                             outline_line_color=None, output_backend="canvas", title=_NO_TITLE, css_classes=[css])
        self.source = ColumnDataSource(dict(image=[np.zeros((2, 2), np.float32 if mapper else np.uint32)],
                                            x=[0.0], y=[0.0], dw=[1.0], dh=[1.0]))
        # one glyph model (a renderer's selection and muted copies are made by the browser): with fewer models
        # a view costs less to make and to add to the page
        if mapper is None:
            r = self.figure.add_glyph(self.source, ImageRGBA(image="image", x="x", y="y", dw="dw", dh="dh"))
            hover = HoverTool(renderers=[r], tooltips=[("monitor R, G, B", "@image{custom}")],
                              formatters={"@image": _rgb_hover()})
        else:
            r = self.figure.add_glyph(self.source, Image(image="image", x="x", y="y", dw="dw", dh="dh",
                                                         color_mapper=mapper))
            self.figure.add_layout(ColorBar(color_mapper=mapper, width=12, padding=3), "right")
            hover = HoverTool(renderers=[r], tooltips=[("dE", "@image{0.00}")])
        self.figure.add_tools(hover)
        self.pane = pn.pane.Bokeh(self.figure)

    def fit(self, aspect):
        """Give the frame the shape of images of ``aspect`` (height / width) unless it has it, within
        ``ASPECT_TOLERANCE`` (a sensor's crop); whether it changed. Called only for a view about to show such
        an image: a change of frame lays the tab out again in the browser."""
        if max(aspect / self.aspect, self.aspect / aspect) <= ASPECT_TOLERANCE:
            return False
        self.aspect = aspect
        width, height = _frame(aspect)
        self.figure.update(frame_width=width, frame_height=height)
        return True

    def show(self, image, title):
        """Show ``image`` (bottom row first: packed RGBA, or values for the mapper) under ``title``."""
        self.show_view(*screen_view(image), title)

    def show_view(self, view, shape, title):
        """Show ``view``, what :func:`screen_part` sends of an image of ``shape`` (h, w), under ``title``."""
        h, w = shape
        self.source.data = dict(image=[view], x=[0.0], y=[0.0], dw=[1.0], dh=[h / w])
        if self.figure.title.text != title:
            self.figure.title.text = title


def screen_view(image):
    """What an image view sends of ``image``: ``(view, (h, w))``, the image as it is, or as block means when
    larger than the server's ``--max-view-side`` (:func:`screen_part`), and the image's own shape."""
    return screen_part(image, state_module.LIMITS.max_view_side)[0], image.shape[:2]


def rendered_view(rendered):
    """:func:`screen_view` of a rendered image: its packed RGBA, bottom row first."""
    return screen_view(monitor_rgba(rendered))


def _ab_shown(a, b, metric):
    """The A/B difference of designs ``a`` and ``b`` and what its two views show (any thread): ``(ab, dE view,
    wins view, colour scale top, aspect)``, each view as :meth:`ImageView.show_view` takes it; a refusal's
    message (str) when the engine refuses the pair. On a frame-sized chart ~0.2 s: made off the event loop."""
    try:
        ab = ab_difference(a, b, metric)
    except CamsimError as exc:
        return str(exc)
    tie = a.error_map(metric) == b.error_map(metric)
    idx = np.where(tie, 2, np.where(ab["a_wins"], 0, 1))
    return (ab, de_view(ab["delta_e"]), screen_view(rgba32(_WIN_COLOURS[idx])), shared_scale([ab["delta_e"]]),
            _aspect(ab["delta_e"]))


def _same(a, b):
    """Whether arrays ``a`` and ``b`` show the same: the same array, or equal values of the same shape and type."""
    return a is b or (a is not None and b is not None and a.shape == b.shape and a.dtype == b.dtype
                      and np.array_equal(a, b))


def slot_order(shown, designs):
    """Which of the tab's design slots shows each design: ``designs`` is ``[(name, rendered image), ...]``,
    ``shown`` what each slot shows now (``(name, rendered image, dE map)`` or None). Returns the slot of each
    design, then the slots left free (hidden).

    A design a slot shows already (the same image array) keeps that slot, then one a slot showed under the same
    name (the live design after a move), then the first free slots. Designs are shown in their slots' order
    (:meth:`CompareView.designs`), so pinning the live design keeps it where it is: with the live design always
    first, each pin shifted every design by one slot and sent all their images again (8 images, ~9 MB, at the
    fourth pin of a frame-sized chart; moving the slots instead cost the browser more than sending them).

    Examples
    --------
    >>> a, b, c = np.zeros(1), np.zeros(1), np.zeros(1)
    >>> shown = [("live", a, None), ("d1", b, None), None, None, None]
    >>> slot_order(shown, [("d1", b), ("d2", a)])  # the live design pinned as d2: it stays in its slot
    [1, 0, 2, 3, 4]
    >>> slot_order(shown, [("live", c), ("d1", b)])  # a live move: the live design keeps its slot
    [0, 1, 2, 3, 4]
    """
    order, free = [None] * len(designs), list(range(len(shown)))
    for same in (lambda s, d: s[1] is d[1], lambda s, d: s[0] == d[0]):
        for i, design in enumerate(designs):
            if order[i] is None:
                j = next((j for j in free if shown[j] is not None and same(shown[j], design)), None)
                if j is not None:
                    order[i] = j
                    free.remove(j)
    for i in range(len(designs)):
        if order[i] is None:
            order[i] = free.pop(0)
    return order + free


def _ab_shared(a, b, metric):
    """:func:`_ab_shown`, made once per pair of designs' arrays for the whole server (:data:`SHARED_VIEWS`): a
    class opening one link shows the same pair."""
    arrays = (a.xyz, b.xyz, a.error_map(metric), b.error_map(metric))
    if not all(isinstance(x, np.ndarray) for x in arrays):
        return _ab_shown(a, b, metric)
    outcome = SHARED_VIEWS.get(("ab", metric), arrays)
    if outcome is None:
        outcome = _ab_shown(a, b, metric)
        if not isinstance(outcome, str):
            SHARED_VIEWS.put(("ab", metric), arrays, outcome)
    return outcome


def de_view(de):
    """:func:`screen_view` of a dE map: its values as float32, bottom row first (coloured in the browser)."""
    return screen_view(np.ascontiguousarray(np.asarray(de, np.float32)[::-1]))


class SweepPlot:
    """The sweep's curves, mean dE against the swept value, one per design (line and points in its colour).

    A :class:`~camsim_explorer.curves.CurvesPlot` (made once, its data
    replaced in place as points arrive: a plot made anew for each point took
    the event loop ~0.1-0.3 s a point). A click calls ``on_click(x, y)``
    with the data coordinates, on the event loop of ``doc`` (the session's
    document; default the current one).

    Examples
    --------
    >>> plot = SweepPlot()
    >>> plot.update([("dcs", "#1f77b4", (0.0, 2.0), (1.5, 2.5))], "noise sigma", "CIELAB")
    >>> plot.figure.title.text, list(plot.sources[0].data["y"])
    ('Mean CIELAB dE against noise sigma', [1.5, 2.5])
    """

    def __init__(self, on_click=None, doc=None):
        self.curves = CurvesPlot(frame_width=520, frame_height=240, legend_location="top_left", points=True,
                                 on_click=on_click, doc=doc)
        self.figure, self.legend = self.curves.figure, self.curves.legend
        self.sources, self.lines, self.points = self.curves.sources, self.curves.lines, self.curves.points

    def update(self, curves, x_label, metric):
        """Show ``curves``: (name, colour, xs, ys) each, for the swept parameter ``x_label`` and ``metric``."""
        self.curves.update(curves, title=f"Mean {metric} dE against {x_label}", x_label=x_label,
                           y_label=f"mean {metric} dE")


class HistogramPlot:
    """Overlaid dE histograms, one step curve per design with its mean (solid) and median (dashed).

    A Bokeh figure with a fixed set of renderers whose data, labels and
    visibility are updated in place (a live move re-draws in milliseconds).
    """

    EDGES = np.linspace(0, 30, 61)

    def __init__(self):
        from bokeh.models import ColumnDataSource, Legend, LegendItem, Span
        from bokeh.plotting import figure

        self.figure = figure(width=600, height=270, x_axis_label="dE (values above 30 in the last bin)",
                             y_axis_label="fraction of pixels", tools="pan,wheel_zoom,box_zoom,reset,save",
                             title="Overlaid CIELAB dE histograms (mean solid, median dashed)")
        self.sources = [ColumnDataSource(data={"x": [], "y": []}) for _ in range(SLOTS)]
        self.lines, self.means, self.medians, items = [], [], [], []
        for i, src in enumerate(self.sources):
            colour = DESIGN_COLOURS[i % len(DESIGN_COLOURS)]
            line = self.figure.step("x", "y", source=src, mode="after", color=colour, line_width=2, visible=False)
            mean = Span(location=0, dimension="height", line_color=colour, line_width=1, visible=False)
            median = Span(location=0, dimension="height", line_color=colour, line_width=1, line_dash="dashed",
                          visible=False)
            self.figure.add_layout(mean)
            self.figure.add_layout(median)
            self.lines.append(line)
            self.means.append(mean)
            self.medians.append(median)
            items.append(LegendItem(label="", renderers=[line], visible=False))
        self.legend = Legend(items=items, location="top_right")
        self.figure.add_layout(self.legend)

    @classmethod
    def stats(cls, values):
        """What the plot shows of one dE map: ``(fraction of pixels per bin, mean, median)`` of its finite
        values (values above 30 in the last bin), or None when it has none."""
        v = np.asarray(values, float)
        v = v[np.isfinite(v)]
        if not v.size:
            return None
        counts, _ = np.histogram(np.clip(v, 0, 30), cls.EDGES)
        return counts / v.size, float(np.mean(v)), float(np.median(v))

    def show(self, items, metric, colours=None):
        """Show ``items``, a list of (name, :meth:`stats` of its dE map), for ``metric`` ("CIELAB" or
        "S-CIELAB"), each design in its colour of ``colours`` (name -> colour; by position when not given)."""
        self.figure.title.text = f"Overlaid {metric} dE histograms (mean solid, median dashed)"
        colours = colours or design_colours([name for name, _ in items])
        for i in range(SLOTS):
            if i < len(items):
                colour = colours[items[i][0]]
                if self.lines[i].glyph.line_color != colour:
                    self.lines[i].glyph.line_color = colour
                    self.means[i].line_color = self.medians[i].line_color = colour
            stats = items[i][1] if i < len(items) else None
            shown = stats is not None
            if shown:
                fractions, mean, median = stats
                self.sources[i].data = {"x": self.EDGES[:-1], "y": fractions}
                self.means[i].location, self.medians[i].location = mean, median
                self.legend.items[i].label = {"value": f"{items[i][0]}: mean {mean:.2f}, median {median:.2f}"}
            else:
                self.legend.items[i].label = {"value": ""}
            for model in (self.lines[i], self.means[i], self.medians[i], self.legend.items[i]):
                model.visible = shown


#: A progress bar with nothing done is not drawn, but keeps its place: the page is not laid out again when it
#: fills (a change of ``visible`` lays the whole tab out, 0.3-0.45 s with designs pinned).
_EMPTY_BAR_HIDDEN = 'progress[value="0"] { visibility: hidden; }'


def _applied_text(value):
    """A table cell's text for a design's parameter: escaped, or a dash when it does not apply to the camera."""
    return "\u2014" if value is None else html_text(value)


class CompareView:
    """Everything on the Compare designs tab, following one :class:`~camsim_explorer.state.ExplorerState`."""

    def __init__(self, state, when_shown=now, store=None):
        self.state = state
        self.store = store or DesignStore()
        self.errors = {}  # pinned name -> message
        self.points = []  # SweepPoint list of the current sweep
        self.sweep_total = 0
        self._generation = 0
        self._sweep_cancel = None
        self._computing = False
        self.ab = None  # (name A, name B, ab_difference) shown
        self._ab_chosen = None  # the (A, B) names the tab chose itself, not the student
        self._ab_inputs = None  # the arrays the A/B map was computed from (identity)
        self._live = (None, None, None)  # (pipeline result, metric, DesignResult)
        self._pending = False
        self._doc = pn.state.curdoc
        self._built = False  # the plots are made when there is something to compare (a light page until then)
        self._prebuilt = None  # the plots made ahead by a worker thread (a dict for _ensure_plots)
        self._started = self._updated = 0.0  # when the designs computing began, when the tab was last updated
        self._computing_text = None  # the message saying designs are computing (replaced when they are done)
        # what the views show of each design's arrays, made ahead in the thread that computed them (the event loop
        # then only sends it): {(kind, id(array)): (array, value)}, kept for the designs shown
        self._display = {}
        self._when_shown = when_shown
        state.preparers.append(self._prepare_live)
        self._build_widgets()
        state.param.watch(self._on_pinned, ["pinned"])
        refresh, request_update = when_shown(self.refresh), when_shown(self._request_update)
        # designs computed while the tab is hidden (a link's, computing as its page loads) are shown when it is
        self._update_shown = when_shown(lambda: self._safely(self.update))
        # the light level is the scene's (the designs are computed on the scene under it): a design of another
        # level is another result (its dE was the old level's, kept and shown as the new level's)
        state.param.watch(lambda e: (self._sweep_outdated(), refresh()), ["scene", "viewing", "light"])
        state.param.watch(lambda e: request_update(), ["result", "metric"])
        state.param.watch(self._on_sweep, ["sweep"])
        self._on_pinned()
        if state.sweep:
            self.start_sweep()

    # -- widgets ---------------------------------------------------------------
    def _build_widgets(self):
        w = pn.widgets
        self.name_input = w.TextInput(label="Name of the pinned design", placeholder="the camera's name",
                                      css_classes=["w-pin-name"], width=220)
        self.pin_button = w.Button(label="Pin this design", color="primary", css_classes=["w-pin"], width=140)
        self.pin_button.on_click(lambda e: self.pin(self.name_input.value))
        self.pinned_select = w.Select(label="Pinned design", options=[], css_classes=["w-pinned"], width=200)
        self.rename_input = w.TextInput(label="New name", css_classes=["w-rename"], width=180)
        self.rename_button = w.Button(label="Rename", css_classes=["w-rename-button"], width=90)
        self.rename_button.on_click(lambda e: self.rename(self.pinned_select.value, self.rename_input.value))
        self.unpin_button = w.Button(label="Unpin", css_classes=["w-unpin"], width=90)
        self.unpin_button.on_click(lambda e: self.unpin(self.pinned_select.value))
        self.message = pn.pane.Markdown("", css_classes=["camsim-compare-message"], sizing_mode="stretch_width")
        # always in the page, empty when nothing is computed: a change of its visibility made the browser lay the
        # whole tab out again (0.3-0.45 s with pinned designs shown, twice a pin), a change of its value does not
        self.progress = pn.indicators.Progress(label="designs", value=0, max=1, width=300,
                                               css_classes=["camsim-compare-progress"], stylesheets=[_EMPTY_BAR_HIDDEN])
        self.table = pn.pane.HTML("", css_classes=["camsim-compare-table"], sizing_mode="stretch_width")
        self.status = PlainText("", css_classes=["camsim-compare-status"], sizing_mode="stretch_width",
                                styles={"font-size": "10px", "white-space": "pre-wrap", "word-break": "break-all"},
                                stylesheets=["pre { white-space: pre-wrap; word-break: break-all; }"])
        self.show_status = w.Checkbox(label="Show the comparison's status (JSON, for scripts)", value=False,
                                      css_classes=["w-compare-status"])
        self.status.visible = self.show_status  # a reference: shown while the box is ticked
        self.a_select = w.Select(label="A", options=[], css_classes=["w-ab-a"], width=180)
        self.b_select = w.Select(label="B", options=[], css_classes=["w-ab-b"], width=180)
        self.a_select.param.watch(lambda e: self.update_ab(), "value")
        self.b_select.param.watch(lambda e: self.update_ab(), "value")
        self.ab_text = pn.pane.Markdown("", css_classes=["camsim-ab-text"], sizing_mode="stretch_width")
        self.sweep_parameter = w.Select(label="Sweep parameter", options=list(SWEEP_PARAMETERS), value="noise_sigma",
                                        css_classes=["w-sweep-parameter"], width=200)
        self.sweep_values = w.TextInput(label="Values", value="0, 2, 4, 6, 8", css_classes=["w-sweep-values"], width=220)
        self.sweep_button = w.Button(label="Run sweep", color="primary", css_classes=["w-sweep-run"], width=120)
        self.sweep_button.on_click(lambda e: self.request_sweep(self.sweep_parameter.value, self.sweep_values.value))
        self.sweep_progress = pn.indicators.Progress(label="sweep", value=0, max=1, width=300,
                                                     css_classes=["camsim-sweep-progress"], stylesheets=[_EMPTY_BAR_HIDDEN])
        self.sweep_message = pn.pane.Markdown("Pin designs, choose a parameter and values, run: one curve per design. "
                                              "Click a point to load that configuration.",
                                              css_classes=["camsim-sweep-message"], sizing_mode="stretch_width")
        self.views = pn.Column(sizing_mode="stretch_width")  # the plots, made on first use
        self.sweep_area = pn.Column()
        self.download = w.FileDownload(callback=self.report_bytes, filename="camsim-report.html",
                                       label="Download the report (HTML)", color="success",
                                       css_classes=["w-report"], width=260)

    def _ensure_plots(self, aspect=None):
        """Put the plots on the tab (made once: by the thread that computed the first pinned designs, or here),
        image frames of ``aspect`` (height / width; None: square until the first images come)."""
        if self._built:
            return
        self._built = True
        plots, self._prebuilt = self._prebuilt, None
        self.__dict__.update(plots or self._make_plots(1.0 if aspect is None else aspect))
        # the design slots join the page as designs first take them (:meth:`_place_slots`): a hidden slot's two
        # figures are still built, laid out and drawn by the browser (8 of the tab's 14 at the first pin)
        self.slot_row = pn.Row(styles=_WRAP)
        self.ab_row = pn.Row(styles=_WRAP)  # the A/B difference's two views, on the page with the first difference
        # rows that wrap: five designs, or a histogram beside a wide table, do not fit a 1366 px window's width
        self.views[:] = [self.slot_row, pn.Row(self.hist_pane, self.table, styles=_WRAP),
                         pn.pane.Markdown("### A/B difference"), pn.Row(self.a_select, self.b_select), self.ab_text,
                         self.ab_row]
        self.sweep_area[:] = [self.sweep_pane]

    def _prebuild(self, aspect):
        """Make the plots ahead, in a worker thread, for :meth:`_ensure_plots` to show: the Bokeh models of a
        dozen figures take ~0.4 s to make, which on the event loop held every session's page as long."""
        if not self._built and self._prebuilt is None:
            self._prebuilt = self._make_plots(aspect)

    def _make_plots(self, aspect=1.0):
        """The tab's plots, as attributes of the view (a dict); touches nothing shown (any thread)."""
        x_range, y_range = Range1d(0, 1), Range1d(0, aspect)  # every image view on them (zoom and pan linked)
        mapper = LinearColorMapper(palette=Inferno256, low=0, high=20.0)  # one scale for every design's map
        ab_mapper = LinearColorMapper(palette=Inferno256, low=0, high=20.0)
        xy = (x_range, y_range)
        render_views = [ImageView(*xy, aspect, "camsim-compare-rendered") for _ in range(SLOTS)]
        de_views = [ImageView(*xy, aspect, "camsim-compare-de", mapper) for _ in range(SLOTS)]
        histogram = HistogramPlot()
        histogram.figure.css_classes = ["camsim-compare-hist"]  # on the figure: a Bokeh pane does not pass it on
        sweep_plot = SweepPlot(on_click=self.on_tap, doc=self._server_doc())
        sweep_plot.update([], SWEEP_PARAMETERS.get("noise_sigma", "noise_sigma"), self.state.metric)
        sweep_plot.figure.css_classes = ["camsim-sweep-plot"]
        return dict(
            x_range=x_range, y_range=y_range, mapper=mapper, ab_mapper=ab_mapper,
            _fitted=None,  # (scene key, image aspect) the ranges show whole
            render_views=render_views, de_views=de_views,
            _shown=[None] * SLOTS,  # (name, rendered, dE map) each slot shows
            ab_views=[ImageView(*xy, aspect, "camsim-ab-de", ab_mapper), ImageView(*xy, aspect, "camsim-ab-wins")],
            # one column per design slot, shown or hidden as a whole
            slots=[pn.Column(r.pane, d.pane, visible=False, css_classes=["camsim-compare-slot"])
                   for r, d in zip(render_views, de_views)],
            histogram=histogram, hist_pane=pn.pane.Bokeh(histogram.figure),
            sweep_plot=sweep_plot, sweep_pane=pn.pane.Bokeh(sweep_plot.figure))

    def _fit_view(self, view, aspect):
        """Fit ``view``'s frame to images of ``aspect``; the shared ranges to the whole image when the scene or
        the images' shape changed (a live move keeps the user's zoom, and so does a view taking its first design
        of the shape the ranges already show: the live design coming back into a slot of its own)."""
        view.fit(aspect)
        key = (self._scene_key()[:2], aspect)  # a new light level keeps the user's zoom
        if self._fitted is None or self._fitted[0] != key[0] or (
                max(aspect / self._fitted[1], self._fitted[1] / aspect) > ASPECT_TOLERANCE):
            self._fitted = key
            fit_ranges(self.x_range, self.y_range, 1.0, aspect, view.figure.frame_width / view.figure.frame_height)

    # -- pinning -----------------------------------------------------------------
    def pin(self, name=""):
        """Pin the live design under ``name`` (default: its camera); refused past four pinned designs."""
        pinned = list(self.state.pinned)
        if len(pinned) >= MAX_PINNED:
            self.message.object = (f"**At most {MAX_PINNED} pinned designs**: unpin one to pin another "
                                   "(this bounds the memory and the time of a comparison).")
            return False
        names = {p["name"] for p in pinned}
        base = (name or "").strip() or self.state.camera
        if len(base) > MAX_NAME:  # refused, not cut: the box keeps the text for the user to shorten
            self.message.object = (f"**Refused:** the name of a pinned design takes at most {MAX_NAME} characters "
                                   f"(got {len(base)}).")
            return False
        unique, k = base, 2
        while unique in names:
            unique, k = f"{base[:MAX_NAME - 4]} {k}", k + 1
        entry = {"name": unique, "params": _design_only(self.state.design_params())}
        self.message.object = ""
        self.name_input.value = ""
        self.state.pinned = pinned + [entry]
        return True

    def unpin(self, name):
        self.state.pinned = [p for p in self.state.pinned if p["name"] != name]

    def rename(self, old, new):
        new = (new or "").strip()
        names = [p["name"] for p in self.state.pinned]
        if old not in names:
            return False
        if not new or len(new) > MAX_NAME or (new in names and new != old):
            self.message.object = (f"**Refused:** a pinned design needs a unique, non-empty name of at most {MAX_NAME} "
                                   f"characters (got {md_text(short_repr(new, 40))}).")
            return False
        self.state.pinned = [dict(p, name=new) if p["name"] == old else p for p in self.state.pinned]
        self.rename_input.value = ""
        return True

    def _on_pinned(self, *events):
        try:
            checked = check_pinned(list(self.state.pinned))
        except CamsimError as exc:
            self.state.message = f"Pinned designs refused: {exc}"
            self.state.pinned = []
            return
        if checked != list(self.state.pinned):
            self.state.pinned = checked  # normalised (full parameters); comes back here once
            return
        names = [p["name"] for p in checked]
        self.pinned_select.options = names
        if names and self.pinned_select.value not in names:
            self.pinned_select.value = names[-1]
        self.refresh()

    # -- computing pinned designs -------------------------------------------------
    def _shared(self):
        """What the designs share: the scene, its light level and how the rendered images are viewed (S-CIELAB)."""
        return {"scene": self.state.scene, "light": self.state.light, "viewing": self.state.viewing}

    def _scene_key(self):
        """(scene, viewing, light level): what a stored design was computed on, besides its own parameters."""
        name = self.state.scene
        # an upload by the object read (not the one under the light level, made anew at each level: a new key,
        # and every design computed again, at every return to a level)
        held = self.state._uploads.get(name) if name.startswith(("upload:", "file:")) else None
        scene = name if held is None else f"{name}@{id(held)}"
        return (scene, self.state.viewing, float(self.state.light))

    def refresh(self):
        """Compute the pinned designs not in the store (in a background thread on a server); then update."""
        self._generation += 1
        generation = self._generation
        key, shared = self._scene_key(), self._shared()  # what the designs are computed on, read once, here
        building = page_being_built(self._server_doc())
        if building:
            self._take_shared(key)
        missing = [p for p in self.state.pinned if self.store.get(key, p["params"]) is None]
        if building and missing:
            # a link's designs to compute: the plots go with the page's first document, made in the builder thread
            # (made later on the event loop, they and their addition to the page held every page 1-2 s)
            self._ensure_plots()
        if not missing:
            self._computing = False
            self.progress.value = 0
            self.update()
            return
        try:
            scene = self.state.scene_object()
        except CamsimError as exc:
            self.message.object = f"**Refused:** {md_text(exc)}"
            return
        self._computing = True
        self._started = time.monotonic()
        self.progress.max, self.progress.value = len(missing), 0
        self.message.object = self._computing_text = (f"Computing {len(missing)} pinned design(s) on "
                                                      f"{md_text(self.state.scene)}...")
        # what the live design's pipeline has computed (shared arrays, no copy): a design pinned as it is shown
        # re-runs only the steps the page has not (S-CIELAB, the quality measures), not its whole simulation
        # (a pin took 5-12 s, the whole pipeline again)
        live = self.state.pipeline.snapshot() if self.state.result is not None and not self.state.computing else None
        if self._server_doc() is None:
            self._compute(missing, scene, key, generation, live, shared)
        else:
            self._start_worker(self._compute, (missing, scene, key, generation, live, shared), "camsim-compare")

    def _take_shared(self, key):
        """The pinned designs another session holds (:data:`SHARED_DESIGNS`), into this page's store now: a page
        built for a link (in the builder thread) then has them in its first document, plots and all, and its
        browser gets them with the page (made after the page was sent, they held the event loop 1.5-2.5 s a link
        and came 2-3 s after the page)."""
        metric = self.state.metric
        for p in self.state.pinned:
            if self.store.get(key, p["params"]) is None:
                result = SHARED_DESIGNS.get(key, {**p["params"], **self._shared()})
                if result is not None:
                    self._prepare_design(result, metric)
                    self.store.put(key, p["params"], result)

    def _compute(self, missing, scene, key, generation, live=None, shared=None):
        """Compute the designs ``missing`` (shown as each is done), then their image-quality measures.

        A design is shown once simulated and scored (its images, dE maps and numbers); its image-quality
        measures (SSIM, PSNR, the chart's MTF50, SNR or CIEDE2000: 0.3-0.7 s a design, more than the rest of a
        pinned design) follow in the same thread, and the table fills in when they are done. A design is
        offered to other sessions once measured. Measures of designs computed here are taken even if the
        pinned designs change meanwhile: each holds its pipeline result until measured.
        """
        pipeline = Pipeline()  # one per thread; its results are exactly a fresh run's (camsim_core.cache)
        if live is not None:
            pipeline.start_from(live)
        later = []  # (params, design) measured once every design is shown
        for i, p in enumerate(missing):
            if generation != self._generation:
                break
            # the scene, light and viewing ``scene`` and ``key`` were made with (read again here, a light changed
            # meanwhile was recorded with designs computed on the scene under the old one)
            params = {**p["params"], **(shared or self._shared())}
            try:
                result = SHARED_DESIGNS.get(key, params)  # another page's (a link's designs, pinned by who shared it)
                if result is None:
                    result = evaluate_design(params, p["name"], scene=scene, pipeline=pipeline, quality="later")
                    later.append((params, result))
                # once: the plots the first update will show, made before the design is stored (an update on the
                # event loop that finds a design finds its plots made)
                self._prebuild(_aspect(result.rendered))
                self._prepare_design(result, self.state.metric)
                self.store.put(key, params, result)
                self.errors.pop(p["name"], None)
            except CamsimError as exc:
                self.errors[p["name"]] = str(exc)
            except Exception as exc:  # never a dead page
                self.errors[p["name"]] = f"{type(exc).__name__}: {exc}"
            self._schedule(partial(self._progress, generation, i + 1, len(missing)))
        in_worker = self._server_doc() is not None  # a thread of its own (else the caller's: a test, a notebook)
        for params, result in later:
            try:
                result.measure_quality(background=in_worker)
            except Exception:  # a measure that fails leaves its cells "n/a" (logged), never the design unshown
                import logging

                logging.getLogger("camsim.compare").exception("image-quality measures of a pinned design failed")
                result.quality_inputs = None
            SHARED_DESIGNS.put(key, params, result)
        if later:
            self._schedule(self._measured)

    def _measured(self):
        """The image-quality measures of designs just computed are in: the table (and status) show them."""
        if not self._computing:
            self._update_shown()

    def _start_worker(self, target, args, name):
        """Run ``target(*args)`` in a thread of its own, started once this page's session is live.

        A link's pinned designs and sweep start while its page is being built, before Bokeh has made the
        page's session: callbacks a worker added to the document meanwhile were lost or ran out of order (the
        last design's progress among them: the tab said "computing" for ever, one link in three when the
        designs were at hand). Such a worker starts on the session's first tick.
        """
        start = threading.Thread(target=target, args=args, daemon=True, name=name).start
        doc = self._server_doc()
        if page_being_built(doc):
            doc.add_next_tick_callback(start)
        else:
            start()

    def _progress(self, generation, done, total):
        if generation != self._generation:
            return
        self.progress.value = done
        if done == total:
            self._computing = False
            self.progress.value = 0
            refused = "; ".join(f"**{md_text(n)}** refused: {md_text(m)}" for n, m in self.errors.items())
            # the computing note gives way to the designs' refusals (or nothing); a message the user got meanwhile
            # (a name refused while the designs computed) stays in sight
            if refused or self.message.object == self._computing_text:
                self.message.object = refused
        # the designs shown together when they come quickly (each update lays the tab out again in the browser),
        # one by one when each takes a while
        if done == total or time.monotonic() - max(self._started, self._updated) >= UPDATE_EVERY_S:
            self._update_shown()

    def _safely(self, fn):
        """Run a view update from a callback; a failure shows a message (and goes to the log), never a dead tab."""
        try:
            fn()
        except Exception as exc:
            import logging

            logging.getLogger("camsim.compare").exception("compare tab update failed")
            self.message.object = f"**Display failed:** {type(exc).__name__}: {md_text(exc)}"

    def _server_doc(self):
        doc = self._doc
        return doc if doc is not None and doc.session_context is not None else None

    def _schedule(self, fn):
        doc = self._server_doc()
        if doc is None:
            fn()
            return

        def closed():  # the session closed while a worker thread was computing: nothing to show
            if self._sweep_cancel is not None:
                self._sweep_cancel.set()

        # designs' arrays not kept by the callback once shown (``once``); and not shown between the page's first
        # pull and its "document ready", where Panel drops changes (a link's designs found at hand come then)
        next_tick(doc, partial(when_page_ready, once(fn)), closed)

    # -- the designs shown ---------------------------------------------------------
    def _request_update(self):
        """After a live move: update once the explorer's own views have been sent (next tick on a server)."""
        doc = self._server_doc()
        if doc is None:
            self.update()
        elif not self._pending:
            self._pending = True
            self._schedule(self._deferred_update)

    def _deferred_update(self):
        self._pending = False
        self._safely(self.update)

    def live_result(self):
        """The live design as a DesignResult (the explorer's own result; made once per result)."""
        return self._live_of(self.state.result, self.state.metric)

    def _live_of(self, res, metric):
        if res is None:
            return None
        held = self._live
        if held[0] is res and held[1] == metric:
            return held[2]
        try:
            # without the image-quality measures (about 45 ms on the default scene): the live design keeps its
            # speed; a pinned design has them (computed once, in the background)
            live = result_from_pipeline(res, {**self.state.design_params()}, LIVE, self.state.processing(),
                                        quality=False)
        except CamsimError:
            live = None
        self._live = (res, metric, live)
        return live

    # -- what the views show, made ahead --------------------------------------------
    #: How each kind of display product is made from its array.
    _MAKERS = {"render": rendered_view, "de": de_view, "hist": HistogramPlot.stats, "top": map_top}

    def _prepared(self, kind, array):
        """``_MAKERS[kind](array)``, made once per array (identity): by :meth:`_prepare_design` in the thread that
        computed the design, or here."""
        key = (kind, id(array))
        held = self._display.get(key)
        if held is not None and held[0] is array:
            return held[1]
        value = SHARED_VIEWS.get(kind, (array,))
        if value is None:
            value = self._MAKERS[kind](array)
            SHARED_VIEWS.put(kind, (array,), value)
        self._display[key] = (array, value)
        return value

    def _de_map(self, r, metric):
        de = r.error_map(metric)
        return de if de is not None else r.delta_e

    def _prepare_design(self, r, metric):
        """Everything the views show of design ``r`` for ``metric``, made now (any thread): its image views'
        data, its histogram and its part of the colour scale. A 1.1-megapixel chart's took the event loop
        ~60-100 ms a design at each update."""
        de = self._de_map(r, metric)
        for kind, array in (("render", r.rendered), ("de", de), ("hist", de), ("top", de)):
            if array is not None and np.size(array):
                try:
                    self._prepared(kind, array)
                except Exception:  # made ahead only: the update makes it again on the loop and says why there
                    pass

    def _prepare_live(self, res):
        """In the session's computing thread, with a new result (``ExplorerState.preparers``): the live design
        and what the tab shows of it, when the tab shows designs (the event loop then only sends them)."""
        if res is None or res.raw is None or not (self._built or self.state.pinned):
            return
        if not getattr(self._when_shown, "shown", True):
            return
        metric = self.state.metric
        live = self._live_of(res, metric)
        if live is not None:
            self._prepare_design(live, metric)

    def _forget_display(self, results, metric):
        """Drop what is held for arrays no longer shown."""
        kept = {id(a) for r in results for a in (r.rendered, self._de_map(r, metric))}
        for key in [k for k in self._display if k[1] not in kept]:
            self._display.pop(key, None)

    def designs(self):
        """The DesignResults compared, in the order the tab shows them: the live design (unless equal to a pinned
        one) and the pinned ones, each design where its slot is (:func:`slot_order`: a design keeps its place, the
        live design takes the first free one; before any is shown, the live design first)."""
        return self._in_slot_order(self._designs())

    def _in_slot_order(self, results):
        if not self._built:
            return results
        order = slot_order(self._shown, [(r.name, r.rendered) for r in results])[:len(results)]
        return [r for _, r in sorted(zip(order, results), key=lambda pair: pair[0])]

    def _designs(self):
        key = self._scene_key()
        # a stored result carries the name it was computed under: show the current one (a shallow copy)
        pinned = [dataclasses.replace(r, name=p["name"]) for p, r in
                  ((p, self.store.get(key, p["params"])) for p in self.state.pinned) if r is not None]
        out = []
        live_params = _design_only(self.state.design_params())
        if not any(_design_only(p["params"]) == live_params for p in self.state.pinned):
            live = self.live_result()
            if live is not None:
                out.append(live)
        return out + pinned

    def update(self):
        """Show the current designs: images, histograms, table, A/B choices, status."""
        self._updated = time.monotonic()
        results = self.designs()
        metric = self.state.metric
        maps = [r.error_map(metric) for r in results if r.error_map(metric) is not None]
        top = scale_top([self._prepared("top", m) for m in maps if np.size(m)]) if maps else 20.0
        self.table.object = self._table(results)
        if not (self._built or self.state.pinned):  # only the live design: its table, no plots yet
            self.views[:] = [self.table]
            self._status(results, top)
            return
        doc = self._server_doc()
        # held: the new plots first, then their data, in order (see ``views.held``); frozen while the plots are put
        # on the page: the document's models are listed again once, not after each change (Bokeh walks the whole
        # page's models each time; frozen when nothing is added, it would walk them once for nothing)
        adding = doc is not None and not self._built
        with pn.io.hold(doc), (doc.models.freeze() if adding else contextlib.nullcontext()):
            self._ensure_plots(_aspect(results[0].rendered) if results else None)
            if self.mapper.high != top:
                self.mapper.high = top  # every design's dE map recoloured in the browser, no map sent again
            order = slot_order(self._shown, [(r.name, r.rendered) for r in results])
            for i, j in enumerate(order):
                if i < len(results):
                    r = results[i]
                    aspect = _aspect(r.rendered)
                    self._fit_view(self.render_views[j], aspect)
                    self.de_views[j].fit(aspect)
                    de = self._de_map(r, metric)
                    # a live move re-sends the live design's images only; the arrays themselves are compared
                    # (identity), never a reused id
                    old = self._shown[j] or (None, None, None)
                    if old[1] is not r.rendered:
                        self.render_views[j].show_view(*self._prepared("render", r.rendered), f"{r.name}: rendered")
                    elif old[0] != r.name:
                        self.render_views[j].figure.title.text = f"{r.name}: rendered"
                    # the scale the designs' maps share (the report's for this metric): said, as the Results tab says its own
                    label = f"{r.name}: {metric if r.error_map(metric) is not None else 'CIELAB'} dE, 0 to {top:g}"
                    if not _same(old[2], de):
                        self.de_views[j].show_view(*self._prepared("de", de), label)
                    elif self.de_views[j].figure.title.text != label:
                        self.de_views[j].figure.title.text = label
                    self._shown[j] = (r.name, r.rendered, de)
                else:
                    self._shown[j] = None
                if self.slots[j].visible != (i < len(results)):
                    self.slots[j].visible = i < len(results)
            self._place_slots(order[:len(results)])
            self.histogram.show([(r.name, self._prepared("hist", self._de_map(r, metric))) for r in results], metric,
                                self.colours(results))
        self._forget_display(results, metric)
        names = [r.name for r in results]
        a, b = self.a_select.value, self.b_select.value
        self.a_select.options = names
        self.b_select.options = names
        if len(names) >= 2:
            self.a_select.value = a if a in names else names[0]
            shape = next(r.shape for r in results if r.name == self.a_select.value)
            others = [r for r in results if r.name != self.a_select.value]
            # B chosen here (not by the student) is chosen again as designs come: the first other design of A's
            # geometry (the A/B difference needs one), else the first other
            ours = (a, b) == self._ab_chosen and not any(r.name == b and r.shape == shape for r in others)
            if ours or not (b in names and b != self.a_select.value):
                self.b_select.value = next((r.name for r in others if r.shape == shape), others[0].name)
                self._ab_chosen = (self.a_select.value, self.b_select.value)
        self.update_ab(results)
        self._status(results, top)

    def _place_slots(self, used):
        """Put on the page the design slots up to the last of ``used`` (slot indices showing a design), in their
        order; a slot once placed stays (hidden when free), so a design never moves to another slot's place."""
        count = max(used, default=-1) + 1
        if count > len(self.slot_row.objects):
            self.slot_row.objects = list(self.slots[:count])

    def _table(self, results):
        if not results:
            return "<p>No design yet.</p>"
        differ = differing_parameters([r.params for r in results], skip=_SHARED)
        head = "".join(f"<th>{html_text(r.name)}</th>" for r in results)
        applied = [applied_parameters(r.params) for r in results]  # a parameter the camera does not use: a dash
        rows = [f"<tr><th>{html_text(k)}</th>" + "".join(f"<td>{_applied_text(p[k])}</td>" for p in applied) + "</tr>"
                for k in differ]
        if any(r.flags for r in results):  # a black, empty or clipped frame: its scores are not good ones
            cells = "".join(f'<td class="flag" style="color:#c00000">{html_text("; ".join(r.flags))}</td>' if r.flags
                            else "<td></td>" for r in results)
            rows.append(f'<tr class="measure" data-measure="exposure"><th>exposure warning</th>{cells}</tr>')
        for metric, key in (("dE", "cielab"), ("S-CIELAB dE", "scielab")):
            for stat, label in (("mean", "mean"), ("median", "median"), ("p95", "95th pct")):
                cells = "".join(
                    f'<td class="num" data-value="{r.measures[key][stat]!r}">{r.measures[key][stat]:.2f}</td>'
                    if key in r.measures else "<td>n/a</td>" for r in results)
                rows.append(f'<tr class="measure" data-measure="{key}-{stat}"><th>{label} {metric}</th>{cells}</tr>')
        pending = [r.quality_pending for r in results]
        for key, label in QUALITY_LABELS.items():  # the image-quality measures the scene allows
            if not any(key in r.quality for r in results) and not (any(pending) and key in _ALWAYS_MEASURED):
                continue
            cells = "".join('<td class="measuring">measuring...</td>' if waiting else quality_cell(r, key)
                            for r, waiting in zip(results, pending))
            rows.append(f'<tr class="measure" data-measure="{key}"><th>{label}</th>{cells}</tr>')
        style = ("<style>table.cmp{border-collapse:collapse} table.cmp th, table.cmp td{border:1px solid #ccc;"
                 "padding:2px 8px} td.num{text-align:right}</style>")
        note = "" if differ else "<p>The designs have the same parameters.</p>"
        if any(r.name == LIVE for r in results) and any(r.quality for r in results):
            note += "<p>Image-quality measures are computed for pinned designs: pin the live design to measure it.</p>"
        return (f'{style}<table class="cmp"><thead><tr><th>parameter / measure</th>{head}</tr></thead>'
                f"<tbody>{''.join(rows)}</tbody></table>{note}")

    # -- A/B -----------------------------------------------------------------------
    def update_ab(self, results=None):
        if not self._built:
            return
        results = results if results is not None else self.designs()
        by = {r.name: r for r in results}
        a, b = by.get(self.a_select.value), by.get(self.b_select.value)
        if a is None or b is None or a is b:
            self.ab, self._ab_inputs = None, None
            self.ab_text.object = "Pin a design to compare two designs pixel by pixel."
            return
        metric = self.state.metric if (a.error_map(self.state.metric) is not None and
                                       b.error_map(self.state.metric) is not None) else "CIELAB"
        inputs = (a.name, b.name, metric, a.rendered, b.rendered, a.error_map(metric), b.error_map(metric))
        if self._ab_inputs is not None and inputs[:3] == self._ab_inputs[:3] and all(
                x is y for x, y in zip(inputs[3:], self._ab_inputs[3:])):
            return  # the same two images, shown or being made: nothing to recompute (a move A and B do not show)
        self.ab, self._ab_inputs = None, inputs

        def made(outcome):  # on the page's next tick: shown unless another pair was chosen meanwhile
            if self._ab_inputs is inputs:
                self._show_ab(a, b, metric, outcome)

        # and shown once the tab is: a difference made after the student left the tab waits, as the tab's other
        # updates do (its views are out of the page meanwhile)
        shown = lambda outcome: self._when_shown(lambda: made(outcome))()  # noqa: E731
        if off_the_loop(lambda: _ab_shared(a, b, metric), shown, lambda exc: f"{type(exc).__name__}: {exc}"):
            self.ab_text.object = "Computing the A/B difference..."

    def _show_ab(self, a, b, metric, outcome):
        """Show an A/B difference made by :func:`_ab_shown` (or why there is none)."""
        if isinstance(outcome, str):
            self.ab_text.object = f"**A/B not available:** {md_text(outcome)}"
            return
        ab, de, wins, top, aspect = outcome
        self.ab = (a.name, b.name, ab)
        with pn.io.hold(self._server_doc()):  # after the plots, if this update made them
            if not self.ab_row.objects:  # before the first difference they were empty frames
                self.ab_row[:] = [v.pane for v in self.ab_views]
            self._fit_view(self.ab_views[0], aspect)
            self.ab_views[1].fit(aspect)
            if self.ab_mapper.high != top:
                self.ab_mapper.high = top
            self.ab_views[0].show_view(*de, "A/B: dE between the renderings")
            self.ab_views[1].show_view(*wins, "closer to ideal: A blue, B orange")
        m = ab["measures"]
        a_name, b_name = md_text(a.name), md_text(b.name)
        self.ab_text.object = (f"dE\\*ab between **{a_name}** and **{b_name}**: mean {m['mean']:.2f}, median "
                               f"{m['median']:.2f}. **{a_name}** is closer to the ideal image ({metric}) on "
                               f"{100 * ab['a_wins_fraction']:.1f} % of the pixels, **{b_name}** on "
                               f"{100 * ab['b_wins_fraction']:.1f} %.")

    # -- the sweep -----------------------------------------------------------------
    def request_sweep(self, parameter, values):
        """Set the state's sweep from the widgets (which starts it); a bad definition shows a message."""
        try:
            sweep = check_sweep({"parameter": parameter, "values": values})
        except CamsimError as exc:
            self.sweep_message.object = f"**Refused:** {md_text(exc)}"
            return False
        if sweep == self.state.sweep:
            self.start_sweep()
        else:
            self.state.sweep = sweep
        return True

    def _on_sweep(self, event):
        if self.state.sweep:
            try:
                self.state.sweep = check_sweep(self.state.sweep)
            except CamsimError as exc:
                self.state.message = f"Sweep refused: {exc}"
                self.state.sweep = None
                return
            self.start_sweep()

    def sweep_designs(self):
        """(name, params) of the designs swept: the pinned ones, or the live one when none is pinned."""
        if self.state.pinned:
            return [(p["name"], {**p["params"], **self._shared()}) for p in self.state.pinned]
        return [(LIVE, self.state.design_params())]

    def _sweep_outdated(self):
        """The scene, its light or the viewing changed: the sweep's points were of the old one (a report mixed them
        with designs computed on the new one). Dropped, and said; Run computes them again."""
        if not self.points and self._sweep_cancel is None:
            return
        if self._sweep_cancel is not None:
            self._sweep_cancel.set()
            self._sweep_cancel = None  # points still coming are dropped (``_add_point``)
        self.points = []
        self.sweep_total = 0
        self.sweep_progress.value = 0
        self.sweep_message.object = "The scene, its light or the viewing changed since the sweep: run it again."
        if self._built and self.state.sweep:
            self.show_sweep()

    def start_sweep(self):
        sweep = self.state.sweep
        if not sweep:
            return
        self.sweep_parameter.value, self.sweep_values.value = sweep["parameter"], ", ".join(f"{v:g}" for v in sweep["values"])
        if self._sweep_cancel is not None:
            self._sweep_cancel.set()
        cancel = threading.Event()
        self._sweep_cancel = cancel
        designs = self.sweep_designs()
        try:
            scene = self.state.scene_object()
            # refuses here, before anything runs, a parameter that does not apply to a design
            metrics = ("cielab",) if self.state.metric == "CIELAB" else ("cielab", "scielab")  # what the plot shows
            points = iter_sweep(designs, sweep["parameter"], sweep["values"], scene=scene, cancel=cancel, metrics=metrics)
        except CamsimError as exc:
            self.sweep_message.object = f"**Refused:** {md_text(exc)}"
            return
        self.points = []
        self.sweep_total = len(designs) * len(sweep["values"])
        self.sweep_progress.max, self.sweep_progress.value = self.sweep_total, 0
        self.sweep_message.object = f"Sweeping {md_text(sweep['parameter'])} over {len(sweep['values'])} values for {len(designs)} design(s)..."
        if self._server_doc() is None:
            for p in points:
                self._add_point(cancel, p)
        else:
            self._start_worker(self._sweep_work, (cancel, points), "camsim-sweep-feed")

    def _sweep_work(self, cancel, points):
        try:
            self._prebuild(1.0)  # the plots, made here rather than on the event loop
            for p in points:
                if cancel.is_set():
                    break
                self._schedule(partial(self._add_point, cancel, p))
        except Exception as exc:  # never a dead page
            self._schedule(partial(setattr, self.sweep_message, "object",
                                   f"**Failed:** {type(exc).__name__}: {md_text(exc)}"))

    def _add_point(self, cancel, point):
        if cancel is not self._sweep_cancel:
            return  # a newer sweep replaced this one
        self._ensure_plots()
        self.points.append(point)
        self.sweep_progress.value = len(self.points)
        self.show_sweep()
        errors = [p for p in self.points if p.error]
        if len(self.points) == self.sweep_total:
            # the points computed, then those refused (a design the parameter does not apply to): "Done: 12
            # points ... 3 refused" counted the refused among the points
            self.sweep_message.object = (f"Done: {len(self.points) - len(errors)} points. Click a point to load its "
                                         "configuration." + (f" {len(errors)} refused: {md_text(errors[0].error)}"
                                                             if errors else ""))
        self._status()

    def show_sweep(self):
        """Draw the sweep's points, one curve per design in its colour; a click on the plot loads the nearest point.
        (The plot is on the page from the first pin, empty until a sweep: added with the first sweep's first point
        instead, it made that sweep 1.5-3 s slower, 4 x 6 on the slanted edge.)"""
        self.sweep_plot.update(self._sweep_curves(list(self.points), self.state.metric),
                               SWEEP_PARAMETERS.get(self.state.sweep["parameter"], self.state.sweep["parameter"]),
                               self.state.metric)

    def colours(self, results=None):
        """Each design's colour (name -> colour) in every plot of the tab and in the report: the designs shown,
        in order, then the sweep's others (as :func:`camsim_core.review.report.design_colours` gives them)."""
        results = results if results is not None else self.designs()
        return design_colours([r.name for r in results], more=[p.name for p in self.points])

    def _sweep_curves(self, points, metric):
        """(name, colour, xs, ys) of each design swept that has points, in the designs' order: a design left out
        of the sweep (the message says why) has no curve and no legend entry."""
        names = {}
        for p in points:
            names.setdefault(p.design, p.name)
        colours = self.colours() if points else {}
        curves = []
        for i, name in sorted(names.items()):
            pts = sorted((p.value, p.measure(metric)) for p in points if p.design == i and p.measures)
            if pts:
                xs, ys = zip(*pts)
                curves.append((name, colours.get(name, DESIGN_COLOURS[i % len(DESIGN_COLOURS)]), xs, ys))
        return curves

    def nearest_point(self, x, y):
        """The sweep point nearest to (x, y) in the plot, distances relative to the axes' spans."""
        pts = [p for p in self.points if p.measures]
        if not pts or x is None or y is None:
            return None
        metric = self.state.metric
        xs = np.array([p.value for p in pts], float)
        ys = np.array([p.measure(metric) for p in pts], float)
        sx, sy = max(np.ptp(xs), 1e-9), max(np.ptp(ys), 1e-9)
        return pts[int(np.argmin(((xs - x) / sx) ** 2 + ((ys - y) / sy) ** 2))]

    def on_tap(self, x=None, y=None):
        point = self.nearest_point(x, y)
        if point is not None:
            self.load_point(point)

    def load_point(self, point):
        """Load a sweep point's configuration into the live design."""
        values = {k: v for k, v in _design_only(point.params).items() if getattr(self.state, k) != v}
        self.state.param.update(**values)
        self.sweep_message.object = (f"Loaded **{md_text(point.name)}** at {md_text(self.state.sweep['parameter'])} = "
                                     f"{point.value:g} into the live design.")

    # -- status and report -------------------------------------------------------
    def _status(self, results=None, top=None):
        results = results if results is not None else self.designs()
        sweep = self.state.sweep
        self.status.object = json.dumps({
            "designs": [{"name": r.name, "camera": r.params.get("camera"), "measures": r.measures,
                         "shape": list(r.shape), "flags": list(r.flags)} for r in results],
            "pinned": [p["name"] for p in self.state.pinned],
            "differ": differing_parameters([r.params for r in results], skip=_SHARED) if results else [],
            "busy": self._computing,
            "measuring": [r.name for r in results if r.quality_pending],
            "errors": self.errors,
            "scale_top": top,
            "hist_curves": len(results),
            "ab": None if getattr(self, "ab", None) is None else {
                "a": self.ab[0], "b": self.ab[1], "mean": self.ab[2]["measures"]["mean"],
                "a_wins": self.ab[2]["a_wins_fraction"], "b_wins": self.ab[2]["b_wins_fraction"]},
            "sweep": None if not sweep else {
                "parameter": sweep["parameter"], "values": sweep["values"], "total": self.sweep_total,
                "points": [{"design": p.name, "value": p.value, "measures": p.measures, "error": p.error}
                           for p in sorted(self.points, key=lambda p: (p.design, p.value))]},
            "store": {"entries": len(self.store), "megabytes": round(self.store.nbytes / 1e6, 1)},
        }, separators=(",", ":"))

    def report_bytes(self):
        """The HTML report of the comparison on screen (designs, A/B, sweep points)."""
        results = self.designs()
        if not results:
            return None
        res = self.state.result
        for i, r in enumerate(results):
            if r.name == LIVE and not r.quality and res is not None:  # the report has the live design's measures too
                results[i] = dataclasses.replace(r, quality=quality_measures(res, self.state.processing().monitor))
            elif r.quality_pending:  # a design just pinned, whose measures the tab's worker has not finished
                r.measure_quality()
        ab = None
        if self.ab is not None and len(results) >= 2 and self.ab[0] == results[0].name and self.ab[1] == results[1].name:
            ab = self.ab[2]
        points = list(self.points)
        text = report_html(results, sweep=self.state.sweep if points else None, points=points or None, ab=ab,
                           metric=self.state.metric)
        return io.BytesIO(text.encode("utf-8"))

    # -- layout --------------------------------------------------------------------
    def panel(self):
        pin_row = pn.Row(self.name_input, self.pin_button, self.pinned_select, self.rename_input, self.rename_button,
                         self.unpin_button, styles=_WRAP)
        return pn.Column(
            pn.pane.Markdown(f"Pin up to {MAX_PINNED} designs; they are compared with the live design on the same "
                             "scene. Images share zoom and pan; every dE map uses one colour scale."),
            pin_row, pn.Row(self.progress, self.download), self.message, self.views,
            pn.pane.Markdown("### Sweep"),
            pn.Row(self.sweep_parameter, self.sweep_values, self.sweep_button, self.sweep_progress, styles=_WRAP),
            self.sweep_message, self.sweep_area, self.show_status, self.status,
            name="Compare designs",
        )


def compare_tab(state, when_shown=now):
    """The Compare designs tab of one session (a :class:`CompareView` on ``state``); ``when_shown``: the tab's
    gate (:class:`~camsim_explorer.shown.WhenShown`)."""
    view = CompareView(state, when_shown)
    tab = view.panel()
    tab.compare = view
    return tab
