"""Views of the explorer: Bokeh figures that follow an :class:`~camsim_explorer.state.ExplorerState`.

Only display logic lives here (turning engine arrays into pictures); every
number shown comes from the engine through the state's cached pipeline.
Each figure is built once per session; a new result replaces the data of its
``ColumnDataSource`` (images as packed 8-bit RGBA), so an update sends arrays,
not new plots. The image views of the camera's results share one pair of
ranges (camera pixels), so they zoom and pan together, and refit to the
whole image when its size changes.
"""

from __future__ import annotations

import html
import io
import json
import zlib
from functools import lru_cache, partial, wraps

import numpy as np
import panel as pn
import param
from bokeh.events import DoubleTap, RangesUpdate, SelectionGeometry, Tap
from bokeh.models import (BoxSelectTool, ColumnDataSource, CustomJSHover, CustomJSTickFormatter, DataRange1d,
                          HoverTool, Image, ImageRGBA, LinearColorMapper, Range1d, Span, TapTool)
from bokeh.palettes import Category10, Greys256, Inferno256
from bokeh.plotting import figure
from panel.models.markup import HTML as HTMLModel

from camsim_core._parallel import run_blocks
from camsim_core.cache import fingerprint
from camsim_core.metrics.exposure import saturation_level
from camsim_core.preview import sensor_colors
from camsim_core.scene.preview import scene_srgb as preview_srgb
from camsim_core.screen import block_size, to_screen
from camsim_core.simulation import tile_index_map

from . import state as state_module
from .compat import hooks as _compat
from .safe_text import html_text, md_text
from .shown import now
from .state import bright_end, exposure_warnings, mean_level
from .tab import TabView


__all__ = ["held", "sensor_colors", "scene_srgb", "raw_rgb", "planes_rgb", "rgba32", "screen_part", "fit_ranges",
           "histogram", "de_range", "ResultsView", "SceneView", "CameraView"]

#: The fixed dE colour scale (an option, for comparing designs); by default the scale follows the data.
DE_RANGE = (0.0, 20.0)
_SCENE_RGB = {}


#: A computation still running after this long marks the views' grid as busy (ms).
BUSY_DELAY_MS = 250
#: The views' grid, marked busy, shows a still "Computing..." label over its dimmed content: the look of Panel's
#: ``loading`` without its animated spinner (an animated spinner repaints at the screen's frame rate, and six of
#: them, one a view before the grid was marked as one, kept half a core of the browser busy for as long as a
#: result was computing: 2.4 CPU-s per 5 s, against 0.04 idle). The mark is two custom properties set in the
#: grid's ``styles`` (:data:`BUSY_STYLES`), not a class: Bokeh lays the whole page body out again when an
#: element's classes change (80-160 ms of a 2-core machine's browser, twice a long computation, while the
#: engine computes beside it), and only restyles it when its ``styles`` change.
STILL_BUSY_CSS = """
:host::after {
  content: var(--camsim-busy-veil, none); cursor: progress; position: absolute; top: 0; left: 0;
  width: 100%; height: 100%; z-index: 1000; background-color: rgba(255, 255, 255, 0.5);
}
:host::before {
  content: var(--camsim-busy, none); position: absolute; top: 50%; left: 50%; transform: translate(-50%, -50%);
  z-index: 1001; background-color: rgba(255, 255, 255, 0.9); color: #333; font-size: 1em;
  padding: 2px 10px; border-radius: 4px; border: 1px solid #bbb;
}
"""
#: The grid's ``styles`` while a newer result is computed (:data:`STILL_BUSY_CSS` draws them), and otherwise
#: (the browser keeps a property it was given until it is given another value: an empty ``styles`` would not
#: take the mark off).
BUSY_STYLES = {"--camsim-busy": "'Computing...'", "--camsim-busy-veil": "''"}
IDLE_STYLES = {"--camsim-busy": "none", "--camsim-busy-veil": "none"}
#: The image frames keep their shape while the image's aspect ratio stays within this factor of theirs
#: (a distance change, which keeps the scene's aspect until the sensor crops it).
ASPECT_TOLERANCE = 1.1


def _after(ms, fn):
    """Call ``fn`` after ``ms`` on this session's event loop (at once outside a server)."""
    doc = pn.state.curdoc
    if doc is not None and doc.session_context is not None:
        doc.add_timeout_callback(partial(when_page_ready, fn), ms)
    else:
        fn()


def once(fn, *args):
    """``fn(*args)`` as a callable that runs once and then lets go of ``fn`` and ``args``.

    For callbacks handed to Bokeh's event loop: its one-shot callbacks sit in
    reference cycles (each refers to itself) that only a full garbage
    collection frees, which a busy server runs rarely; a result held by one
    stayed in memory until then (+0.6 MB a change in a 200-change soak).
    """
    parcel = [fn, args]

    def call():
        if parcel:
            f, a = parcel
            parcel.clear()
            return f(*a)

    call.drop = parcel.clear  # for a callback that will never run (the session closed)
    return call


def held(fn, doc=None):
    """``fn`` as a callback whose changes reach the page in the order they were made.

    Bokeh sends a change made straight to one of its models (a figure's
    data source, a legend's label) at once, while Panel queues its own
    changes whenever a write to the page's websocket is under way. A change
    to a model that a queued message brings to the page could then arrive
    before the model itself: the browser drops it ("reference p2578 isn't
    known", seen on the Compare tab's histogram under load). Inside
    ``pn.io.hold`` both kinds go through Panel's queue, in order. The call
    waits for the page to be ready (:func:`when_page_ready`), as every
    held change must.

    Parameters
    ----------
    fn : callable
        A callback for the session's event loop (a Bokeh event handler, a
        next-tick callback).
    doc : bokeh.document.Document, optional
        The session's document: give it when ``held`` is called outside the
        session's thread (a worker thread); default ``pn.state.curdoc``.

    Returns
    -------
    callable
        ``fn`` with the same arguments, run inside ``pn.io.hold(doc)``.

    Examples
    --------
    >>> calls = []
    >>> held(calls.append)("shown")
    >>> calls
    ['shown']
    """
    doc = doc or pn.state.curdoc

    @wraps(fn)  # Bokeh reads the handler's signature to know whether it takes the event
    def call(*args, **kwargs):
        def run():
            with pn.io.hold(doc):
                fn(*args, **kwargs)

        when_page_ready(run)

    return call


def when_page_ready(fn):
    """Call ``fn`` now if this session's page has reported that it is rendered, else as soon as it does.

    Panel drops the changes made inside ``pn.io.hold`` between the browser's
    first pull of the page and its "document ready" report (it counts on the
    pull to carry them, but the pull has already gone), so a result shown in
    that window would never reach the screen. Before the browser has
    connected, also at once: its pull will carry the changes. Outside a
    server: at once. With ``compat.hooks.connected_at_pull`` in place, which
    closes that window for every change, always at once: waiting then only
    delayed a link's first result until the page had drawn, and a page whose
    pull waited for that result (``compat.spare_session``) waited its 10 s.
    """
    doc = pn.state.curdoc
    if doc is None or doc.session_context is None or pn.state.loaded or _compat.pages_get_every_change():
        fn()
        return
    session = getattr(doc.session_context, "session", None)
    if session is None or session.connection_count == 0:
        fn()
    else:
        pn.state.onload(fn)


# -- display helpers (pure functions over arrays) ----------------------------
def scene_srgb(scene):
    """sRGB (H, W, 3) in [0, 1] of a scene (the engine's :func:`camsim_core.scene.preview.scene_srgb`: CIE 1931
    XYZ of its radiance, brightest 1 % clipped), cached per scene object (scenes are shared read-only)."""
    hit = _SCENE_RGB.get(id(scene))
    if hit is not None and hit[0] is scene:
        return hit[1]
    rgb = preview_srgb(scene)
    if len(_SCENE_RGB) > 32:
        _SCENE_RGB.clear()
    _SCENE_RGB[id(scene)] = (scene, rgb)
    return rgb


#: Display gamma of the raw and demosaiced views: their values are linear in light, and shown linearly
#: a raw at a fifth of full scale looks black although nothing is wrong with it.
VIEW_GAMMA = 2.2


_LINEAR_NOTE = (f"Camera values are linear in light; shown as fractions of full scale with display gamma "
                f"{VIEW_GAMMA:g}, so that dim values stay visible")


def _normalise(data, full_scale):
    """Values as fractions of full scale (of the 99.5th percentile without one), display-encoded (``VIEW_GAMMA``).

    In float32: the screen shows 8 bits, and the power runs several times faster than in float64.
    """
    data = np.asarray(data)
    top = full_scale if full_scale else (np.percentile(data, 99.5) or 1.0)
    x = np.multiply(data, np.float32(1.0 / top), dtype=np.float32)
    np.clip(x, 0, 1, out=x)
    return np.power(x, np.float32(1.0 / VIEW_GAMMA), out=x)


def raw_rgb(image):
    """The raw camera image coloured by sensor: each pixel's value (display-encoded) times its sensor's colour."""
    colors = sensor_colors(image.sensitivities, image.wavelengths, image.sensor_names).astype(np.float32)
    data = np.asarray(image.data)
    v = _normalise(data, image.full_scale)
    if image.mosaiced and data.ndim == 2:
        idx = tile_index_map(image.tile, data.shape)
        return colors[idx] * v[..., None]
    if data.ndim == 3 and image.mosaiced:  # tiered tile: show the first tier
        idx = tile_index_map(image.tile, data.shape[:2])[..., 0]
        return colors[idx] * v[..., :1]
    return planes_rgb(image)


def planes_rgb(image):
    """Full sensor planes (H, W, K) as a picture: sum of planes times sensor colours, display-encoded."""
    colors = sensor_colors(image.sensitivities, image.wavelengths, image.sensor_names)
    data = np.asarray(image.data)
    if data.ndim == 2:
        data = data[..., None]
    mixed = data.astype(np.float32, copy=False) @ (colors / colors.sum(axis=0, keepdims=True).clip(1e-9)).astype(np.float32)
    return _normalise(mixed, image.full_scale)


def monitor_rgb(image):
    """A rendered image (0..255 monitor settings) as [0, 1] RGB."""
    data = np.asarray(getattr(image, "data", image), float)
    return np.clip(data / 255.0, 0, 1)


def digest(array):
    """Short content hash of an array (for the status pane and tests): CRC-32 of its bytes, its shape and dtype.

    Tells one result from the next, not an adversary's: CRC-32 runs at memory speed (blake2b took 3.5 ms a
    rendered image, in every result).
    """
    if array is None:
        return None
    a = np.ascontiguousarray(np.asarray(getattr(array, "data", array)))
    return f"{zlib.crc32(memoryview(a).cast('B'), zlib.crc32(repr((a.shape, a.dtype.str)).encode())):08x}"


def rgba32(rgb):
    """(H, W, 3) colours in [0, 1] (or uint8) as Bokeh's packed RGBA: (H, W) uint32, bottom row first.

    8 bits per channel is what the screen shows; packing four of them in one
    uint32 lets Bokeh's ``image_rgba`` draw the array as sent (a quarter of the
    bytes of float RGB).
    """
    rgb = np.asarray(rgb)
    h, w = rgb.shape[:2]
    out = np.empty((h, w, 4), np.uint8)
    if rgb.dtype == np.uint8:
        out[..., :3] = rgb
    else:  # float32 is exact enough for 8 bits, and twice as fast
        x = np.multiply(rgb, np.float32(255.0), dtype=np.float32)
        np.clip(x, 0, 255, out=x)
        out[..., :3] = np.rint(x, out=x)
    out[..., 3] = 255
    return np.ascontiguousarray(out[::-1]).view(np.uint32)[..., 0]


def raw_rgba(image):
    """:func:`raw_rgb` packed for Bokeh (:func:`rgba32`): the raw view's data.

    A mosaic of whole digital values (a quantized raw of up to 16 bits, with
    its full scale) is coloured by a table of every sensor's every value
    (:func:`_raw_table`), one lookup a pixel: the same numbers as the
    per-pixel arithmetic, which is the same for each pixel of a sensor and
    value (5x faster on the default raw).
    """
    data = np.asarray(image.data)
    levels = 1 << int(image.bits or 0) if image.bits and 0 < int(image.bits) <= 16 else 0
    if levels and image.mosaiced and data.ndim == 2 and image.full_scale and image.tile is not None:
        with np.errstate(invalid="ignore"):  # NaN or a value beyond int32: fails the test below
            q = data.astype(np.int32)
        if data.size and q.min() >= 0 and q.max() < levels and np.array_equal(q, data):
            colors = sensor_colors(image.sensitivities, image.wavelengths, image.sensor_names).astype(np.float32)
            table = _raw_table(colors.tobytes(), colors.shape[0], float(image.full_scale), levels)
            q += tile_index_map(image.tile, data.shape).astype(np.int32) * levels
            return table.take(q[::-1])
    return rgba32(raw_rgb(image))


@lru_cache(maxsize=8)
def _raw_table(colors_bytes, k, full_scale, levels):
    """Packed RGBA (k levels,) of sensor ``s`` at digital value ``v`` (index ``s levels + v``), as
    :func:`raw_rgb` and :func:`rgba32` colour it."""
    colors = np.frombuffer(colors_bytes, np.float32).reshape(k, 3)
    v = _normalise(np.arange(levels, dtype=np.float32), full_scale)
    table = rgba32((colors[:, None, :] * v[None, :, None]).reshape(1, k * levels, 3))[0]
    table.flags.writeable = False
    return table


def monitor_u8(image):
    """A rendered image (0..255 monitor settings) as uint8 RGB."""
    data = np.asarray(getattr(image, "data", image))
    if data.dtype.kind != "f":
        return np.clip(data, 0, 255).astype(np.uint8)
    x = np.clip(data, 0, 255, dtype=np.float32)  # float32 is exact enough for 8 bits
    return np.rint(x, out=x).astype(np.uint8)


def planes_rgba(image):
    """:func:`planes_rgb` packed for Bokeh (:func:`rgba32`): the demosaiced view's data."""
    return rgba32(planes_rgb(image))


def monitor_rgba(image):
    """:func:`monitor_u8` packed for Bokeh (:func:`rgba32`): the rendered and ideal views' data."""
    return rgba32(monitor_u8(image))


def screen_part(array, side, region=None):
    """What a view sends of a display array (bottom row first): the part ``region`` (top, left, height,
    width; default the whole), as it is when it fits ``side`` x ``side``, else as block means of its pixels
    (:func:`camsim_core.screen.to_screen`; packed RGBA averaged per channel). Returns (part, block)."""
    a = np.asarray(array)
    top, left, height, width = (0, 0) + a.shape[:2] if region is None else region
    part = a[top : top + height, left : left + width]
    block = block_size(part.shape, (side, side))
    if block == 1:
        return np.ascontiguousarray(part), 1
    if a.dtype == np.uint32:  # packed RGBA: the four 8-bit channels averaged, then packed again
        channels = np.ascontiguousarray(part).view(np.uint8).reshape(part.shape + (4,))
        view, block = to_screen(channels, (side, side))
        return np.ascontiguousarray(np.rint(view, out=view).astype(np.uint8)).view(np.uint32)[..., 0], block
    view, block = to_screen(part.astype(np.float32, copy=False), (side, side))
    return view, block


def histogram(values, bins=40, p995=None):
    """Counts of finite ``values`` in ``bins`` equal bins from 0 to the 99.5th percentile
    (at least 1); larger values are counted in the last bin. Returns (edges, counts, top).
    ``p995``: that percentile, when the caller has it already."""
    v = np.asarray(values, float).ravel()
    v = v[np.isfinite(v)]
    if p995 is None and v.size:
        p995 = np.percentile(v, 99.5)
    top = float(max(1.0, np.ceil(p995))) if v.size else 1.0
    edges = np.linspace(0.0, top, bins + 1)
    counts, _ = np.histogram(np.clip(v, 0, top), edges)
    return edges, counts, top


def de_range(de, scale, p995=None):
    """Colour range of the dE map: (0, 99.5th percentile) of the data, or the fixed (0, 20).
    ``p995``: that percentile, when the caller has it already."""
    if scale != "data":
        return DE_RANGE
    v = np.asarray(de, float)
    v = v[np.isfinite(v)]
    if p995 is None and v.size:
        p995 = np.percentile(v, 99.5)
    top = float(p995) if v.size else 1.0
    return (0.0, max(top, 0.5))


def _palette_rgba(palette):
    """A Bokeh palette ("#rrggbb" strings) as packed RGBA (uint32, the layout of :func:`rgba32`)."""
    rgb = np.array([[int(c[i : i + 2], 16) for i in (1, 3, 5)] for c in palette], np.uint8)
    return rgba32(rgb[None, :, :])[0]


#: The dE map's colours (Inferno, as the colour bar's mapper), packed RGBA, and the colour of "no value".
_DE_COLOURS = _palette_rgba(Inferno256)
_DE_NAN = _palette_rgba(["#808080"])[0]


def de_rgba(values, low, high):
    """dE values (bottom row first) coloured as Bokeh's ``LinearColorMapper(Inferno256, low, high)`` would
    colour them in the browser, packed RGBA: values below ``low`` take the first colour, above ``high`` the
    last, NaN grey. Colouring here spares each browser ~9 ms a result (a mapper recolours the whole map
    in JavaScript); the page sends the values too, for the hover."""
    v = np.asarray(values, np.float32)
    n = len(_DE_COLOURS)
    scale = np.float32(n / (high - low)) if high > low else np.float32(0.0)
    idx = np.subtract(v, np.float32(low), dtype=np.float32)
    idx *= scale
    np.clip(idx, 0, n - 1, out=idx)
    nan = np.isnan(idx)
    idx[nan] = 0
    out = _DE_COLOURS[idx.astype(np.intp)]
    out[nan] = _DE_NAN
    return out


def _rgba_glyph():
    """The glyph of an image view (packed RGBA from the source's ``image``, ``x``, ``y``, ``dw``, ``dh``
    columns), added with ``figure.add_glyph``: one glyph model, where ``figure.image_rgba`` adds three (its
    selection and muted copies, which an image never uses): fewer models to make and send with each page."""
    return ImageRGBA(image="image", x="x", y="y", dw="dw", dh="dh")


def fit_ranges(x_range, y_range, width, height, frame_aspect):
    """Set an image view's ranges to show a ``width`` x ``height`` image whole, centred, with square pixels, in a
    frame of ``frame_aspect`` (width / height): the image fills the frame's width or its height, the rest is
    margin. The ranges' reset values are set too (a reset tool comes back to the whole image).

    Examples
    --------
    >>> x, y = Range1d(0, 1), Range1d(0, 1)
    >>> fit_ranges(x, y, 200, 100, 1.0)  # a wide image in a square frame: full width, margins above and below
    >>> (x.start, x.end), (y.start, y.end)
    ((0, 200), (-50.0, 150.0))
    """
    if width / height >= frame_aspect:  # as wide or wider: full width
        extra = width / frame_aspect - height
        x0, x1, y0, y1 = 0, width, -extra / 2, height + extra / 2
    else:
        extra = height * frame_aspect - width
        x0, x1, y0, y1 = -extra / 2, width + extra / 2, 0, height
    x_range.update(start=x0, end=x1, reset_start=x0, reset_end=x1)
    y_range.update(start=y0, end=y1, reset_start=y0, reset_end=y1)


def _image_figure(x_range, y_range, name, shape):
    """A borderless figure that shows an image filling its frame, width following the page."""
    h, w = shape
    fig = figure(x_range=x_range, y_range=y_range, tools="pan,wheel_zoom", active_scroll="wheel_zoom",
                 toolbar_location=None, sizing_mode="scale_width", aspect_ratio=w / h, min_border=0,
                 outline_line_color=None, background_fill_color="white", border_fill_color="white", name=name,
                 output_backend="canvas", x_axis_type=None, y_axis_type=None)  # no axes or grids: fewer models to build and send
    return fig


def _unavailable(shape):
    """A grey stand-in of the image's size for an output the engine could not give."""
    return rgba32(np.full(tuple(shape) + (3,), 0.55))


class ColourBar:
    """A colour mapper and its horizontal colour bar, in a strip of its own; ``set(low, high)`` changes both.

    Drawn as an image of the mapper's own colours over an axis from low to
    high (Bokeh's ColorBar annotation drew as a solid black bar in a strip this
    thin; inside the image figure it would change the image's aspect ratio).
    The strip is redrawn by ``set``, not by a callback on the mapper: Python
    callbacks on a model do not run inside ``pn.io.hold``, which every result
    update uses.
    """

    def __init__(self, mapper, title, name):
        self.mapper = mapper
        fig = figure(height=64, sizing_mode="stretch_width", toolbar_location=None, tools="", min_border=0,
                     min_border_left=10, min_border_right=20, outline_line_color=None, name=name,
                     x_range=Range1d(0, 1), y_range=Range1d(0, 1), x_axis_label=title)
        fig.yaxis.visible = False
        fig.grid.visible = False
        fig.xaxis.axis_label_standoff = 2
        self.source = ColumnDataSource(dict(image=[np.zeros((1, 256))], x=[0.0], y=[0.0], dw=[1.0], dh=[1.0]))
        fig.add_glyph(self.source, Image(image="image", x="x", y="y", dw="dw", dh="dh", color_mapper=mapper))
        self.figure = fig
        self.set(mapper.low, mapper.high)

    def set(self, low, high):
        lo, hi = float(low), float(high)
        hi = hi if hi > lo else lo + 1.0
        if (self.mapper.low, self.mapper.high) != (lo, hi):
            self.mapper.update(low=lo, high=hi)
        if (self.figure.x_range.start, self.figure.x_range.end) != (lo, hi):
            self.source.data = dict(image=[np.linspace(lo, hi, 256)[None, :]], x=[lo], y=[0.0], dw=[hi - lo], dh=[1.0])
            self.figure.x_range.update(start=lo, end=hi)


def _same_column(old, new):
    """True when two one-image columns hold the same array (then it is not sent again)."""
    a, b = old[0], new[0]
    return a is b or (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape
                      and a.dtype == b.dtype and np.array_equal(a, b))


class Text:
    """A piece of HTML that changes with results, set in place on Panel's HTML model.

    In the browser a new text only replaces the element's inner HTML. A Bokeh
    ``Div`` re-renders instead and lays out its whole root again (every
    figure's axes measured: ~80 ms a result at 1366 px, several times per
    result with the labels); a Panel HTML *pane* re-sends its stylesheets
    with each change, which makes Bokeh re-walk the whole document's model
    graph on the server. The model carries the text HTML-escaped, as Panel's
    own panes send it (the browser decodes it); scripts and TeX are off.
    The text is HTML: a part that users wrote (a name, a value) goes through
    :func:`~camsim_explorer.safe_text.html_text`. Use it where a pane would go (``__panel__``).
    """

    def __init__(self, text, css, margin=(2, 5), styles=None, stylesheets=()):
        self._text = text
        self.div = HTMLModel(text=html.escape(text), css_classes=list(css), margin=margin,
                             sizing_mode="stretch_width", styles=dict(styles or {}), stylesheets=list(stylesheets),
                             run_scripts=False, disable_math=True)
        self.pane = pn.pane.Bokeh(self.div, sizing_mode="stretch_width", margin=0)

    @property
    def object(self):
        return self._text

    @object.setter
    def object(self, text):
        if text != self._text:  # an unchanged text sends nothing
            self._text = text
            self.div.text = html.escape(text)

    @property
    def visible(self):
        return self.div.visible

    @visible.setter
    def visible(self, value):
        self.div.visible = bool(value)

    def __panel__(self):
        return self.pane


#: A view's title stays on one line (cut with an ellipsis): a title wrapped to two lines pushed its image
#: 17 px below its neighbours'.
_ONE_LINE = ":host { display: block; } div { white-space: nowrap; overflow: hidden; text-overflow: ellipsis; }"


#: The scene's facts (``Scene.describe()``) as the Scene tab names them.
_FACT_LABELS = {"name": "Name", "kind": "Kind", "size_px": "Size (px)", "planes": "Planes",
                "wavelengths_nm": "Wavelengths (nm)", "distance_m": "Distance (m)",
                "angular_resolution_px_per_deg": "Angular resolution (px/deg)", "unit": "Unit",
                "radiance_range": "Radiance, lowest to highest", "illuminant": "Illuminant", "notices": "Notices"}


def _fact_text(value):
    """A value of ``Scene.describe()`` as a reader writes it: numbers to 4 significant digits, lists joined,
    an x/y pair as "x x y" (never a Python repr)."""
    if isinstance(value, bool) or value is None:
        return {True: "yes", False: "no", None: "none"}[value]
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, dict):
        if set(value) == {"x", "y"}:
            x, y = (_fact_text(value[k]) for k in ("x", "y"))
            return x if x == y else f"{x} (x), {y} (y)"
        return "; ".join(f"{k}: {_fact_text(v)}" for k, v in value.items()) or "none"
    if isinstance(value, (list, tuple)):
        return "; ".join(_fact_text(v) for v in value) or "none"
    return str(value)


def scene_facts(described):
    """(label, text) rows of a scene's ``describe()`` dict for the Scene tab: labelled in words, values as
    text; the radiance range with its unit, the file's comments left out (shown elsewhere)."""
    unit = described.get("unit", "")
    rows = []
    for key, value in described.items():
        if key == "comments":
            continue
        text = _fact_text(value)
        if key == "radiance_range" and isinstance(value, (list, tuple)) and len(value) == 2:
            text = f"{_fact_text(value[0])} to {_fact_text(value[1])} {unit}".strip()
        rows.append((_FACT_LABELS.get(key, key.replace("_", " ").capitalize()), text))
    return rows


def _label(text, css):
    return Text(text, ["camsim-label", css], stylesheets=[_ONE_LINE])


_RGB_HOVER_JS = """
    const v = value >>> 0;
    return `${v & 255}, ${(v >>> 8) & 255}, ${(v >>> 16) & 255}`;"""


def _rgb_hover():
    """Hover formatter: packed RGBA -> "R, G, B". A new model per figure: a Bokeh model belongs to one
    document, and a module-level one would keep the first session's document (and its arrays) alive."""
    return CustomJSHover(code=_RGB_HOVER_JS)


def _exposure_flags(res):
    """The warnings a score of ``res`` must carry (a black, empty or clipped frame: :attr:`camsim_core.cache.Result.exposure`),
    with the result's camera: an electron-level sensor's pixels at its full well are clipped too, also below the
    ADC's full scale (:func:`camsim_core.metrics.exposure.saturation_level`)."""
    from camsim_core.metrics.exposure import exposure_measures, saturation_level

    camera = getattr(res, "camera", None)
    if getattr(res, "raw", None) is not None and saturation_level(camera) is not None:
        return tuple(exposure_measures(res.raw, camera).flags)
    exposure = getattr(res, "exposure", None)
    return tuple(exposure.flags) if exposure is not None else ()


def _mean_y(xyz):
    """Mean luminance Y (cd/m^2) of the rendered image's XYZ on the monitor; ``None`` without one."""
    if xyz is None:
        return None
    return round(float(np.mean(np.asarray(getattr(xyz, "data", xyz))[..., 1], dtype=np.float64)), 4)


# -- the results: raw, demosaiced, rendered, ideal, dE ---------------------
class ResultsView:
    """Image views sharing zoom and pan, the dE histogram and the statistics line.

    Each view is a Bokeh figure made once; a new result replaces the data of
    its ``ColumnDataSource`` (packed 8-bit RGBA, or the dE values coloured in
    the browser), so nothing is rebuilt. On a change of image size all views
    refit to the whole image; otherwise zoom and pan are kept.
    """

    TITLES = {"raw": f"<span title='{_LINEAR_NOTE}'>Raw mosaic (each pixel in its sensor's colour)</span>",
              "raw_full": f"<span title='{_LINEAR_NOTE}'>Raw, no mosaic (every sensor at every pixel)</span>",
              "demosaiced": "Demosaiced",
              "rendered": "Rendered (the camera's image on the monitor)",
              "ideal": "<span title='The light of the scene through the human cones on the camera image pixel grid: "
                       "an ideal lens, no noise, not quantized, the white of the scene at the white of the display. It "
                       "does not change with the exposure, f-number, bits, noise or optics of the camera.'>Ideal: the "
                       "scene through the cones, unquantized</span>"}
    KEYS = ("raw", "demosaiced", "rendered", "ideal", "de")

    def __init__(self, state):
        self.state = state
        self.shape = (233, 372)
        h, w = self.shape
        self.frame_aspect = w / h
        self.x_range, self.y_range = Range1d(0, w), Range1d(0, h)
        blank = np.zeros(self.shape, np.uint32)
        self.sources, self.figures, self.labels, self.panes = {}, {}, {}, {}
        self._shown = {}
        for key in self.KEYS:
            fig = _image_figure(self.x_range, self.y_range, f"camsim-{key}-figure", self.shape)
            fig.css_classes = [f"camsim-{key}-plot"]
            cols = dict(image=[blank], x=[0], y=[0], dw=[w], dh=[h])
            if key == "raw":
                cols.update(value=[np.zeros(self.shape, np.float32)], sensor=[np.zeros(self.shape, np.uint8)])
            if key == "de":  # coloured here (de_rgba); the values for the hover
                cols["value"] = [np.zeros(self.shape, np.float32)]
            src = ColumnDataSource(cols)
            r = fig.add_glyph(src, _rgba_glyph())
            if key == "de":
                self.mapper = LinearColorMapper(palette=Inferno256, low=DE_RANGE[0], high=DE_RANGE[1])  # the bar's
                tips = [("dE", "@value{0.00}")]
            else:
                if key == "raw":
                    self.sensor_hover = CustomJSHover(args=dict(names=["?"]), code="return names[value] || value;")
                    tips = [("digital value", "@value{0.[00]}"), ("sensor", "@sensor{custom}")]
                else:
                    tips = [("monitor R, G, B", "@image{custom}")]
            fmt = {"@sensor": self.sensor_hover} if key == "raw" else ({"@image": _rgb_hover()} if key != "de" else {})
            fig.add_tools(HoverTool(renderers=[r], tooltips=[("x, y", "$x{0}, $y{0}")] + tips, formatters=fmt))
            self.sources[key], self.figures[key] = src, fig
            self.labels[key] = _label(self.TITLES.get(key, "dE map"), f"camsim-{key}-label")
            parts = [self.labels[key], pn.pane.Bokeh(fig, sizing_mode="stretch_width")]
            if key == "de":
                self.colour_bar = ColourBar(self.mapper, "dE", "camsim-de-colorbar")
                # in a column of its own: Bokeh aligns the frames of figures in one column, and the bar's borders
                # (room for its end labels) narrowed the map's frame by 30 px, ~9 % of a view at 1366 px
                parts.append(pn.Column(pn.pane.Bokeh(self.colour_bar.figure, sizing_mode="stretch_width"),
                                       sizing_mode="stretch_width", margin=0))
            self.panes[key] = pn.Column(*parts, css_classes=[f"camsim-{key}", "camsim-view"], sizing_mode="stretch_width")
        # the histogram keeps its own axes, refitted to each result
        self.hist_source = ColumnDataSource(dict(left=[0.0], right=[1.0], top=[0]))
        hist = figure(height=240, sizing_mode="stretch_width", tools="", toolbar_location=None,
                      x_range=Range1d(0, 1), y_range=Range1d(0, 1), name="camsim-hist-figure",
                      x_axis_label="dE (values above the last bin counted in it)", y_axis_label="pixels")
        hist.quad(left="left", right="right", top="top", bottom=0, source=self.hist_source, color="#4c78a8")
        self.mean_span = Span(location=0, dimension="height", line_color="red", line_width=2)
        self.median_span = Span(location=0, dimension="height", line_color="orange", line_dash="dashed", line_width=2)
        hist.add_layout(self.mean_span)
        hist.add_layout(self.median_span)
        self.hist_figure = hist
        self.labels["hist"] = _label("dE histogram", "camsim-hist-label")
        self.panes["hist"] = pn.Column(self.labels["hist"], pn.pane.Bokeh(hist, sizing_mode="stretch_width"),
                                       css_classes=["camsim-hist"], sizing_mode="stretch_width")
        p = self.panes
        # the views in a grid, marked busy as one (see _show_computing)
        self.grid = pn.GridBox(p["raw"], p["demosaiced"], p["rendered"], p["ideal"], p["de"], p["hist"], ncols=3,
                               sizing_mode="stretch_width", css_classes=["camsim-grid"], stylesheets=[STILL_BUSY_CSS],
                               styles=IDLE_STYLES)
        # HTML, not Markdown: these change with every result, and need no parsing
        self.stats = Text("", ["camsim-stats"], margin=(0, 10))
        self.warnings = Text("", ["camsim-warnings"], margin=(0, 10))
        self.status = Text("", ["camsim-status"], styles={"font-size": "10px"},
                           stylesheets=["pre { white-space: pre-wrap; word-break: break-all; margin: 0; }"])
        self._busy_shown = False
        self._computations = 0
        self._memos = {}
        # a result larger than the screen: the views send block means of it, and the region in view (top, left,
        # height, width of the image, bottom row first; None: the whole) in more detail when zoomed in
        self.region = None
        self._full = {}  # key -> (display array, extra columns, sensor names) at full resolution
        self._screens = {}  # key -> (display array, side, its whole-image view): see _whole
        self.figures["rendered"].on_event(RangesUpdate, held(self._on_ranges))  # one event per zoom or pan (ranges are shared)
        state.param.watch(self._on_state, ["result", "metric", "de_scale", "computing", "message"])
        state.preparers.append(self.prepare)
        self.update()

    # -- pieces -------------------------------------------------------------
    def fit(self):
        """Show the whole image in every view (after a change of size, or on request), centred.

        The frames keep their aspect ratio (``frame_aspect``) while the image's
        stays within ``ASPECT_TOLERANCE`` of it: the image then fills the
        frame's width or height, with a margin of at most 10 % on the other.
        """
        if self.region is not None:  # the whole image again, as block means if it does not fit the screen
            self.region = None
            for key in self._full:
                self._send_screen(key)
        h, w = self.shape
        fit_ranges(self.x_range, self.y_range, w, h, self.frame_aspect)

    def _send(self, key, image, place=None, **extra):
        """Replace an image view's data; only the columns that changed go to the browser.

        ``place`` (x, y, dw, dh): where the image lies, in image pixels (default: at the origin, its own size).
        """
        h, w = image.shape[:2]
        x, y, dw, dh = place if place is not None else (0, 0, w, h)
        src = self.sources[key]
        new = dict(image=[image], **extra)
        if ([src.data[k] for k in ("x", "y", "dw", "dh")] != [[x], [y], [dw], [dh]]
                or set(src.data) != set(new) | {"x", "y", "dw", "dh"}):
            src.data = dict(new, x=[x], y=[y], dw=[dw], dh=[dh])
            return
        changed = {k: v for k, v in new.items() if not _same_column(src.data[k], v)}
        if changed:
            src.data.update(changed)

    def _show(self, key, image, names=None, **extra):
        """Show a display array (bottom row first) in view ``key``: what of it fits the screen (:meth:`_send_screen`)."""
        self._full[key] = (image, extra, names)
        self._send_screen(key)

    def _send_screen(self, key):
        """Send view ``key`` the region in view of its image, as it is or as block means when it does not fit
        ``LIMITS.max_view_side`` (a 12-megapixel result is never sent whole). The raw's hover then gives the
        block's mean value, and names the block instead of a sensor."""
        image, extra, names = self._full[key]
        h, w = image.shape[:2]
        if self.region is None:
            region, (view, columns, block) = (0, 0, h, w), self._whole(key, image, extra)
        else:
            top, left, height, width = self.region
            region = (top, left, min(height, h - top), min(width, w - left))
            view, columns, block = self._screen(image, extra, region)
        if key == "raw":
            self.sensor_hover.args = dict(names=names if block == 1 else
                                          [f"mean of {block} x {block} pixels (zoom in for each pixel)"])
        self._send(key, view, place=(region[1], region[0], region[3], region[2]), **{k: [v] for k, v in columns.items()})

    @staticmethod
    def _screen(image, extra, region):
        """(view, extra columns, block) of a display array's ``region`` (:func:`screen_part`)."""
        side = state_module.LIMITS.max_view_side
        view, block = screen_part(image, side, region)
        columns = {}
        for name, values in extra.items():
            if name == "sensor" and block > 1:  # a block holds several sensors
                columns[name] = np.zeros(view.shape[:2], np.uint8)
            else:
                columns[name] = screen_part(values, side, region)[0]
        return view, columns, block

    def _whole(self, key, image, extra):
        """The whole-image view of a display array, kept while the array is the same: made in the computing
        thread by :meth:`prepare` (block means of a large image take ~80 ms a view), sent by the event loop."""
        side = state_module.LIMITS.max_view_side
        held = self._screens.get(key)
        if held is None or held[0] is not image or held[1] != side:
            held = self._screens[key] = (image, side, self._screen(image, extra, (0, 0) + image.shape[:2]))
        return held[2]

    def _on_ranges(self, event):
        self.zoom_to(event.x0, event.x1, event.y0, event.y1)

    def zoom_to(self, x0, x1, y0, y1):
        """The views now show image pixels x0..x1, y0..y1 (y up): send that region in the detail the
        screen allows, with a margin (half the view on each side, as far as the detail allows) so that a small
        pan needs nothing new. Nothing to do for an image that fits the screen whole."""
        if x0 is None or x1 is None or y0 is None or y1 is None:
            return
        h, w = self.shape
        side = state_module.LIMITS.max_view_side
        whole = block_size((h, w), (side, side))
        vx0, vx1 = max(0.0, min(x0, x1)), min(float(w), max(x0, x1))
        vy0, vy1 = max(0.0, min(y0, y1)), min(float(h), max(y0, y1))
        if (whole == 1 and self.region is None) or vx1 <= vx0 or vy1 <= vy0:
            return
        need = block_size((np.ceil(vy1 - vy0), np.ceil(vx1 - vx0)), (side, side))
        region = None
        if need < whole:
            my = max(0.0, min((vy1 - vy0) / 2, (need * side - (vy1 - vy0)) / 2 - 1))
            mx = max(0.0, min((vx1 - vx0) / 2, (need * side - (vx1 - vx0)) / 2 - 1))
            top, left = int(max(0, np.floor(vy0 - my))), int(max(0, np.floor(vx0 - mx)))
            bottom, right = int(min(h, np.ceil(vy1 + my))), int(min(w, np.ceil(vx1 + mx)))
            region = (top, left, bottom - top, right - left)
            if self.region is not None:  # the region shown already holds the view in as much detail: keep it
                t, l, rh, rw = self.region
                if t <= vy0 and l <= vx0 and t + rh >= vy1 and l + rw >= vx1 and block_size((rh, rw), (side, side)) <= need:
                    return
        if region == self.region:
            return
        self.region = region
        for key in self._full:
            self._send_screen(key)

    def _resize(self, shape):
        """A new image size: refit the views; reshape the frames only for a clearly different aspect ratio
        (each frame's new shape makes the browser lay the whole page out again, ~60 ms a frame)."""
        if tuple(shape) == self.shape:
            return
        self.shape = tuple(shape)
        self.region = None  # a region of the old image means nothing in the new one
        aspect = shape[1] / shape[0]
        if max(aspect / self.frame_aspect, self.frame_aspect / aspect) > ASPECT_TOLERANCE:
            self.frame_aspect = aspect
            for fig in self.figures.values():
                fig.aspect_ratio = aspect
        self.fit()

    def _changed(self, key, obj):
        """True when ``obj`` (a step's output, re-used by the cache when unchanged) is new for view ``key``."""
        if self._shown.get(key) is obj and obj is not None:
            return False
        self._shown[key] = obj
        return True

    # display arrays of a result: computed once per step output, in the computing thread when the page runs
    # one (``prepare``), here otherwise; each is (array(s) to send, numbers shown)
    def _raw_view(self, raw):
        data = np.asarray(raw.data)
        value = (data if data.ndim == 2 else data[..., 0]).astype(np.float32)[::-1]
        names = list(raw.sensor_names or ())
        if raw.mosaiced and raw.tile is not None and np.ndim(raw.tile) == 2:
            sensor = tile_index_map(raw.tile, data.shape[:2]).astype(np.uint8)[::-1]
        else:  # full colour: every pixel has every sensor; show the first plane's value
            sensor = np.zeros(data.shape[:2], np.uint8)
            names = [f"{names[0] if names else '0'} (all {len(names)} at every pixel)"]
        return dict(image=raw_rgba(raw), value=np.ascontiguousarray(value),
                    sensor=np.ascontiguousarray(sensor), names=names)

    @staticmethod
    def _de_view(de):
        de = np.asarray(de, float)
        finite = de[np.isfinite(de)]
        if finite.size:  # one partial sort for the median and the 99.5th percentile (histogram and colour range)
            median, p995 = (float(q) for q in np.percentile(finite, [50, 99.5]))
            mean = float(finite.mean())
        else:
            median = p995 = mean = float("nan")
        edges, counts, _ = histogram(finite, p995=p995)
        return dict(image=np.ascontiguousarray(de[::-1].astype(np.float32)), edges=edges, counts=counts,
                    data_range=de_range(finite, "data", p995=p995), mean=mean, median=median)

    def _de_scale(self, view):
        """(low, high) of the dE colours: the data's 0 to 99.5th percentile, or the fixed scale."""
        return view["data_range"] if self.state.de_scale == "data" else DE_RANGE

    def _de_coloured(self, de, view, low, high):
        """The dE map coloured for ``(low, high)``, kept while the map and the scale stay the same."""
        held = self._memos.get("de_rgba")
        if held is None or held[0] is not de or held[1] != (low, high):
            held = self._memos["de_rgba"] = (de, (low, high), de_rgba(view["image"], low, high))
        return held[2]

    def prepare(self, res):
        """Every display array of a new result (``ExplorerState.preparers``: runs in the computing thread).

        The views' arrays are independent of each other: on a large result they are made at once on the
        engine's block threads (:func:`camsim_core._parallel.run_blocks`; numpy and the compiled block means
        release the GIL), each view's in one of them. A frame-sized chart (860 x 1295 pixels): 160-200 ms
        in turn. A small result (the shipped scenes) is made here, in turn: threads would cost more than
        they save. Each task writes its own memo and screen entries (distinct keys)."""
        if res is None or res.raw is None:
            return

        def raw_task():
            raw = self._memo("raw_view", res.raw, self._raw_view)
            self._whole("raw", raw["image"], dict(value=raw["value"], sensor=raw["sensor"]))

        def image_task(key, make):
            return lambda: self._whole(key, self._memo(f"{key}_view", getattr(res, key), make), {})

        def de_task():
            view = self._memo("de_view", de, self._de_view)
            self._whole("de", self._de_coloured(de, view, *self._de_scale(view)), dict(value=view["image"]))

        def measures_task():
            self._memo("exposure", res.raw, lambda raw: exposure_warnings(raw, getattr(res, "camera", None)))
            self._memo("flags", res.raw, lambda raw: _exposure_flags(res))
            self._memo("rendered_y", res.xyz, _mean_y)
            self._memo("level", res.raw, lambda raw: mean_level(raw, getattr(res, "camera", None)))
            self._memo("raw_hash", res.raw, digest)
            self._memo("rendered_hash", res.rendered, digest)

        tasks = [raw_task]
        if res.demosaiced is not None:
            tasks.append(image_task("demosaiced", planes_rgba))
        tasks += [image_task(key, monitor_rgba) for key in ("rendered", "ideal") if getattr(res, key) is not None]
        de, _ = self.error_map(res)
        if de is not None:
            tasks.append(de_task)
        tasks.append(measures_task)
        pixels = int(np.prod(np.shape(res.raw.data)[:2]))
        run_blocks(lambda i, _: tasks[i](), range(len(tasks) + 1), values=pixels * len(tasks))

    def update(self):
        res = self.state.result
        if res is None or res.raw is None:
            return
        raw = res.raw
        self._resize(raw.data.shape[:2])
        if self._changed("raw", raw):
            view = self._memo("raw_view", raw, self._raw_view)
            self._show("raw", view["image"], names=view["names"], value=view["value"], sensor=view["sensor"])
        self.labels["raw"].object = self.TITLES["raw" if raw.mosaiced else "raw_full"]
        skipped = "demosaic" in getattr(res, "skipped", {})
        self.labels["demosaiced"].object = ("Sensor planes (full colour: no demosaicing)"
                                            if skipped else f"<span title='{_LINEAR_NOTE}'>Demosaiced "
                                                           f"({html_text(self.state.shown.get('demosaic_method', ''))})</span>")
        shape = raw.data.shape[:2]
        if self._changed("demosaiced", res.demosaiced):
            self._show("demosaiced", self._memo("demosaiced_view", res.demosaiced, planes_rgba)
                       if res.demosaiced is not None else _unavailable(shape))
        for key in ("rendered", "ideal"):
            img = getattr(res, key)
            if self._changed(key, img):
                self._show(key, self._memo(f"{key}_view", img, monitor_rgba) if img is not None else _unavailable(shape))
            self.labels[key].object = self.TITLES[key] + ("" if img is not None else " (not available)")
        de, label = self.error_map(res)
        mean = med = None
        if de is not None:
            view = self._memo("de_view", de, self._de_view)
            lo, hi = self._de_scale(view)
            self.colour_bar.set(lo, hi)
            coloured = self._de_coloured(de, view, lo, hi)
            if self._changed("de", coloured):
                self._show("de", coloured, value=view["image"])
            if self._changed("hist", de):
                edges, counts = view["edges"], view["counts"]
                self.hist_source.data = dict(left=edges[:-1], right=edges[1:], top=counts)
                # ranges set here, not left to the browser (which would send them back to the server)
                self.hist_figure.x_range.update(start=0, end=float(edges[-1]))
                self.hist_figure.y_range.update(start=0, end=1.05 * max(float(np.max(counts)), 1.0))
            mean, med = view["mean"], view["median"]
            self.mean_span.location, self.median_span.location = mean, med
            scale = "colours 0 to 99.5th pct" if self.state.de_scale == "data" else "fixed colours 0-20"
            self.labels["de"].object = (f"<span title='0 = identical to the ideal image; the colour scale is set "
                                        f"under Processing'>{label} dE map ({scale})</span>")
            self.labels["hist"].object = (f"{label} dE histogram: <span style='color:red'>mean {mean:.2f}</span>, "
                                          f"<span style='color:#d08000'>median {med:.2f}</span>")
        else:
            self.labels["de"].object = "dE map (not available)"
            if self._changed("de", None):
                missing = np.full(shape, np.nan, np.float32)
                self._show("de", de_rgba(missing, *DE_RANGE), value=missing)
                self._changed("hist", None)
        self.res_summary = (label, mean, med)
        self.show_computing()

    def _on_state(self, *events):
        """Redraw once per batch of state changes (a new result comes with ``computing`` False).

        When a computation starts, the busy marks appear only if it is still
        running after ``BUSY_DELAY_MS``: a quick result replaces the old one
        directly, in one message to the browser, instead of first marking six
        panes busy (each mark makes the browser lay the page out again).
        """
        names = {e.name for e in events}
        if "computing" in names:
            self._computations += 1  # each start and end; a timer of an earlier computation marks nothing
        if names & {"result", "metric", "de_scale"}:
            self.update()
        elif self.state.computing and not self._busy_shown and names == {"computing"}:
            _after(BUSY_DELAY_MS, partial(self._busy_if_still_computing, self._computations))
        else:
            self.show_computing()

    def _busy_if_still_computing(self, computation):
        """Mark the panes busy if the computation that started the timer is still the one running."""
        if self.state.computing and computation == self._computations:
            self.show_computing()

    def _memo(self, name, obj, fn):
        """``fn(obj)``, computed once per object (a step's output is the same object until it re-runs)."""
        held = self._memos.get(name)
        if held is None or held[0] is not obj:
            held = self._memos[name] = (obj, fn(obj))
        return held[1]

    def show_computing(self):
        """Stats, warnings and the status pane; panes marked as loading while a newer result is computed."""
        with pn.io.hold():
            self._show_computing()

    def _show_computing(self):
        res = self.state.result
        busy = bool(self.state.computing)
        self._busy_shown = busy
        # One mark over the views' grid (a mark per view made six of them to show a computation and six more to
        # end it), set in its styles, which the browser applies without laying the page out (STILL_BUSY_CSS).
        styles = BUSY_STYLES if busy else IDLE_STYLES
        if self.grid.styles != styles:
            self.grid.styles = styles
        if res is None or res.raw is None:
            return
        label, mean, med = getattr(self, "res_summary", (self.state.metric, None, None))
        steps = [n.removeprefix("stage:") for n, _ in res.ran]
        engine_s = getattr(res, "elapsed", 0.0) or res.seconds  # wall time (the ideal side may run beside)
        head = "<strong>Computing the new result...</strong> (the images below are the previous one) · " if busy else ""
        # a black, empty or clipped frame: its warning stands beside the dE, as large (the score is not a good one)
        flags = self._memo("flags", res.raw, lambda raw: _exposure_flags(res))
        flagged = "".join(f" <strong class='camsim-flag' style='color:#c00000'>⚠ {html.escape(f)}</strong>" for f in flags)
        if mean is None:
            self.stats.object = f"<p>{head}dE not available{flagged}</p>"
        else:
            view = (f" · viewing {html.escape(str(self.state.viewing))}, {res.samples_per_degree:.4g} samples/deg"
                    if label == "S-CIELAB" and getattr(res, "samples_per_degree", None) else "")
            self.stats.object = (f"<p>{head}<strong>{label}</strong> mean dE <strong>{mean:.2f}</strong>{flagged} · median "
                                 f"<strong>{med:.2f}</strong>{view} · engine {1000 * engine_s:.0f} ms "
                                 f"({', '.join(steps) or 'nothing re-run'})</p>")
        camera = getattr(res, "camera", None)
        clipped, dark = self._memo("exposure", res.raw, lambda raw: exposure_warnings(raw, camera))
        exposure = getattr(res, "exposure", None)  # the engine's measures of the frame (made once per raw)
        unbounded = exposure is not None and not exposure.bounded
        if unbounded:  # no full scale to be a share of ("mean level 25018 % of full scale") nor to be dark in
            dark = 0.0
        notes = []
        if clipped > 0.01:
            where = "at the full well or full scale" if saturation_level(camera) is not None else "at full scale"
            notes.append(f"⚠ {100 * clipped:.1f} % of pixels are clipped ({where}): lower the exposure")
        # under-exposed: many dark pixels and a low bright end (a chart's black surround is dark content)
        if dark > 0.25 and self._memo("bright_end", res.raw, lambda raw: bright_end(raw, camera)) < 0.5:
            notes.append(f"⚠ {100 * dark:.0f} % of pixels are in the lowest 2 % of the digital range: "
                         "under-exposed (try Auto exposure)")
        level = self._memo("level", res.raw, lambda raw: mean_level(raw, getattr(res, "camera", None)))
        if unbounded:  # the chapter's cameras at 0 bits: the raw in digital units, unbounded
            self.warnings.object = (f"<p>Unquantized, in digital units: nothing clips and there is no full scale · "
                                    f"mean level {255 * level:.4g} DU</p>")
        else:
            self.warnings.object = "<p>" + (" · ".join(notes) or
                                            f"Clipped {100 * clipped:.1f} % · in the lowest 2 % of levels "
                                            f"{100 * dark:.1f} %") + f" · mean level {100 * level:.0f} % of full scale</p>"
        self.status_data = {
            "params": getattr(res, "params", self.state.to_dict()),
            "computing": busy,
            "mean_de": None if mean is None else round(mean, 4),
            "median_de": None if med is None else round(med, 4),
            "metric": label,
            "raw_hash": self._memo("raw_hash", res.raw, digest),
            "rendered_hash": self._memo("rendered_hash", res.rendered, digest),
            "tile": None if res.raw.tile is None else np.asarray(res.raw.tile).tolist(),
            "shape": list(res.raw.data.shape[:2]),
            "skipped": sorted(getattr(res, "skipped", {})),
            "errors": res.errors,
            "ran": [[name, round(t * 1000, 2)] for name, t in res.ran],
            "engine_ms": round(engine_s * 1000, 2),
            "clipped": round(clipped, 4), "dark": round(dark, 4),
            "flags": list(flags),
            "rendered_mean_y": self._memo("rendered_y", res.xyz, _mean_y),
            "message": self.state.message,
        }
        self.status.object = "<pre>" + html.escape(json.dumps(self.status_data, separators=(",", ":"))) + "</pre>"

    def error_map(self, res):
        if self.state.metric == "S-CIELAB" and res.scielab is not None:
            return res.scielab, "S-CIELAB"
        if res.delta_e is not None:
            return res.delta_e, "CIELAB"
        return None, self.state.metric

    # downloads
    def rendered_png(self):
        from PIL import Image

        res = self.state.result
        buf = io.BytesIO()
        if res is None or res.rendered is None:
            return None
        Image.fromarray(np.clip(np.rint(np.asarray(res.rendered.data, float)), 0, 255).astype(np.uint8)).save(buf, "PNG")
        buf.seek(0)
        return buf

    def raw_tiff(self):
        import tifffile

        res = self.state.result
        if res is None or res.raw is None:
            return None
        data = np.asarray(res.raw.data)
        data = data.astype(np.uint16) if res.raw.quantized and (res.raw.bits or 16) <= 16 else data.astype(np.float32)
        buf = io.BytesIO()
        tifffile.imwrite(buf, data, description=json.dumps(res.raw.metadata()))
        buf.seek(0)
        return buf

    def de_csv(self):
        res = self.state.result
        de, label = self.error_map(res) if res is not None else (None, "")
        if de is None:
            return None
        buf = io.StringIO()
        np.savetxt(buf, np.asarray(de, float), fmt="%.4f", delimiter=",",
                   header=f"{label} dE per camera pixel (rows top to bottom)")
        return io.BytesIO(buf.getvalue().encode())


#: The wavelength slider's value shown as its band's wavelength in nm (the slider counts the scene's bands).
_BAND_LABEL_JS = "const w = wavelengths[Math.round(tick)]; return w === undefined ? '' : String(Math.round(w * 10) / 10);"


# -- the scene: one plane, sRGB, spectra of clicked pixels, metadata -------
class SceneView(TabView):
    """The scene before the camera: sRGB and one plane side by side (sharing zoom), spectra of
    clicked pixels (numbered markers in their curve's colour) and of box-selected regions.

    A :class:`~camsim_explorer.tab.TabView` following the state's scene and wavelength through its tab's
    gate; its wavelength slider sets the state's.

    Examples
    --------
    >>> from camsim_explorer.state import ExplorerState
    >>> state = ExplorerState(scene="macbeth")
    >>> view = SceneView(state)
    >>> view.wavelength.value = 20  # the scene's 21st band
    >>> state.wavelength, ">Radiance at 600 nm, grey 0 to " in view.plane_label.object
    (600.0, True)
    """

    MAX_SPECTRA = 6
    COLORS = Category10[10]
    UNIT = "W/sr/m² per band"

    def __init__(self, state, when_shown=now, **params):
        """``when_shown``: the tab's gate (:class:`~camsim_explorer.shown.WhenShown`): updates wait while hidden."""
        self.shape = (2, 2)
        self.x_range, self.y_range = Range1d(0, 2), Range1d(0, 2)
        self.rgb_source = ColumnDataSource(dict(image=[np.zeros((2, 2), np.uint32)], x=[0], y=[0], dw=[2], dh=[2]))
        self.plane_source = ColumnDataSource(dict(image=[np.zeros((2, 2), np.float32)], x=[0], y=[0], dw=[2], dh=[2]))
        self.marks = ColumnDataSource(dict(x=[], y=[], text=[], color=[], w=[], h=[]))
        self.plane_mapper = LinearColorMapper(palette=Greys256, low=0, high=1)  # black at 0, white at the maximum
        self.figures = {}
        for key in ("rgb", "plane"):
            fig = _image_figure(self.x_range, self.y_range, f"camsim-scene-{key}-figure", self.shape)
            box = BoxSelectTool()
            fig.add_tools(TapTool(), box)
            fig.toolbar.active_drag = box  # "drag a box" selects a region (a drag panned the image)
            if key == "rgb":
                r = fig.add_glyph(self.rgb_source, _rgba_glyph())
                fig.add_tools(HoverTool(renderers=[r], tooltips=[("x, y", "$x{0}, $y{0}"), ("sRGB", "@image{custom}")],
                                        formatters={"@image": _rgb_hover()}))
            else:
                r = fig.add_glyph(self.plane_source, Image(image="image", x="x", y="y", dw="dw", dh="dh",
                                                           color_mapper=self.plane_mapper))
                fig.add_tools(HoverTool(renderers=[r], tooltips=[("x, y", "$x{0}, $y{0}"),
                                                                 (f"radiance ({self.UNIT})", "@image{0.0000}")]))
            fig.rect(x="x", y="y", width="w", height="h", source=self.marks, fill_alpha=0.25, fill_color="color",
                     line_color="color", line_width=2)
            fig.text(x="x", y="y", text="text", source=self.marks, text_color="color", text_font_size="14pt",
                     text_font_style="bold", x_offset=6, y_offset=-4, text_outline_color="white")
            # a click within Bokeh's double-tap window of the one before comes as a double tap, not a tap: two
            # pixels clicked quickly added only the first (a double click on one pixel comes as both: added once)
            fig.on_event(Tap, held(self._on_tap))
            fig.on_event(DoubleTap, held(self._on_tap))
            fig.on_event(SelectionGeometry, held(self._on_box))
            self.figures[key] = fig
        self.spectra = []  # (scene, row0, row1, col0, col1)
        self.curves = ColumnDataSource(dict(xs=[], ys=[], color=[], label=[]))
        spec = figure(height=280, sizing_mode="stretch_width", tools="pan,wheel_zoom,reset", toolbar_location="right",
                      x_axis_label="Wavelength (nm)", y_axis_label=f"Radiance ({self.UNIT})",
                      name="camsim-spectra-figure", x_range=DataRange1d(), y_range=DataRange1d(start=0))
        spec.multi_line(xs="xs", ys="ys", line_color="color", line_width=2, source=self.curves,
                        legend_field="label")
        # the scene's wavelengths at zero radiance, undrawn: an extent for the fitted ranges before any spectrum
        # is clicked (the browser logged "could not set initial ranges" at each visit of the empty plot)
        self._extent = ColumnDataSource(dict(x0=[400.0], x1=[700.0], y=[0.0]))
        spec.segment("x0", "y", "x1", "y", source=self._extent, line_alpha=0)
        spec.legend.location = "top_left"
        spec.legend.background_fill_alpha = 0.6
        spec.add_layout(spec.legend[0], "right")
        self.wl_span = Span(location=550, dimension="height", line_color="black", line_dash="dotted", line_width=2)
        spec.add_layout(self.wl_span)
        self.spectrum_figure = spec
        self.rgb_label = _label("Scene (sRGB): click a pixel, or drag a box (box select) for a region's mean",
                                "camsim-scene-rgb-label")
        self.plane_label = _label("Radiance at 550 nm", "camsim-scene-plane-label")
        self.rgb_pane = pn.Column(self.rgb_label, pn.pane.Bokeh(self.figures["rgb"], sizing_mode="stretch_width"),
                                  css_classes=["camsim-scene-rgb", "camsim-view"], sizing_mode="stretch_width")
        self.plane_bar = ColourBar(self.plane_mapper, f"radiance ({self.UNIT})", "camsim-plane-colorbar")
        self.plane_pane = pn.Column(self.plane_label, pn.pane.Bokeh(self.figures["plane"], sizing_mode="stretch_width"),
                                    pn.pane.Bokeh(self.plane_bar.figure, sizing_mode="stretch_width"),
                                    css_classes=["camsim-scene-plane", "camsim-view"], sizing_mode="stretch_width")
        self.spectrum_pane = pn.Column(
            _label("Spectra of clicked pixels and regions (dotted: the wavelength shown)", "camsim-spectra-label"),
            pn.pane.Bokeh(spec, sizing_mode="stretch_width"), css_classes=["camsim-spectra"], sizing_mode="stretch_width")
        self.meta = pn.pane.Markdown("", css_classes=["camsim-scene-meta"], sizing_mode="stretch_width")
        self.clear = pn.widgets.Button(label="Clear spectra", css_classes=["w-clear-spectra"], width=120)
        self.clear.on_click(lambda e: self.reset_spectra())
        # the scene's bands by index, the title showing the band's wavelength (formatted in the browser): a
        # DiscreteSlider links its label to its slider with a Panel link, and any Panel link makes Panel look
        # for links over the whole page at every tab switch
        self._wavelengths = [550.0]
        self._band_label = CustomJSTickFormatter(code=_BAND_LABEL_JS, args={"wavelengths": self._wavelengths})
        self.wavelength = pn.widgets.IntSlider(label="Wavelength (nm)", start=0, end=1, value=0,
                                               format=self._band_label, css_classes=["w-wavelength"], width=280)
        self._scene, self._scene_name = None, None
        super().__init__(state, when_shown, **params)
        self._layout = pn.Column(pn.Row(self.wavelength, self.clear),
                                 pn.Row(self.rgb_pane, self.plane_pane, sizing_mode="stretch_width"),
                                 pn.Row(self.spectrum_pane, self.meta, sizing_mode="stretch_width"),
                                 sizing_mode="stretch_width")
        self.update()

    @param.depends("wavelength.value", watch=True)
    def _wavelength_chosen(self):
        self.state.wavelength = self._wavelengths[min(self.wavelength.value, len(self._wavelengths) - 1)]

    # the light level too: the scene shown is the scene under it (the tab kept the old radiance, spectra and facts)
    @param.depends("state.scene", "state.light", "state.wavelength", watch=True)
    def _on_change(self):
        self._update_when_shown()

    def scene(self):
        try:
            return self.state.scene_object()
        except Exception:
            return None

    def update(self):
        scene = self.scene()
        if scene is None:
            return
        note = self.state.wavelength_in_scene(scene)  # the address changed to a wavelength beyond the scene's
        if note:
            self.state.notice = note
        wls = [float(w) for w in scene.wavelengths]
        k = int(np.argmin(np.abs(np.asarray(wls) - float(self.state.wavelength))))
        if self._wavelengths != wls:
            self._wavelengths = wls
            self._band_label.args = {"wavelengths": wls}
            self.wavelength.param.update(end=max(len(wls) - 1, 1), disabled=len(wls) < 2)
        if self.wavelength.value != k:
            self.wavelength.value = k
        h, w = scene.data.shape[:2]
        if scene is not self._scene:
            # the same scene under another light level: the clicked spectra stay, read from it
            relit = (self._scene is not None and self.state.scene == self._scene_name and self._scene.data.shape ==
                     scene.data.shape and np.array_equal(self._scene.wavelengths, scene.wavelengths))
            self._scene, self._scene_name = scene, self.state.scene
            if (h, w) != self.shape:
                self.shape = (h, w)
                for fig in self.figures.values():
                    fig.aspect_ratio = w / h
            self.x_range.update(start=0, end=w)
            self.y_range.update(start=0, end=h)
            self.rgb_source.data = dict(image=[rgba32(scene_srgb(scene))], x=[0], y=[0], dw=[w], dh=[h])
            d = scene.describe() if hasattr(scene, "describe") else {}
            # names, units and notices come from the scene's file: shown as text
            rows = [f"| {md_text(label)} | {md_text(text)} |" for label, text in scene_facts(d)]
            self.meta.object = "| | |\n|---|---|\n" + "\n".join(rows)
            self._extent.data = dict(x0=[wls[0]], x1=[wls[-1]], y=[0.0])
            if relit:
                self.spectra = [(scene, *where) for _, *where in self.spectra]
                self._draw()
            else:
                self.reset_spectra()
        plane = np.asarray(scene.data[:, :, k], np.float32)
        top = float(np.percentile(plane, 99.5)) or float(plane.max()) or 1.0
        self.plane_bar.set(0.0, top)
        self.plane_source.data = dict(image=[np.ascontiguousarray(plane[::-1])], x=[0], y=[0], dw=[w], dh=[h])
        # short enough for one line beside the sRGB view at 1366 px (the scale's top came last and was cut off);
        # the whole sentence on hover, the unit on the colour bar's axis
        self.plane_label.object = (f"<span title='Radiance at {wls[k]:g} nm ({self.UNIT}): the grey scale runs from 0 "
                                   f"to this plane&#39;s 99.5th percentile, {top:.3g}'>Radiance at {wls[k]:g} nm, "
                                   f"grey 0 to {top:.3g} (99.5th pct)</span>")
        self.wl_span.location = wls[k]

    # clicks and boxes, in scene pixels (x right, y up from the bottom edge)
    def _on_tap(self, event):
        self.on_tap(event.x, event.y)

    def on_tap(self, x=None, y=None):
        scene = self.scene()
        if scene is None or x is None or y is None:
            return
        h, w = scene.data.shape[:2]
        col, row = int(np.floor(x)), int(h - 1 - np.floor(y))
        if not (0 <= row < h and 0 <= col < w):
            return
        if self.spectra and self.spectra[-1][0] is scene and self.spectra[-1][1:] == (row, row + 1, col, col + 1):
            return  # the same pixel again (a double click is a tap and a double tap)
        self._add(scene, row, row + 1, col, col + 1)

    def _on_box(self, event):
        g = event.geometry or {}
        if g.get("type") != "rect" or not getattr(event, "final", True):
            return
        scene = self.scene()
        if scene is None:
            return
        h, w = scene.data.shape[:2]
        c0, c1 = sorted((g["x0"], g["x1"]))
        r_lo, r_hi = sorted((g["y0"], g["y1"]))
        col0, col1 = max(0, int(np.floor(c0))), min(w, int(np.ceil(c1)))
        row0, row1 = max(0, int(h - np.ceil(r_hi))), min(h, int(h - np.floor(r_lo)))
        if col1 > col0 and row1 > row0:
            self._add(scene, row0, row1, col0, col1)

    def _add(self, scene, row0, row1, col0, col1):
        self.spectra = (self.spectra + [(scene, row0, row1, col0, col1)])[-self.MAX_SPECTRA:]
        self._draw()

    def reset_spectra(self):
        self.spectra = []
        self._draw()

    def _draw(self):
        xs, ys, colors, labels, mx, my, mt, mc, mw, mh = [], [], [], [], [], [], [], [], [], []
        for i, (scene, r0, r1, c0, c1) in enumerate(self.spectra):
            h = scene.data.shape[0]
            color = self.COLORS[i % len(self.COLORS)]
            xs.append(np.asarray(scene.wavelengths, float))
            ys.append(scene.data[r0:r1, c0:c1].reshape(-1, scene.data.shape[2]).mean(axis=0))
            colors.append(color)
            single = (r1 - r0) * (c1 - c0) == 1
            labels.append(f"{i + 1}: pixel ({r0}, {c0})" if single else
                          f"{i + 1}: mean of rows {r0}-{r1 - 1}, columns {c0}-{c1 - 1}")
            mx.append((c0 + c1) / 2)
            my.append(h - (r0 + r1) / 2)
            mt.append(str(i + 1))
            mc.append(color)
            mw.append(max(c1 - c0, 1))
            mh.append(max(r1 - r0, 1))
        self.curves.data = dict(xs=xs, ys=ys, color=colors, label=labels)
        self.marks.data = dict(x=mx, y=my, text=mt, color=mc, w=mw, h=mh)


# -- the camera: sensor curves and mosaic tile -------------------------------
class CameraView(TabView):
    """Sensor curves and the mosaic tile of the camera shown; redrawn only when those change.

    A :class:`~camsim_explorer.tab.TabView` following the state's result through its tab's gate.

    Examples
    --------
    >>> from camsim_explorer.state import ExplorerState
    >>> view = CameraView(ExplorerState(camera="human-cones"))
    >>> view.curve_source.data["label"]
    ['L', 'M', 'S']
    """

    def __init__(self, state, when_shown=now, **params):
        self._key = None
        self.curve_source = ColumnDataSource(dict(xs=[], ys=[], color=[], label=[]))
        fig = figure(height=300, sizing_mode="stretch_width", tools="pan,wheel_zoom,reset", toolbar_location="right",
                     x_axis_label="Wavelength (nm)", y_axis_label="Sensitivity", name="camsim-sensors-figure",
                     x_range=DataRange1d(), y_range=DataRange1d(start=0))
        fig.multi_line(xs="xs", ys="ys", line_color="color", line_width=3, source=self.curve_source,
                       legend_field="label")
        fig.add_layout(fig.legend[0], "right")
        self.curve_figure = fig
        self.tile_source = ColumnDataSource(dict(x=[], y=[], color=[], text=[]))
        tile = figure(width=260, height=260, tools="", toolbar_location=None, name="camsim-tile-figure",
                      x_range=Range1d(0, 2), y_range=Range1d(0, 2), min_border=10, match_aspect=True)
        tile.rect(x="x", y="y", width=1, height=1, fill_color="color", line_color="white", source=self.tile_source)
        tile.text(x="x", y="y", text="text", source=self.tile_source, text_align="center", text_baseline="middle",
                  text_font_size="12pt", text_color="black")
        tile.axis.visible = False
        tile.grid.visible = False
        self.tile_figure = tile
        self.title = _label("Sensors", "camsim-sensors-label")
        self.tile_label = _label("Mosaic tile", "camsim-tile-label")
        self.curves = pn.Column(self.title, pn.pane.Bokeh(fig, sizing_mode="stretch_width"),
                                css_classes=["camsim-sensors"], sizing_mode="stretch_width")
        self.tile = pn.Column(self.tile_label, pn.pane.Bokeh(tile), css_classes=["camsim-tile"], width=280)
        self.info = pn.pane.Markdown("", css_classes=["camsim-camera-info"], sizing_mode="stretch_width")
        super().__init__(state, when_shown, **params)
        self._layout = pn.Column(self.info, pn.Row(self.curves, self.tile), sizing_mode="stretch_width")
        self.update()

    def update(self):
        """Show the camera of the state's result: its name and image; its sensor curves and mosaic tile drawn
        again only when they changed."""
        res = self.state.result
        if res is None:
            return
        cam = res.camera
        self.info.object = (f"**{md_text(cam.name)}** · {len(cam.sensors)} sensors · image {res.raw.data.shape[0]} x "
                            f"{res.raw.data.shape[1]} px at {cam.distance} m · {cam.exposure:g} s f/{cam.f_stop:g}")
        key = (fingerprint(cam.sensors), fingerprint(cam.mosaic))
        if key == self._key:
            return
        self._key = key
        wls = np.asarray(cam.sensors.wavelengths, float)
        colors = sensor_colors(cam.sensors.values, wls, cam.sensors.names)
        names = list(cam.sensors.names)
        self.curve_source.data = dict(xs=[wls] * len(names), ys=[np.asarray(v, float) for v in cam.sensors.values],
                                      color=[_hex(c) for c in colors], label=names)
        self.title.object = f"Sensors: {html_text(cam.sensors.name or cam.name)}"
        t = None if cam.mosaic is None else np.asarray(cam.mosaic)
        if t is None:
            self.tile_label.object = "No mosaic: every pixel has every sensor"
            self.tile_source.data = dict(x=[0.5], y=[0.5], color=["#dddddd"], text=["all sensors"])
            n = m = 1
        else:
            if t.ndim == 3:
                t = t[..., 0]
            n, m = t.shape
            # short enough for the tile's 280 px at presentation size; each cell reads "index:sensor" (0-based)
            self.tile_label.object = f"Mosaic tile, {n} x {m}"
            self.tile_source.data = dict(
                x=[j + 0.5 for i in range(n) for j in range(m)], y=[n - i - 0.5 for i in range(n) for j in range(m)],
                color=[_hex(colors[t[i, j]]) for i in range(n) for j in range(m)],
                text=[f"{t[i, j]}:{names[t[i, j]]}" for i in range(n) for j in range(m)])
        self.tile_figure.x_range.update(start=0, end=max(n, m))
        self.tile_figure.y_range.update(start=0, end=max(n, m))


def _hex(rgb):
    r, g, b = (int(round(255 * float(np.clip(c, 0, 1)))) for c in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"
