"""The explorer page: ``create_app()`` builds one session's page around a fresh state.

Serve it with ``camsim serve`` (``pn.serve(create_app, ...)``): Panel calls
``create_app`` once per browser session, so each session has its own
:class:`~app.state.ExplorerState` (parameters and cached pipeline), while
scenes, cameras and monitors are read once per process and shared read-only.
"""

from __future__ import annotations

import io
import weakref

import panel as pn

from . import state as state_module
from .compare import compare_tab
from .quality import QualityView
from .state import BITS_CHOICES, COMPARE_PARAMETERS, URL_PARAMETERS, ExplorerState
from .upload import BoundedUpload
from .views import CameraView, ResultsView, SceneView

__all__ = ["create_app", "DEFAULT_SCENE", "configure", "LIVE_STATES"]

DEFAULT_SCENE = "cacaphony290"
_options = {"scene": None, "upload": True}
#: Every session's state while it lives (weak: a closed session's state must be freed).
LIVE_STATES = weakref.WeakSet()


def configure(scene=None, *, limits=None, upload=True):
    """Set what new sessions get (``camsim serve``): the scene they open on, the limits, whether uploads are offered."""
    _options["scene"] = scene
    _options["upload"] = bool(upload)
    if limits is not None:
        state_module.LIMITS = limits


def _release(state, page):
    """Break a closed session's links so that its state, pipeline and views are freed.

    Widgets made with ``from_param`` and the views watch the state, and the
    state's watchers point back at them; dropping the watchers, the cached
    pipeline, the uploads, the last result and the page's children leaves
    nothing that reaches the session's arrays.
    """
    for group in list(state.param.watchers.values()) if hasattr(state.param, "watchers") else []:
        for watchers in list(group.values()):
            for w in list(watchers):
                try:
                    state.param.unwatch(w)
                except Exception:
                    pass
    state.pipeline = None
    state._uploads.clear()
    with param_discard(state):
        state.result = None
    page.objects = []
    page.state = None


def param_discard(obj):
    import param

    return param.parameterized.discard_events(obj)


def _widget(cls, state, parameter, css, **kw):
    return cls.from_param(state.param[parameter], css_classes=[css], sizing_mode="stretch_width", **kw)


def _controls(state, results):
    w = pn.widgets
    scene = _widget(w.Select, state, "scene", "w-scene", name="Scene")
    limits = state_module.LIMITS
    upload = BoundedUpload(accept=".npz,.zip,.mat,.png,.jpg,.jpeg", max_bytes=limits.upload.max_upload_bytes, css_classes=["w-upload"],
                           sizing_mode="stretch_width", visible=_options["upload"])

    def on_upload(event):
        if upload.value is not None:
            state.add_upload(upload.filename, upload.value)

    def on_refused(event):
        if upload.refused:
            state.message = f"Upload refused: {upload.refused.rsplit(' (refusal', 1)[0]}"

    upload.param.watch(on_upload, "value")
    upload.param.watch(on_refused, "refused")

    camera = _widget(w.Select, state, "camera", "w-camera", name="Camera preset")
    alpha = _widget(w.FloatSlider, state, "alpha", "w-alpha", name="Mixture alpha (0 cones, 1 DCS-200)")
    centers = _widget(w.TextInput, state, "gaussian_centers", "w-centers", name="Gaussian centres (nm)")
    widths = _widget(w.TextInput, state, "gaussian_widths", "w-widths", name="Gaussian widths (nm)")
    alpha.visible = state.camera == "mixture"
    centers.visible = widths.visible = state.camera.startswith("gaussian")
    mosaic = _widget(w.Select, state, "mosaic", "w-mosaic", name="Mosaic")
    tile = _widget(w.TextInput, state, "custom_tile", "w-tile", name="Custom tile (0-based; rows split by ';')")
    tile.visible = state.mosaic == "custom"

    def visibility(*_):
        alpha.visible = state.camera == "mixture"
        centers.visible = widths.visible = state.camera.startswith("gaussian")
        tile.visible = state.mosaic == "custom"

    state.param.watch(visibility, ["camera", "mosaic"])

    distance = _widget(w.EditableFloatSlider, state, "distance", "w-distance", name="Distance (m)")
    exposure = _widget(w.FloatInput, state, "exposure", "w-exposure", name="Exposure (s)", format="0.0000")
    auto = w.Button(name="Auto exposure", css_classes=["w-auto"], button_type="primary", width=120)
    auto.on_click(lambda e: state.auto_expose())
    f_stop = _widget(w.EditableFloatSlider, state, "f_stop", "w-fstop", name="f-stop")
    noise = _widget(w.EditableFloatSlider, state, "noise_sigma", "w-noise", name="Noise sigma (digital units)")
    bits = w.Select(name="Bits", options=BITS_CHOICES, value=state.bits, css_classes=["w-bits"], sizing_mode="stretch_width")
    bits.link(state, value="bits", bidirectional=True)
    seed = _widget(w.IntInput, state, "seed", "w-seed", name="Noise seed")

    demosaic = _widget(w.Select, state, "demosaic_method", "w-demosaic", name="Demosaicing")
    render = _widget(w.Select, state, "render_method", "w-render", name="Rendering")
    illum = _widget(w.Select, state, "illuminant", "w-illuminant", name="Illuminant (for illuminant-based)")
    monitor = _widget(w.Select, state, "monitor", "w-monitor", name="Monitor")
    metric = _widget(w.RadioButtonGroup, state, "metric", "w-metric", name="Error metric")

    params_down = w.FileDownload(callback=lambda: io.BytesIO(state.to_json().encode()), filename="camsim-parameters.json",
                                 label="Parameters (JSON)", css_classes=["w-json-download"], button_type="light",
                                 sizing_mode="stretch_width")
    params_up = BoundedUpload(accept=".json", max_bytes=limits.max_json_bytes, css_classes=["w-json-upload"],
                              sizing_mode="stretch_width")

    def on_params(event):
        if params_up.value is not None:
            state.from_json(params_up.value.decode("utf-8", errors="replace"))

    def on_params_refused(event):
        if params_up.refused:
            state.message = f"Parameters file refused: {params_up.refused.rsplit(' (refusal', 1)[0]}"

    params_up.param.watch(on_params, "value")
    params_up.param.watch(on_params_refused, "refused")
    downloads = [
        w.FileDownload(callback=results.rendered_png, filename="rendered.png", label="Rendered PNG",
                       css_classes=["w-png"], button_type="light", sizing_mode="stretch_width"),
        w.FileDownload(callback=results.raw_tiff, filename="raw.tif", label="Raw TIFF",
                       css_classes=["w-tiff"], button_type="light", sizing_mode="stretch_width"),
        w.FileDownload(callback=results.de_csv, filename="delta_e.csv", label="dE values (CSV)",
                       css_classes=["w-csv"], button_type="light", sizing_mode="stretch_width"),
    ]
    card = dict(sizing_mode="stretch_width", margin=(4, 0))
    return pn.Column(
        pn.Card(scene, pn.pane.Markdown("Upload a scene (.npz, .mat, a photo, or a .zip of a .Simg, an ENVI .hdr or band PNGs):",
                                        visible=_options["upload"]), upload, title="Scene", **card),
        pn.Card(camera, alpha, centers, widths, mosaic, tile, title="Camera", **card),
        pn.Card(distance, pn.Row(exposure, auto), f_stop, noise, bits, seed, title="Exposure and noise", **card),
        pn.Card(demosaic, render, illum, monitor, metric, title="Processing", **card),
        pn.Card(params_down, pn.pane.Markdown("Load parameters (JSON):"), params_up, *downloads,
                title="Save and share", collapsed=False, **card),
        width=330,
    )


def _experiments_tab():
    """The Experiments tab: a small sensors sweep (issue 6) when the engine offers it."""
    try:
        from camsim_core.experiments import sensors as experiment

        run = experiment.run
        from .experiments import ExperimentsView
    except Exception:
        return pn.pane.Markdown("The experiments (issue 6) are not available in this engine yet.",
                                css_classes=["camsim-experiments"])
    return ExperimentsView(run).panel()


def create_app(scene=None):
    """One session's page (a fresh state: nothing is shared between sessions but read-only data)."""
    pn.extension(notifications=False)
    chosen = scene or _options["scene"] or DEFAULT_SCENE
    if isinstance(chosen, str):
        state = ExplorerState(scene=chosen)
    else:  # a Scene read from a file by ``camsim serve --scene PATH``
        state = ExplorerState()
        state.add_scene(f"file:{chosen.name}", chosen)
    LIVE_STATES.add(state)
    if pn.state.location is not None:
        def on_error(values):
            state.message = f"The link held parameters that were refused: {str(values)[:300]}"

        too_long = _long_url_values(pn.state.location.search)
        if too_long:
            state.message = (f"The link's values for {', '.join(too_long)} are longer than "
                             f"{state_module.LIMITS.max_text} characters and were ignored")
        else:
            pn.state.location.sync(state, {p: p for p in URL_PARAMETERS + COMPARE_PARAMETERS}, on_error=on_error)
    results = ResultsView(state)
    scene_view = SceneView(state)
    camera_view = CameraView(state)
    alert = pn.pane.Alert(state.message, alert_type="danger", visible=bool(state.message),
                          css_classes=["camsim-alert"], sizing_mode="stretch_width")
    notice = pn.pane.Alert(state.notice, alert_type="warning", visible=bool(state.notice),
                           css_classes=["camsim-notice"], sizing_mode="stretch_width")

    def on_message(event):
        alert.object = state.message
        alert.visible = bool(state.message)
        notice.object = state.notice
        notice.visible = bool(state.notice)

    state.param.watch(on_message, ["message", "notice"])
    p = results.panes
    results_tab = pn.Column(
        results.stats,
        pn.Row(p["raw"], p["demosaiced"], p["rendered"]),
        pn.Row(p["ideal"], p["de"], p["hist"]),
        pn.pane.Markdown("Image views share zoom and pan (wheel to zoom, drag to pan)."),
        name="Results",
    )
    scene_tab = pn.Column(
        pn.Row(scene_view.wavelength, scene_view.clear),
        pn.Row(scene_view.rgb_pane, scene_view.plane_pane),
        pn.Row(scene_view.spectrum_pane, scene_view.meta),
        name="Scene",
    )
    camera_tab = pn.Column(camera_view.info, pn.Row(camera_view.curves, camera_view.tile), name="Camera")
    tabs = pn.Tabs(results_tab, scene_tab, camera_tab, ("Image quality", QualityView(state).panel()),
                   compare_tab(state), ("Experiments", _experiments_tab()),
                   css_classes=["camsim-tabs"], dynamic=False)
    tabs.append(__import__("app.physical", fromlist=["PhysicalView"]).PhysicalView(state).panel())  # Optics & sensor
    header = pn.pane.Markdown("## camsim explorer: a camera design on a hyperspectral scene", margin=(0, 10))
    page = pn.Column(
        header, alert, notice,
        pn.Row(_controls(state, results), pn.Column(tabs, pn.pane.Markdown("**Diagnostics** (parameters, stages run, engine time):"),
                                                    results.status)),
        sizing_mode="stretch_width",
    )
    page.state = state  # for tests and notebooks
    if pn.state.curdoc is not None and pn.state.curdoc.session_context is not None:
        pn.state.on_session_destroyed(lambda ctx, state=state, page=page: _release(state, page))
    return page


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
