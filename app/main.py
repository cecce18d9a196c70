"""The explorer page: ``create_app()`` builds one session's page around a fresh state.

Serve it with ``camsim serve`` (``pn.serve(create_app, ...)``): Panel calls
``create_app`` once per browser session, so each session has its own
:class:`~camsim_explorer.state.ExplorerState` (parameters and cached pipeline), while
scenes, cameras and monitors are read once per process and shared read-only.

In the server, each session computes in a background thread of its own
(:class:`~camsim_explorer.state.Runner`) and shows the outcome on its document's next
tick: the Tornado event loop, shared by all sessions, never waits for the
engine. The page is a ``FastListTemplate``: controls in the sidebar, results
in tabs (``TABS``: one line per tab).
"""

from __future__ import annotations

import io
import json
import logging
import threading
import urllib.parse
import weakref
from functools import partial

import panel as pn
from bokeh.core.validation import silence
from bokeh.core.validation.warnings import FIXED_SIZING_MODE

from camsim_core.camera.physical import PHYSICAL_NAMES
from camsim_core.scene.charts import CHART_NAMES, chart_defaults

from . import compat
from .compat import hooks as _compat
from .compat.number_box import FloatInput  # reads any number the browser sends
from . import state as state_module
from .body_class import BodyClass
from .compare import compare_tab
from .history import HistoryFollower
from .number_slider import NumberSlider
from .physical import SensorControls
from .quality import QualityView
from .safe_text import md_text
from .shown import WhenShown, next_tick, now, page_being_built
from .state import (COMPARE_PARAMETERS, PAGE_PARAMETERS, TAB_NAMES, URL_PARAMETERS, VIEW_PARAMETERS,
                    ExplorerState, Runner, bits_choices)
from .typed_text import TypedTextWatch
from .upload import BoundedUpload
from .views import CameraView, ResultsView, SceneView, Text, _after, once, when_page_ready

__all__ = ["create_app", "DEFAULT_SCENE", "configure", "LIVE_STATES", "live_states", "TABS"]

DEFAULT_SCENE = "cacaphony290"
_options = {"scene": None, "upload": True}
#: Every session's state while it lives (weak: a closed session's state must be freed).
LIVE_STATES = weakref.WeakSet()
_LIVE_LOCK = threading.Lock()  # pages are built in a thread (app/compat/build_off_loop.py) while the loop looks at them


def live_states():
    """The sessions' states alive now (a list: safe while a page is being built in another thread)."""
    with _LIVE_LOCK:
        return list(LIVE_STATES)


#: Each session's document -> its state (weak both ways: nothing here keeps a closed session alive).
_STATE_OF_DOC = weakref.WeakKeyDictionary()


def state_of(doc):
    """The explorer state shown in Bokeh document ``doc``; None for a document the explorer did not build."""
    with _LIVE_LOCK:
        ref = _STATE_OF_DOC.get(doc)
    return ref() if ref is not None else None
#: Called after a closed session is released (``camsim serve`` gives freed memory back to the system here).
AFTER_RELEASE = []

START_HERE = """**Start here.** A camera design (sidebar) looks at a hyperspectral scene. The
*Results* tab shows what the camera records (raw mosaic), its processing (demosaiced,
rendered) and how far the rendered image is from the **ideal image**: what a human observer
would see of the same scene on the same monitor (cone sensors, no mosaic, no noise).
**dE** is the colour difference per pixel in CIELAB units (about 1 is just noticeable);
**S-CIELAB** first blurs both images as the eye does, so fine-grain noise counts less.
Move one control at a time and watch the mean dE."""

#: Presentation mode: large type and images for a projector (a class on the page's body).
_PRESENT_CSS = """
body.camsim-present { --bokeh-font-size: 20px; --base-font-size: 20px; font-size: 20px; --camsim-scale: 1.5; }
body.camsim-present .bk-input, body.camsim-present label { font-size: 20px; }
"""
#: How much larger presentation mode makes the controls' text: 1.5 x the browser's 13.3 px (inputs, selects)
#: and Bootstrap's 12.8 px (buttons) gives 20 and 19.2 px, readable from the back of a room.
PRESENT_SCALE = 1.5
#: In every widget's own style (its shadow root, where the page's CSS does not reach): the controls' text
#: scaled by ``--camsim-scale``, which presentation mode sets on the page's body and custom properties carry
#: into shadow roots (1 otherwise: the sizes a page has without it).
_CONTROL_CSS = (".bk-input, select, option, input { font-size: calc(13.333px * var(--camsim-scale, 1)); }\n"
                ".bk-btn, button.card-header { font-size: calc(12.8px * var(--camsim-scale, 1)); }")
#: Plots draw their text on a canvas, out of CSS's reach: presentation mode gives their document a Bokeh theme.
PRESENT_PLOT_TEXT = {"axis_label": "20px", "tick_label": "18px", "title": "20px", "legend": "18px"}
#: The page's icon, in the page itself: a 2 x 2 Bayer tile (G R / B G). The explorer writes its parameters into
#: the address on every change, and Chromium fetches a linked icon again after each such change: one HTTP
#: request to the server per move, handled on the event loop that also serves the results.
FAVICON = ("data:image/svg+xml,%3Csvg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 2 2'%3E"
           "%3Crect width='1' height='1' fill='%2300a050'/%3E%3Crect x='1' width='1' height='1' fill='%23d02020'/%3E"
           "%3Crect y='1' width='1' height='1' fill='%232050d0'/%3E%3Crect x='1' y='1' width='1' height='1' "
           "fill='%2300a050'/%3E%3C/svg%3E")

#: Where a refusal shows: fixed at the window's top right, below the header, over the page.
_FLOATING = {"position": "fixed", "top": "64px", "right": "16px", "z-index": "1050", "max-width": "80vw",
             "box-shadow": "0 4px 16px rgba(0, 0, 0, 0.25)"}
#: Tab titles that do not fit (presentation mode, a narrow window) go to a second row, not out of sight.
_TAB_TITLES_WRAP = ".bk-header { overflow: visible; } .bk-headers-wrapper { flex-wrap: wrap; overflow: visible; }"
_BIG = ":host { font-size: var(--camsim-text, inherit); } p, span, div, label, td, th, li { font-size: inherit; }"


class _ClosedTabFilter(logging.Filter):
    """Drop Bokeh's per-message warning when a tab closed while its last updates were on the way
    (expected, harmless: the session is going away)."""

    def filter(self, record):
        return "connection was closed" not in record.getMessage()


def _quiet_known_warnings():
    """Bokeh's warnings the explorer expects, silenced (once; called by :func:`create_app`, not on import)."""
    ws = logging.getLogger("bokeh.server.views.ws")
    if not any(isinstance(f, _ClosedTabFilter) for f in ws.filters):
        ws.addFilter(_ClosedTabFilter())
    # Plots sized by their frame (frame_width / frame_height) are valid but make Bokeh warn
    # W-1005 FIXED_SIZING_MODE once per plot and session: silence that one check, not the log.
    silence(FIXED_SIZING_MODE, True)


def configure(scene=None, *, limits=None, upload=True):
    """Set what new sessions get (``camsim serve``): the scene they open on, the limits, whether uploads are offered."""
    _options["scene"] = scene
    _options["upload"] = bool(upload)
    if limits is not None:
        state_module.LIMITS = limits


def warm_up():
    """Compute the first page's result once, before the server takes requests.

    The first visitor then gets a page whose result is at hand (sessions start
    from this one's pipeline memory, see ``ExplorerState._compute``), and the
    engine's compiled kernels (those of the other demosaicing methods too)
    and lazy imports are ready: on a cold start compiling them took seconds
    while the server answered nothing else.
    Returns the seconds it took.
    """
    import time

    t0 = time.perf_counter()
    state = _new_state(None)
    state.recompute()  # no runner: computes here
    res = state.result
    if res is not None and res.raw is not None and res.xyz is not None and res.ideal_xyz is not None:
        # the kernels other choices use (Freeman's median, the Bayesian filters) and S-CIELAB's FFT plans and
        # kernel spectra: loaded here once, not by the first visitor who picks them (memory that stays for the
        # process, as the shipped data does)
        from camsim_core import demosaic, metrics
        from camsim_core.errors import CamsimError

        for method in ("freeman", "bayesian"):
            try:
                demosaic(res.raw, method)
            except CamsimError:  # a start-up scene or mosaic the method refuses: it loads on first use instead
                pass
        metrics.scielab(res.xyz, res.ideal_xyz, metrics.samples_per_degree(res.raw), res.white)
    return time.perf_counter() - t0


def _release(state, page, template=None):
    """Break a closed session's links so that its state, pipeline and views are freed.

    Widgets made with ``from_param`` and the views watch the state, and the
    state's watchers point back at them; dropping the watchers, the cached
    pipeline, the uploads, the last result, the widgets' browser-side links
    and the page's children leaves nothing that reaches the session's arrays.
    """
    if template is not None:
        _compat.forget_js_links([page, *list(template.sidebar), *list(template.header)])
        template.state = None
    for group in list(state.param.watchers.values()) if hasattr(state.param, "watchers") else []:
        for watchers in list(group.values()):
            for w in list(watchers):
                try:
                    state.param.unwatch(w)
                except Exception:
                    pass
    state.pipeline = None
    state._uploads.clear()
    state._lit = None
    state.preparers.clear()  # the views' display-array makers (and through them, the views' arrays)
    with param_discard(state):
        state.result = None
    page.objects = []
    page.state = None
    for hook in AFTER_RELEASE:
        hook()


def param_discard(obj):
    import param

    return param.parameterized.discard_events(obj)


def _later(fn):
    """Run ``fn`` on the next tick of this session's event loop (now, outside a server)."""
    doc = pn.state.curdoc
    if doc is not None and doc.session_context is not None:
        next_tick(doc, fn)
    else:
        fn()


def _bind(widget, state, name):
    """Link ``widget`` and ``state.<name>`` both ways; a refused value gets a message (``state.set_value``)
    and the widget returns to the value in force."""
    busy = [False]

    def from_widget(event):
        if busy[0]:
            return
        kept = state.set_value(name, event.new)
        if kept != event.new:
            _later(lambda: to_widget(kept))

    def to_widget(value):
        busy[0] = True
        try:
            widget.value = value
        finally:
            busy[0] = False

    widget.param.watch(from_widget, "value")
    state.param.watch(lambda e: to_widget(e.new), name)
    return widget


def _number(cls, state, name, css, label, **kw):
    """A numeric widget without client-side limits (the state checks them and says why)."""
    return _bind(cls(label=label, value=getattr(state, name), css_classes=[css], sizing_mode="stretch_width", **kw),
                 state, name)


def _slider_number(state, name, css, label, start, end, step):
    """A number box over a slider (:class:`NumberSlider`), linked to ``state.<name>`` as :func:`_number`."""
    return _bind(NumberSlider(label=label, css=css, start=start, end=end, step=step, value=getattr(state, name)),
                 state, name)


def _select(state, name, css, label):
    return pn.widgets.Select.from_param(state.param[name], label=label, css_classes=[css], sizing_mode="stretch_width")


def _controls(state, results):
    w = pn.widgets
    scene = _select(state, "scene", "w-scene", "Scene")
    chart_options = pn.widgets.TextInput(label="Chart options (key=value, ...; Enter applies)", css_classes=["w-chart"],
                                         sizing_mode="stretch_width")

    def on_scene(*_):
        """The chart options box follows the scene: shown for a test chart, holding its options."""
        base, _, options = state.scene.partition(":")
        chart_options.visible = base in CHART_NAMES
        if chart_options.visible:
            chart_options.value = options
            chart_options.placeholder = ", ".join(f"{k}={v}" for k, v in chart_defaults(base).items())[:200]

    def on_chart_options(event):
        state.set_chart(event.new)
        # on the next tick: the box then shows the options in force (tidied, or those of the chart in use
        # after a refusal); set during the browser's own change, the value would not be sent back
        state.defer(on_scene)

    state.param.watch(on_scene, "scene")
    chart_options.param.watch(on_chart_options, "value")
    on_scene()
    limits = state_module.LIMITS
    upload = BoundedUpload(accept=".npz,.zip,.mat,.png,.jpg,.jpeg", max_bytes=limits.upload.max_upload_bytes, css_classes=["w-upload"],
                           sizing_mode="stretch_width", visible=_options["upload"])

    def on_upload(event):  # the widget lets go of the bytes when this returns; the read has its own copy
        if event.new is None:
            return
        filename, content = upload.filename, event.new
        doc = pn.state.curdoc
        if doc is None or doc.session_context is None:  # outside a server: read here
            state.add_upload(filename, content)
            return
        state.notice = f"Reading {state_module.short_repr(filename)}..."

        def show(outcome):
            state.notice = ""
            state.accept_upload(outcome)

        def read():  # in a thread: the read itself runs in a worker process, the event loop never waits for it
            outcome = state.read_upload(filename, content)
            next_tick(doc, partial(show, outcome))  # nothing to show if the session closed meanwhile

        state_module.UPLOAD_THREADS.submit(read)  # a thread kept for reads: starting one here waits for the GIL

    def on_refused(event):
        if upload.refused:
            state.message = f"Upload refused: {upload.refused.rsplit(' (refusal', 1)[0]}"

    upload.param.watch(on_upload, "value")
    upload.param.watch(on_refused, "refused")

    camera = _select(state, "camera", "w-camera", "Camera preset")
    alpha = _slider_number(state, "alpha", "w-alpha", "Mixture alpha (0 cones, 1 DCS-200)",
                           start=0.0, end=1.0, step=0.05)
    centers = w.TextInput.from_param(state.param.gaussian_centers, label="Gaussian centres (nm)",
                                     css_classes=["w-centers"], sizing_mode="stretch_width")
    widths = w.TextInput.from_param(state.param.gaussian_widths, label="Gaussian widths (nm)",
                                    css_classes=["w-widths"], sizing_mode="stretch_width")
    optics = _select(state, "optics", "w-optics", "Optics")
    optics.description = ("preset: the camera's own lens (diffraction for the electron-level cameras, none for the "
                          "chapter's); none; or diffraction-limited blur at the f-number, per wavelength")
    mosaic = _select(state, "mosaic", "w-mosaic", "Mosaic")
    tile = w.TextInput.from_param(state.param.custom_tile, label="Custom tile (0-based; rows split by ';')",
                                  css_classes=["w-tile"], sizing_mode="stretch_width")

    distance = _slider_number(state, "distance", "w-distance", "Distance (m)",
                            start=0.5, end=10.0, step=0.01)
    exposure = _number(FloatInput, state, "exposure", "w-exposure", "Exposure (s)", step=0.005, format="0.0000")
    light = _number(FloatInput, state, "light", "w-light", "Light level (x the scene's)", step=0.1, format="0.000",
                    description="A factor of the scene's own light, 0.001 to 1000: radiance and illuminant scaled")
    auto = w.Button(label="Auto exposure", css_classes=["w-auto"], color="primary", width=120,
                    description="Exposure putting the scene's brightest 0.5 % at 90 % of full scale")
    auto.on_click(lambda e: state.auto_expose())
    f_stop = _slider_number(state, "f_stop", "w-fstop", "f-stop", start=1.0, end=32.0, step=0.1)
    noise = _slider_number(state, "noise_sigma", "w-noise", "Noise sigma (digital units)",
                           start=0.0, end=50.0, step=0.5)
    # the choices follow the state (bound before the link: a link's 7 bits is among them when the value comes)
    bits = w.Select(label="Bits of the raw (the display is 8-bit)", options=pn.bind(bits_choices, state.param.bits),
                    value=state.bits, css_classes=["w-bits"], sizing_mode="stretch_width")
    bits.link(state, value="bits", bidirectional=True)
    # a float box: a whole number past 2**53 typed into Bokeh's integer box reached the server as nothing (no
    # message, the text left standing); here it arrives as a number and the state refuses it by name
    seed = _number(FloatInput, state, "seed", "w-seed", "Noise seed", step=1, format="0")

    demosaic = _select(state, "demosaic_method", "w-demosaic", "Demosaicing")
    render = _select(state, "render_method", "w-render", "Rendering")
    illum = _select(state, "illuminant", "w-illuminant", "Illuminant")
    monitor = _select(state, "monitor", "w-monitor", "Monitor")
    metric = w.RadioButtonGroup.from_param(state.param.metric, label="Error metric", css_classes=["w-metric"],
                                           sizing_mode="stretch_width")
    de_scale = w.RadioButtonGroup.from_param(state.param.de_scale, label="dE colours", css_classes=["w-de-scale"],
                                             sizing_mode="stretch_width")

    # notes under controls that can be inert: a changing note is cheap, a changing widget label is not
    # (Panel rebuilds the widget's style modifiers on the server, ~7 ms, and the browser re-renders it)
    seed_note = Text("", ["camsim-note", "w-seed-note"], margin=(0, 10), styles={"font-size": "0.85em", "color": "#555"})
    illum_note = Text("", ["camsim-note", "w-illuminant-note"], margin=(0, 10),
                      styles={"font-size": "0.85em", "color": "#555"})

    def sensor_fields():
        sensor = SensorControls(state, Text("", ["camsim-note", "w-sensor-note"], margin=(0, 10),
                                            styles={"font-size": "0.85em", "color": "#555"}))
        return [*sensor.panel(), sensor.note]

    def states(*_):
        """Show only the controls that act on the current camera; disable the inert ones, saying why."""
        with pn.io.hold():  # one message to the browser
            alpha.visible = state.camera == "mixture"
            centers.visible = widths.visible = state.camera.startswith("gaussian")
            tile.visible = state.mosaic == "custom"
            skipped = state.result is not None and "demosaic" in getattr(state.result, "skipped", {})
            demosaic.disabled = skipped
            demosaic.name = "Demosaicing: not needed (full-colour image)" if skipped else "Demosaicing"
            illum.disabled = state.render_method != "illuminant"
            illum_note.object = ("Used by illuminant-based rendering only" if illum.disabled else
                                 "Known, or estimated from the image")
            electrons = state.camera in PHYSICAL_NAMES  # its noise is the sensor's own (Sensor card)
            noise.disabled = electrons
            noisy = electrons or state.noise_sigma > 0
            seed.disabled = not noisy
            seed_note.object = ("Draws the shot and read noise; noise sigma is for the chapter's cameras" if electrons
                                else "Draws the noise pattern" if noisy else "No effect without noise")

    state.param.watch(states, ["camera", "mosaic", "result", "render_method", "noise_sigma"])
    states()

    def save_and_share():
        params_down = w.FileDownload(callback=lambda: io.BytesIO(state.to_json().encode()), filename="camsim-parameters.json",
                                     label="Parameters (JSON)", css_classes=["w-json-download"], color="light",
                                     sizing_mode="stretch_width")
        params_up = BoundedUpload(accept=".json", max_bytes=limits.max_json_bytes, css_classes=["w-json-upload"],
                                  sizing_mode="stretch_width")

        def on_params(event):
            if event.new is not None:
                state.from_json(event.new.decode("utf-8", errors="replace"))

        def on_params_refused(event):
            if params_up.refused:
                state.message = f"Parameters file refused: {params_up.refused.rsplit(' (refusal', 1)[0]}"

        params_up.param.watch(on_params, "value")
        params_up.param.watch(on_params_refused, "refused")
        downloads = [
            w.FileDownload(callback=results.rendered_png, filename="rendered.png", label="Rendered PNG",
                           css_classes=["w-png"], color="light", sizing_mode="stretch_width"),
            w.FileDownload(callback=results.raw_tiff, filename="raw.tif", label="Raw TIFF",
                           css_classes=["w-tiff"], color="light", sizing_mode="stretch_width"),
            w.FileDownload(callback=results.de_csv, filename="delta_e.csv", label="dE values (CSV)",
                           css_classes=["w-csv"], color="light", sizing_mode="stretch_width"),
        ]
        return [params_down, pn.pane.Markdown("Load parameters (JSON):"), params_up, *downloads]

    # text a number box throws away in the browser ("abc" in the exposure box) gets a message naming the box
    numbers = {"w-alpha": ("Mixture alpha", "alpha"), "w-distance": ("Distance (m)", "distance"),
               "w-exposure": ("Exposure (s)", "exposure"), "w-light": ("Light level", "light"),
               "w-fstop": ("f-stop", "f_stop"), "w-noise": ("Noise sigma", "noise_sigma"), "w-seed": ("Noise seed", "seed")}
    values = {css: partial(getattr, state, name) for css, (_, name) in numbers.items()}
    labels = {css: label for css, (label, _) in numbers.items()}
    for name, (label, css) in SensorControls.LABELS.items():  # the electron-level sensor's boxes too
        labels[css] = label
        values[css] = partial(SensorControls.shown_value, state, name)
    typed = TypedTextWatch(fields=labels, values=values,
                           css_classes=["w-typed-watch"], width=0, height=0, margin=0)
    typed.param.watch(lambda event: setattr(state, "message", typed.refused), "refused")

    card = dict(sizing_mode="stretch_width", margin=(4, 0))
    return [
        typed,
        pn.Card(scene, chart_options, pn.pane.Markdown("Upload a scene (.npz, .mat, a photo, or a .zip of a .Simg, an ENVI .hdr or "
                                        "band PNGs):", visible=_options["upload"]), upload, light, title="Scene", **card),
        pn.Card(camera, alpha, centers, widths, optics, mosaic, tile, title="Camera", **card),
        _opened_card(sensor_fields, title="Sensor (electrons)", **card),
        pn.Card(distance, pn.Row(exposure, auto, sizing_mode="stretch_width"), f_stop, noise, bits, seed, seed_note,
                title="Exposure and noise", **card),
        pn.Card(demosaic, render, illum, illum_note, monitor, pn.pane.Markdown("Error metric and dE map colours:"), metric,
                de_scale, title="Processing", **card),
        _opened_card(save_and_share, title="Save and share", **card),
    ]


def _opened_card(build, **card):
    """A collapsed card whose content ``build()`` makes the first time it is opened: a page opens with fewer
    models to make and send (each widget is several Bokeh models), and what is never opened costs nothing."""
    holder = pn.Column(sizing_mode="stretch_width", margin=0)
    opened = pn.Card(holder, collapsed=True, **card)

    def on_open(event):
        if not event.new and not holder.objects:
            content = list(build())
            _undelayed(content)
            holder.objects = content

    opened.param.watch(on_open, "collapsed")
    return opened


def _experiments_tab(state):
    """The Experiments tab: a small sensors sweep when the engine offers it."""
    try:
        from camsim_core.experiments import sensors as experiment

        run = experiment.run
        from .experiments import ExperimentsView
    except Exception:
        return pn.pane.Markdown("The experiments are not available in this engine yet.",
                                css_classes=["camsim-experiments"])
    return ExperimentsView(run).panel()


def _physical_tab(state, when_shown):
    from .physical import PhysicalView

    return PhysicalView(state, when_shown).panel()


def _results_tab(state, views):
    results = views["results"]
    grid = views["grid"] = results.grid
    fit = pn.widgets.Button(label="Show whole images", css_classes=["w-fit"], width=170)
    fit.on_click(lambda e: results.fit())
    return pn.Column(results.stats, results.warnings, grid,
                     pn.Row(fit, pn.pane.Markdown("Image views share zoom and pan: wheel to zoom, drag to pan; "
                                                  "hover for values.")),
                     sizing_mode="stretch_width")


def _scene_tab(state, views, when_shown):
    sv = views["scene"] = SceneView(state, when_shown)
    return sv.__panel__()


def _camera_tab(state, views, when_shown):
    cv = views["camera"] = CameraView(state, when_shown)
    return cv.__panel__()


#: The tabs, in order: (title, builder(state, views, when_shown) -> a Panel object). ``when_shown`` is the
#: tab's :class:`WhenShown` gate: views following the design update through it (at once while the tab is
#: shown, when it is next shown otherwise). Add a tab with one line.
TABS = [
    ("Results", lambda state, views, when_shown: _results_tab(state, views)),
    ("Scene", _scene_tab),
    ("Camera", _camera_tab),
    ("Image quality", lambda state, views, when_shown: QualityView(state, when_shown).panel()),
    ("Compare designs", lambda state, views, when_shown: compare_tab(state, when_shown)),
    ("Experiments", lambda state, views, when_shown: _experiments_tab(state)),
    ("Optics & sensor", lambda state, views, when_shown: _physical_tab(state, when_shown)),
]


#: The index of the Compare designs tab in :data:`TABS`.
_COMPARE_TAB = [title for title, _ in TABS].index("Compare designs")
assert len(TAB_NAMES) == len(TABS) and TAB_NAMES[_COMPARE_TAB] == "compare"  # a link names each tab


def _lazy_tabs(state, views):
    """The tabs, each built the first time it is shown: a page opens with the Results tab only,
    so its first render does not wait for plots nobody has looked at yet."""
    holders = [pn.Column(sizing_mode="stretch_width", css_classes=["camsim-tab"]) for _ in TABS]
    tabs = pn.Tabs(*[(title, holder) for (title, _), holder in zip(TABS, holders)],
                   css_classes=["camsim-tabs"], dynamic=True, sizing_mode="stretch_width",
                   stylesheets=[_TAB_TITLES_WRAP])
    built = set()
    # the Results tab's views always follow (the status pane and the headline numbers live there)
    gates = [now] + [WhenShown(shown=False) for _ in TABS[1:]]
    doc = pn.state.curdoc
    themes = {}  # tab index -> the document's theme when the tab was last shown

    def restyle(index, back=False):
        """The tab's plots in the document's theme, if it changed since the tab was last shown (``back``: the
        tab is shown again now, its plots were out of the document when the theme changed)."""
        if doc is None:
            return
        if back and themes.get(index, doc.theme) is not doc.theme:
            state.defer(lambda: resend_plot_text(doc))  # once the tab's plots are back in the document
        themes[index] = doc.theme

    def build(index):
        if index not in built:
            built.add(index)
            holders[index].objects = [TABS[index][1](state, views, gates[index])]

    def show(index):
        if not 0 <= index < len(TABS):
            return
        restyle(index, back=True)
        for i, gate in enumerate(gates):
            if gate is not now and i != index:
                gate.show(False)
        build(index)
        if gates[index] is not now:
            gates[index].show(True)  # what changed while it was hidden, brought up to date

    def pinned(*_):
        # pinned designs (a link's, a parameters file's) compute from the moment there are some, in the Compare
        # tab's worker, whatever tab is open: a link's are ready when its page has loaded and the tab is opened
        if state.pinned:
            build(_COMPARE_TAB)

    def opened(event):
        show(event.new)
        if 0 <= event.new < len(TAB_NAMES):
            state.tab = TAB_NAMES[event.new]  # into the address: a link opens on the tab it was made from

    tabs.param.watch(opened, "active")
    state.param.watch(lambda event: setattr(tabs, "active", TAB_NAMES.index(event.new)), "tab")  # back, forward
    state.param.watch(pinned, "pinned")
    show(tabs.active)
    pinned()
    linked = TAB_NAMES.index(state.tab)
    if linked == _COMPARE_TAB and state.pinned:
        # a link's comparison: its plots are made with the page (CompareView), so the page is built on the tab;
        # switched to on the first tick, its ~250 models were made and added to the page on the event loop
        tabs.active = linked
    _open_linked_tab(tabs, linked, doc)
    views["tabs"] = tabs
    views["restyle_tab"] = lambda: restyle(tabs.active)  # after a change of theme (presentation mode)
    return tabs


def _open_linked_tab(tabs, index, doc):
    """Show the tab a link names (``?tab=compare``), once the page's session is live.

    The page is built on the Results tab and switches on its session's first tick, as a student's click
    would: built on the Compare tab, the tab's plots added when its designs came reached the browser
    after changes to them, during the page's first messages ("reference ... isn't known" in the page,
    3 links in 4 on a loaded machine). A link with pinned designs is built on the Compare tab
    (:func:`_lazy_tabs`): its plots are made with the page."""
    if index == tabs.active:
        return
    if page_being_built(doc):
        doc.add_next_tick_callback(lambda: setattr(tabs, "active", index))
    else:
        tabs.active = index


def _new_state(scene):
    chosen = scene or _options["scene"] or DEFAULT_SCENE
    if isinstance(chosen, str):
        return ExplorerState(scene=chosen, start=False)
    state = ExplorerState(start=False)  # a Scene read from a file by ``camsim serve --scene PATH``
    state.add_scene(f"file:{chosen.name}", chosen)
    return state


#: How often a session checks for changes Panel left unsent (ms): the longest a stranded result waits.
STRANDED_CHECK_MS = 500


#: Changes Panel queued and forgot are sent by :func:`camsim_explorer.compat.hooks.flush_stranded_writes`.
flush_stranded_writes = _compat.flush_stranded_writes


def _go_background(state):
    """In a server session: compute in a thread of this session, show results on its next tick."""
    doc = pn.state.curdoc
    if doc is None or doc.session_context is None:
        return

    def apply(job, outcome):
        # one batch of model changes: Bokeh re-walks the document's model graph once, not per change
        with pn.io.hold(doc):
            state._apply(job, outcome)

    def deliver(job, outcome):
        show = once(apply, job, outcome)  # not held by Bokeh's callback after it ran (see ``once``)
        next_tick(doc, partial(when_page_ready, show), show.drop)  # dropped if the session has closed

    state.set_runner(Runner(state._compute, deliver))
    state.defer = _later
    doc.add_periodic_callback(partial(flush_stranded_writes, doc), STRANDED_CHECK_MS)


def create_app(scene=None):
    """One session's page (a fresh state: nothing is shared between sessions but read-only data)."""
    compat.apply()
    _quiet_known_warnings()
    # global_css: in the page's head only (raw_css also goes into every view's shadow root, where rules from the
    # body match nothing: 99 copies parsed and matched in a page)
    pn.extension(notifications=False, global_css=[_PRESENT_CSS])
    state = _new_state(scene)
    first_scene = state.scene  # before a link's parameters: the scene a page of this server opens with (Start over)
    with _LIVE_LOCK:
        LIVE_STATES.add(state)
        if pn.state.curdoc is not None:
            _STATE_OF_DOC[pn.state.curdoc] = weakref.ref(state)
    _go_background(state)
    state.recompute()  # in the background in a server: the page shows at once, marked as computing
    if pn.state.location is not None:
        chart_refused = []  # why the link's chart was refused, quoted with the link's refusal

        def on_error(values):
            # Param refused the link's values as one batch: the ones their parameters accept are set, as one
            # change; every refused one is named (a link holds at most the few dozen the page syncs), each value
            # quoted to 40 characters
            values = state.apply_valid(values)
            if not values:
                return
            shown = ", ".join(f"{k} {_as_typed(pn.state.location.search, k, v)}" for k, v in values.items())
            why = f" ({chart_refused[0][:300]})" if chart_refused else ""
            _tell(state, f"The link held parameters that were refused: {shown}{why}")

        too_long = _long_url_values(pn.state.location.search)
        if too_long:
            _tell(state, f"The link's values for {', '.join(too_long)} are longer than "
                         f"{state_module.LIMITS.max_text} characters and were ignored")
        else:
            if not _offer_linked_chart(state, pn.state.location.search):
                chart_refused.append(state.message)
            _sync_address(state, URL_PARAMETERS + VIEW_PARAMETERS + COMPARE_PARAMETERS + PAGE_PARAMETERS, on_error)
    views = {"state": state}
    views["results"] = results = ResultsView(state)
    # the messages quote what users typed, linked or uploaded: shown as text (``md_text``), never as markup
    # the refusal floats over the page's top right corner: in sight wherever the page is scrolled to, and the
    # views below do not move when it comes and goes
    alert = pn.pane.Alert(md_text(state.message), alert_type="danger", visible=bool(state.message),
                          css_classes=["camsim-alert"], styles=_FLOATING, width=560)
    notice = pn.pane.Alert(md_text(state.notice), alert_type="warning", visible=bool(state.notice),
                           css_classes=["camsim-notice"], sizing_mode="stretch_width")

    def on_message(event):
        alert.object = md_text(state.message)
        alert.visible = bool(state.message)
        notice.object = md_text(state.notice)
        notice.visible = bool(state.notice)

    state.param.watch(on_message, ["message", "notice"])
    tabs = _lazy_tabs(state, views)
    present = pn.widgets.Toggle(label="Presentation mode", css_classes=["w-present"], color="default",
                                sizing_mode="stretch_width")
    # the page's class for presentation mode, set from the server (a jscallback would make Panel look for links
    # at every tab switch: see camsim_explorer.body_class)
    present_class = BodyClass(css_class="camsim-present", margin=0, width=0, height=0)
    # back and forward show the page of the address they go to (Panel's Location does not follow them)
    history = HistoryFollower(margin=0, width=0, height=0)

    doc = pn.state.curdoc

    def on_present(event):
        present_class.active = event.new
        views["grid"].ncols = 2 if event.new else 3
        show_presentation(doc, event.new)
        views["restyle_tab"]()

    present.param.watch(on_present, "value")
    start_over = pn.widgets.Button(label="Start over", css_classes=["w-start-over"], sizing_mode="stretch_width",
                                   description="Back to the design a new page opens with: its scene, the default "
                                               "camera and settings, the Results tab. Pinned designs and uploaded "
                                               "scenes stay.")
    # on the next tick, as the session's own callback: Panel runs a button's click outside the document's lock,
    # where the views' changes to their plots are refused ("_pending_writes should be non-None")
    def on_start_over(event):
        def go():
            results.fit()
            if "scene" in views:  # the Scene tab, once built: no clicked pixels or regions, as on a new page
                views["scene"].reset_spectra()
            state.start_over(first_scene)

        state.defer(go)

    start_over.on_click(on_start_over)
    # Not a collapsed Card: a Card hides its children by setting their `visible` in the browser, which the
    # next update from the server undoes, and each round makes the browser lay the whole page out again.
    show_diagnostics = pn.widgets.Checkbox(label="Show diagnostics (parameters computed, steps run, engine time)",
                                           value=False, css_classes=["w-diagnostics"])
    results.status.visible = False
    show_diagnostics.param.watch(lambda event: setattr(results.status, "visible", event.new), "value")
    diagnostics = pn.Column(show_diagnostics, results.status, sizing_mode="stretch_width",
                            css_classes=["camsim-diagnostics"])
    intro = pn.pane.Markdown(START_HERE, css_classes=["camsim-start"], sizing_mode="stretch_width")
    # The alert and the notice are roots of their own (the template makes one of each item of ``main``), not
    # children of the page's body: a change of a root's size makes the browser lay out that root again, and
    # the body holds every view (one layout of it: 80-160 ms of a 2-core machine's browser). Shown, hidden or
    # reworded, they now cost a layout of themselves (5-15 ms); the body below moves down with the page.
    body = pn.Column(intro, tabs, diagnostics, sizing_mode="stretch_width")
    body.state = state
    controls = _controls(state, results)
    _undelayed(controls)
    template = _Template(
        title="camsim explorer: a camera design on a hyperspectral scene",
        # the two buttons one above the other: side by side, presentation mode's large text put one over the other
        sidebar=[present, present_class, history, start_over, *controls],
        main=[notice, body, alert],
        sidebar_width=330,
        favicon=FAVICON,
        busy_indicator=None,  # the result panes show their own state; a header spinner would cost two messages per change
        design=_Design,
    )
    template.state = state  # for tests and notebooks
    template.body = body  # the page's body: its tabs and diagnostics (the alert and the notice are beside it)
    if pn.state.curdoc is not None and pn.state.curdoc.session_context is not None:
        pn.state.on_session_destroyed(lambda ctx, state=state, page=body, template=template:
                                      _release(state, page, template))
    return template


def _tell(state, text):
    """Show ``text`` in the page's alert, once the first result is in if it is still being computed (a
    result shown clears the alert: the link's refusals would be gone before the page showed them)."""
    if state.result is not None and not state.computing:
        state.message = text
        return
    watchers = []

    def first_result(event):
        state.param.unwatch(watchers.pop())
        state.message = text

    watchers.append(state.param.watch(first_result, "result"))
    state.message = text


def _undelayed(objects):
    """Widgets whose changes reach the state at once: Panel holds each change from the browser for 50 ms
    (to gather a burst into one) before acting on it. A burst costs nothing here (a newer change supersedes
    the computation of an older one), and 50 ms is a third of the time a slider has to answer."""
    for obj in objects:
        for widget in obj.select(pn.widgets.Widget) if hasattr(obj, "select") else ():  # a Text has no widgets
            _compat.undelay(widget)


class _Design(pn.theme.Bootstrap):
    """Panel's Bootstrap design, with the explorer's control style (:data:`_CONTROL_CSS`) in every widget."""

    modifiers = {**pn.theme.Bootstrap.modifiers,
                 pn.widgets.Widget: {"stylesheets": [pn.theme.base.Inherit, _CONTROL_CSS]},
                 pn.custom.JSComponent: {"stylesheets": [pn.theme.base.Inherit, _CONTROL_CSS]},  # the upload
                 pn.layout.Card: {**pn.theme.Bootstrap.modifiers.get(pn.layout.Card, {}),
                                  "stylesheets": [pn.theme.base.Inherit, _CONTROL_CSS]}}


#: The plot text presentation mode sets: (Bokeh model class, property) -> key of :data:`PRESENT_PLOT_TEXT`.
_PLOT_TEXT_PROPERTIES = {("Axis", "axis_label_text_font_size"): "axis_label",
                         ("Axis", "major_label_text_font_size"): "tick_label",
                         ("Title", "text_font_size"): "title",
                         ("Legend", "label_text_font_size"): "legend", ("Legend", "title_text_font_size"): "legend",
                         ("ColorBar", "major_label_text_font_size"): "tick_label",
                         ("ColorBar", "title_text_font_size"): "legend"}


def present_theme():
    """The Bokeh theme of presentation mode: plots' axis, tick, title and legend text at
    :data:`PRESENT_PLOT_TEXT` sizes (their canvas text does not follow the page's CSS)."""
    from bokeh.themes import Theme

    attrs = {}
    for (cls, name), key in _PLOT_TEXT_PROPERTIES.items():
        attrs.setdefault(cls, {})[name] = PRESENT_PLOT_TEXT[key]
    return Theme(json={"attrs": attrs})


_THEME_BEFORE = weakref.WeakKeyDictionary()  # document -> its theme before presentation mode


def show_presentation(doc, on):
    """Presentation mode's plot text in ``doc`` (a Bokeh document): the present theme when ``on``, the theme
    it had before otherwise. A theme reaches plots made later too (tabs are built when first opened)."""
    if doc is None:
        return
    if on:
        _THEME_BEFORE.setdefault(doc, doc.theme)
        doc.theme = present_theme()
    elif doc in _THEME_BEFORE:
        doc.theme = _THEME_BEFORE.pop(doc)


def resend_plot_text(doc):
    """Send the browser the text sizes of every plot in ``doc`` again; returns how many values were sent.

    A tab's plots are out of the document while another tab is shown (Panel's dynamic tabs). When they come
    back, Bokeh gives them the document's theme on the server but tells the browser only of values that are
    not defaults: after presentation mode was turned off, the browser drew its own copy of them in the large
    text (for about 30 s, until it forgot that copy). Sent again, the sizes in force are drawn.
    """
    import bokeh.models as bm

    classes = {"Axis": bm.Axis, "Title": bm.Title, "Legend": bm.Legend, "ColorBar": bm.ColorBar}
    sent = 0
    with pn.io.hold(doc):  # one message, not one per value
        for cls, name in _PLOT_TEXT_PROPERTIES:
            for model in doc.select({"type": classes[cls]}):
                value = getattr(model, name)
                model.trigger(name, value, value)  # Bokeh's change notice: sent although the server's value is the same
                sent += 1
    return sent


class _Template(_compat.DataURIFavicon, pn.template.BootstrapTemplate):
    """The page template, put into its document in one batch: Panel adds the page's models and links
    one by one, and Bokeh re-walks the whole model graph after each (18 walks, about 1 s per new page)."""

    def server_doc(self, doc=None, title=None, location=True):
        doc = doc if doc is not None else pn.state.curdoc
        if doc is None:
            return super().server_doc(doc, title, location)
        with doc.models.freeze():
            return super().server_doc(doc, title, location)


#: The address follows a change this long after it (ms), once its result is shown.
ADDRESS_DELAY_MS = 300


def _as_typed(search, name, value):
    """A link's value ``name`` as the link writes it (the query ``search``), to quote in a refusal: a number as
    typed ("seed -3", where Panel's reading made it "-3.0"), any other text quoted, cut to 40 characters.

    Examples
    --------
    >>> _as_typed("?seed=-3&camera=%3Cb%3E", "seed", -3.0), _as_typed("?seed=-3&camera=%3Cb%3E", "camera", "<b>")
    ('-3', "'<b>'")
    >>> _as_typed("?noise_sigma=", "noise_sigma", 1e9)
    '1000000000.0'
    """
    text = urllib.parse.parse_qs(str(search).lstrip("?"), keep_blank_values=True).get(name, [None])[0]
    if text is None or text == "":
        return state_module.short_repr(value, 40)
    try:
        float(text)
    except ValueError:
        return state_module.short_repr(text, 40)
    return text if len(text) <= 40 else state_module.short_repr(text, 40)


def _sync_address(state, names, on_error):
    """The page's address holds the parameters ``names``, so that a link reproduces the page.

    Panel's ``Location.sync`` reads them from the address at start (and on the
    browser's back and forward: :class:`~camsim_explorer.history.HistoryFollower` reloads the page then),
    and writes every change into the address at
    once. Here the writing waits until the change's result is shown and
    ``ADDRESS_DELAY_MS`` have passed, and a burst of changes is written once:
    each new address is a history entry and navigation bookkeeping in the
    browser (~20 ms of its CPU a change, measured with Chromium), which came
    while the browser drew the new result.
    """
    location = pn.state.location
    location.sync(state, {p: p for p in names}, on_error=on_error)
    update_query = _compat.address_writer(location, state)
    if update_query is None:  # another Panel: its own writing
        return
    pending, armed = set(), [0]

    def write(generation):
        if generation != armed[0]:  # a later change re-armed the timer
            return
        if state.computing:
            arm()
            return
        query = {}
        # with every synced value the address holds, in JSON: Panel's writer reads the address's other values back
        # as Python objects and writes them with str(), so a link's pinned designs became a Python repr
        for name in sorted(pending | (set(location.query_params) & set(names))):
            value = getattr(state, name)
            if value is None:
                continue
            try:
                value = state.param[name].serialize(value)
            except Exception:
                pass
            query[name] = value if isinstance(value, str) else json.dumps(value)
        pending.clear()
        update_query(query)  # Panel's writer: marks the address as written by the page

    def arm():
        armed[0] += 1
        _after(ADDRESS_DELAY_MS, once(write, armed[0]))

    def on_change(*events):
        pending.update(e.name for e in events)
        arm()

    state.param.watch(on_change, list(names))


def _offer_linked_chart(state, search):
    """A link to a chart with options ("scene=slanted-edge:angle=10"): make that chart before the link is applied.

    Returns False when the chart was refused (``state.message`` says why)."""
    from urllib.parse import parse_qsl

    scenes = [v for k, v in parse_qsl(str(search or "").lstrip("?")) if k == "scene"]
    if scenes and ":" in scenes[-1] and scenes[-1] not in state.param.scene.objects:
        return state.offer_chart(scenes[-1])
    return True


def _long_url_values(search):
    """Names of the URL's parameters whose values exceed ``LIMITS.max_text`` characters."""
    from urllib.parse import parse_qsl

    limit = state_module.LIMITS.max_text
    try:
        pairs = parse_qsl(str(search or "").lstrip("?"), keep_blank_values=True, max_num_fields=200)
    except ValueError:
        return ["(too many fields)"]
    # pinned designs and the sweep are JSON: bounded like a parameters file
    big = state_module.LIMITS.max_json_bytes
    return sorted({k[:40] for k, v in pairs if len(v) > (big if k in COMPARE_PARAMETERS else limit) or len(k) > limit})
