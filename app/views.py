"""Views of the explorer: HoloViews plots that follow an :class:`~app.state.ExplorerState`.

Only display logic lives here (turning engine arrays into pictures); every
number shown comes from the engine through the state's cached pipeline.
Image views of the camera's results share one coordinate system (camera
pixels, dimensions ``x`` and ``y``), so Panel links their zoom and pan;
``DynamicMap`` + ``Pipe`` patch the data in place, keeping the zoom.
"""

from __future__ import annotations

import hashlib
import io
import json

import colour
import holoviews as hv
import holoviews.plotting.bokeh  # noqa: F401  (the bokeh backend, for .opts)
import numpy as np
import panel as pn
from holoviews import streams

from camsim_core.simulation import tile_index_map

hv.Store.set_current_backend("bokeh")

__all__ = ["sensor_colors", "scene_srgb", "raw_rgb", "planes_rgb", "ResultsView", "SceneView", "CameraView"]

DE_RANGE = (0.0, 20.0)
IMAGE_OPTS = dict(frame_width=310, data_aspect=1, xaxis=None, yaxis=None, toolbar="above",
                  tools=["hover"], active_tools=["wheel_zoom"])
_SCENE_RGB = {}


# -- display helpers (pure functions over arrays) ----------------------------
_NAMED = {"R": (1.0, 0.0, 0.0), "G": (0.0, 1.0, 0.0), "B": (0.0, 0.0, 1.0)}


def sensor_colors(sensitivities, wavelengths, names=None):
    """(K, 3) display colour of each sensor, max 1.

    Sensors named R, G, B get pure red, green, blue. Otherwise the sRGB
    chromaticity of the curve seen as a spectrum: the curve's CIE 1931 XYZ (sum of the colour-matching functions weighted
    by the sensitivity), to linear sRGB, negative parts clipped; a
    colourless result (a curve outside the visible range) is grey.
    """
    sens = np.atleast_2d(np.asarray(sensitivities, float))
    if names is not None and len(names) == len(sens) and all(n in _NAMED for n in names):
        return np.array([_NAMED[n] for n in names])
    wls = np.asarray(wavelengths, float)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    bar = np.stack([np.interp(wls, cmfs.wavelengths, cmfs.values[:, i], left=0, right=0) for i in range(3)], axis=1)
    out = []
    for row in sens:
        xyz = row @ bar
        rgb = np.clip(colour.XYZ_to_sRGB(xyz / max(xyz[1], 1e-12) * 0.5, apply_cctf_encoding=False), 0, None)
        out.append(rgb / rgb.max() if rgb.max() > 0 else np.full(3, 0.6))
    return np.array(out)


def scene_srgb(scene):
    """sRGB (H, W, 3) in [0, 1] of a scene: CIE 1931 XYZ of its radiance, brightest 1 % clipped.

    Cached per scene object (scenes are shared read-only).
    """
    hit = _SCENE_RGB.get(id(scene))
    if hit is not None and hit[0] is scene:
        return hit[1]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    wls = np.asarray(scene.wavelengths, float)
    bar = np.stack([np.interp(wls, cmfs.wavelengths, cmfs.values[:, i], left=0, right=0) for i in range(3)], axis=1)
    h, w, n = scene.data.shape
    xyz = (scene.data.reshape(-1, n) @ bar).reshape(h, w, 3)
    scale = np.percentile(xyz[..., 1], 99) or 1.0
    rgb = colour.XYZ_to_sRGB(xyz / scale, apply_cctf_encoding=True)
    rgb = np.clip(np.nan_to_num(rgb), 0, 1)
    if len(_SCENE_RGB) > 32:
        _SCENE_RGB.clear()
    _SCENE_RGB[id(scene)] = (scene, rgb)
    return rgb


def _normalise(data, full_scale):
    top = full_scale if full_scale else (np.percentile(data, 99.5) or 1.0)
    return np.clip(np.asarray(data, float) / top, 0, 1)


def raw_rgb(image):
    """The raw camera image coloured by sensor: each pixel's value times its sensor's colour."""
    colors = sensor_colors(image.sensitivities, image.wavelengths, image.sensor_names)
    data = np.asarray(image.data, float)
    v = _normalise(data, image.full_scale)
    if image.mosaiced and data.ndim == 2:
        idx = tile_index_map(image.tile, data.shape)
        return colors[idx] * v[..., None]
    if data.ndim == 3 and image.mosaiced:  # tiered tile: show the first tier
        idx = tile_index_map(image.tile, data.shape[:2])[..., 0]
        return colors[idx] * v[..., :1]
    return planes_rgb(image)


def planes_rgb(image):
    """Full sensor planes (H, W, K) as a picture: sum of planes times sensor colours."""
    colors = sensor_colors(image.sensitivities, image.wavelengths, image.sensor_names)
    data = np.asarray(image.data, float)
    if data.ndim == 2:
        data = data[..., None]
    mixed = data @ (colors / colors.sum(axis=0, keepdims=True).clip(1e-9))
    return _normalise(mixed, image.full_scale)


def monitor_rgb(image):
    """A rendered image (0..255 monitor settings) as [0, 1] RGB."""
    data = np.asarray(getattr(image, "data", image), float)
    return np.clip(data / 255.0, 0, 1)


def digest(array):
    """Short content hash of an array (for the status pane and tests)."""
    if array is None:
        return None
    a = np.ascontiguousarray(np.asarray(getattr(array, "data", array)))
    return hashlib.blake2b(a.tobytes(), digest_size=6).hexdigest()


def _bounds(shape):
    h, w = shape[:2]
    return (0, 0, w, h)


def _rgb_map(title, pipe):
    def show(data):
        rgb, label = data
        return hv.RGB(rgb, bounds=_bounds(rgb.shape), label=label).opts(title=label or title)

    return hv.DynamicMap(show, streams=[pipe]).opts(hv.opts.RGB(**IMAGE_OPTS))


def _blank(shape):
    return np.zeros(tuple(shape[:2]) + (3,))


# -- the results: raw, demosaiced, rendered, ideal, dE ---------------------
class ResultsView:
    """Image views sharing zoom and pan, the dE histogram and the statistics line."""

    TITLES = {"raw": "Raw mosaic (by sensor)", "demosaiced": "Demosaiced", "rendered": "Rendered",
              "ideal": "Ideal image"}

    def __init__(self, state):
        self.state = state
        shape = (233, 372)
        self.pipes = {k: streams.Pipe(data=(_blank(shape), t)) for k, t in self.TITLES.items()}
        self.de_pipe = streams.Pipe(data=(np.zeros(shape), "dE"))
        self.hist_pipe = streams.Pipe(data=(np.zeros(1), "dE"))
        self.panes = {
            k: pn.pane.HoloViews(_rgb_map(t, self.pipes[k]), css_classes=[f"camsim-{k}"], linked_axes=True)
            for k, t in self.TITLES.items()
        }

        def show_de(data):
            de, label = data
            return hv.Image(de, bounds=_bounds(de.shape), vdims=["dE"], label=label).opts(title=label)

        de_map = hv.DynamicMap(show_de, streams=[self.de_pipe]).opts(
            hv.opts.Image(cmap="inferno", clim=DE_RANGE, colorbar=True, **IMAGE_OPTS))
        self.panes["de"] = pn.pane.HoloViews(de_map, css_classes=["camsim-de"], linked_axes=True)

        def show_hist(data):
            values, label = data
            values = values[np.isfinite(values)]
            edges = np.linspace(0, 30, 61)
            counts, _ = np.histogram(np.clip(values, 0, 30), edges)
            hist = hv.Histogram((edges, counts), kdims=[hv.Dimension("dE_hist", label=f"{label} (values above 30 in the last bin)")], vdims=["pixels"])
            mean = float(values.mean()) if values.size else 0.0
            med = float(np.median(values)) if values.size else 0.0
            return (hist * hv.VLine(mean).opts(color="red") * hv.VLine(med).opts(color="orange", line_dash="dashed")).opts(
                title=f"{label}: mean {mean:.2f}, median {med:.2f}")

        hist = hv.DynamicMap(show_hist, streams=[self.hist_pipe]).opts(
            hv.opts.Histogram(frame_height=200, frame_width=290, color="#4c78a8", framewise=True, axiswise=True))
        self.panes["hist"] = pn.pane.HoloViews(hist, css_classes=["camsim-hist"], linked_axes=False)
        self.stats = pn.pane.Markdown("", css_classes=["camsim-stats"], margin=(0, 10))
        self.status = pn.pane.Str("", css_classes=["camsim-status"], sizing_mode="stretch_width",
                                  styles={"font-size": "10px", "white-space": "pre-wrap", "word-break": "break-all"},
                                  stylesheets=["pre { white-space: pre-wrap; word-break: break-all; }"])
        state.param.watch(lambda e: self.update(), ["result", "metric"])
        self.update()

    def update(self):
        res = self.state.result
        if res is None or res.raw is None:
            return
        raw = res.raw
        shape = raw.data.shape[:2]
        self.pipes["raw"].send((raw_rgb(raw), self.TITLES["raw"]))
        self.pipes["demosaiced"].send(
            (planes_rgb(res.demosaiced) if res.demosaiced is not None else _blank(shape),
             self.TITLES["demosaiced"] + ("" if res.demosaiced is not None else " (not available)")))
        for key, img in (("rendered", res.rendered), ("ideal", res.ideal)):
            self.pipes[key].send(
                (monitor_rgb(img) if img is not None else _blank(shape),
                 self.TITLES[key] + ("" if img is not None else " (not available)")))
        de, label = self.error_map(res)
        if de is not None:
            self.de_pipe.send((np.asarray(de, float), f"{label} dE map"))
            self.hist_pipe.send((np.asarray(de, float).ravel(), f"{label} dE"))
            mean, med = float(np.nanmean(de)), float(np.nanmedian(de))
            steps = [n.removeprefix("stage:") for n, _ in res.ran]
            view = (f" · viewing {self.state.viewing}, {res.samples_per_degree:.4g} samples/deg"
                    if label == "S-CIELAB" and res.samples_per_degree else "")
            self.stats.object = (f"**{label}** mean dE **{mean:.2f}** · median **{med:.2f}**{view} · engine "
                                 f"{1000 * res.seconds:.0f} ms ({', '.join(steps) or 'nothing re-run'})")
        else:
            mean = med = None
            self.de_pipe.send((np.zeros(shape), "dE map (not available)"))
            self.stats.object = "dE not available"
        self.status.object = json.dumps({
            "params": self.state.to_dict(),
            "mean_de": None if mean is None else round(mean, 4),
            "median_de": None if med is None else round(med, 4),
            "metric": label,
            "samples_per_degree": res.samples_per_degree if label == "S-CIELAB" else None,
            "raw_hash": digest(raw.data),
            "rendered_hash": digest(res.rendered),
            "tile": None if raw.tile is None else np.asarray(raw.tile).tolist(),
            "shape": list(shape),
            "ran": [[name, round(t * 1000, 2)] for name, t in res.ran],
            "engine_ms": round(res.seconds * 1000, 2),
        }, separators=(",", ":"))

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


# -- the scene: one plane, sRGB, spectra of clicked pixels, metadata -------
class SceneView:
    MAX_SPECTRA = 6

    def __init__(self, state):
        self.state = state
        self.rgb_pipe = streams.Pipe(data=np.zeros((2, 2, 3)))
        self.plane_pipe = streams.Pipe(data=(np.zeros((2, 2)), "plane"))
        opts = dict(frame_width=380, data_aspect=1, xaxis=None, yaxis=None, toolbar="above")
        kd = ["scene_x", "scene_y"]
        rgb = hv.DynamicMap(lambda data: hv.RGB(data, kdims=kd, bounds=_bounds(data.shape)), streams=[self.rgb_pipe])
        rgb = rgb.opts(hv.opts.RGB(title="Scene (sRGB): click pixels for spectra", tools=["tap"], **opts))
        self.tap = streams.Tap(source=rgb, x=None, y=None)
        self.tap.add_subscriber(self.on_tap)
        plane = hv.DynamicMap(lambda data: hv.Image(data[0], kdims=kd, bounds=_bounds(data[0].shape)).opts(title=data[1]),
                              streams=[self.plane_pipe])
        plane = plane.opts(hv.opts.Image(cmap="gray", clim=(0, 1), **opts))
        self.spectra = []
        self.rgb_pane = pn.pane.HoloViews(rgb, css_classes=["camsim-scene-rgb"], linked_axes=True)
        self.plane_pane = pn.pane.HoloViews(plane, css_classes=["camsim-scene-plane"], linked_axes=True)
        self.spectrum_pane = pn.pane.HoloViews(self.spectrum_plot(), css_classes=["camsim-spectra"], linked_axes=False)
        self.meta = pn.pane.Markdown("", css_classes=["camsim-scene-meta"])
        self.clear = pn.widgets.Button(name="Clear spectra", css_classes=["w-clear-spectra"], width=120)
        self.clear.on_click(lambda e: self.reset_spectra())
        self.wavelength = pn.widgets.DiscreteSlider(name="Wavelength (nm)", options=[550.0], value=550.0,
                                                    css_classes=["w-wavelength"], width=280)
        self.wavelength.param.watch(lambda e: setattr(state, "wavelength", float(e.new)), "value")
        state.param.watch(lambda e: self.update(), ["scene", "wavelength"])
        self.update()

    def scene(self):
        try:
            return self.state.scene_object()
        except Exception:
            return None

    def update(self):
        scene = self.scene()
        if scene is None:
            return
        wls = [float(w) for w in scene.wavelengths]
        if self.wavelength.options != wls:
            self.wavelength.options = wls
        k = int(np.argmin(np.abs(np.asarray(wls) - float(self.state.wavelength))))
        if self.wavelength.value != wls[k]:
            self.wavelength.value = wls[k]
        self.rgb_pipe.send(scene_srgb(scene))
        plane = scene.data[:, :, k]
        self.plane_pipe.send((_normalise(plane, None), f"Radiance at {wls[k]:g} nm"))
        d = scene.describe() if hasattr(scene, "describe") else {}
        rows = [f"| {k} | {v} |" for k, v in d.items() if k not in ("comments",)]
        self.meta.object = "| | |\n|---|---|\n" + "\n".join(rows)
        if self.spectra and self.spectra[0][0] is not scene:
            self.reset_spectra()

    def on_tap(self, x=None, y=None):
        scene = self.scene()
        if scene is None or x is None or y is None:
            return
        h, w = scene.data.shape[:2]
        col, row = int(np.floor(x)), int(h - 1 - np.floor(y))
        if not (0 <= row < h and 0 <= col < w):
            return
        self.spectra = (self.spectra + [(scene, row, col)])[-self.MAX_SPECTRA:]
        self.spectrum_pane.object = self.spectrum_plot()

    def reset_spectra(self):
        self.spectra = []
        self.spectrum_pane.object = self.spectrum_plot()

    def spectrum_plot(self):
        curves = [hv.Curve([], "Wavelength (nm)", "Radiance (W/sr/m^2 per band)")]
        for scene, row, col in self.spectra:
            curves.append(hv.Curve((scene.wavelengths, scene.data[row, col]), "Wavelength (nm)",
                                   "Radiance (W/sr/m^2 per band)", label=f"pixel ({row}, {col})"))
        return hv.Overlay(curves).opts(frame_height=220, frame_width=360, title="Spectra of clicked pixels",
                                       legend_position="top_right", show_legend=True)


# -- the camera: sensor curves and mosaic tile -------------------------------
class CameraView:
    def __init__(self, state):
        self.state = state
        self.curves = pn.pane.HoloViews(hv.Curve([]), css_classes=["camsim-sensors"], linked_axes=False)
        self.tile = pn.pane.HoloViews(hv.RGB(np.zeros((2, 2, 3))), css_classes=["camsim-tile"], linked_axes=False)
        self.info = pn.pane.Markdown("", css_classes=["camsim-camera-info"])
        state.param.watch(lambda e: self.update(), ["result"])
        self.update()

    def update(self):
        res = self.state.result
        if res is None:
            return
        cam = res.camera
        wls = cam.sensors.wavelengths
        colors = sensor_colors(cam.sensors.values, wls, cam.sensors.names)
        curves = [hv.Curve((wls, v), "Wavelength (nm)", "Sensitivity", label=n).opts(color=_hex(c))
                  for v, n, c in zip(cam.sensors.values, cam.sensors.names, colors)]
        self.curves.object = hv.Overlay(curves).opts(frame_height=220, frame_width=360,
                                                     title=f"Sensors: {cam.sensors.name or cam.name}")
        self.tile.object = tile_plot(cam.mosaic, colors, cam.sensors.names)
        self.info.object = (f"**{cam.name}** · {len(cam.sensors)} sensors · image {res.raw.data.shape[0]} x "
                            f"{res.raw.data.shape[1]} px at {cam.distance} m · {cam.exposure:g} s f/{cam.f_stop:g}")


def tile_plot(tile, colors, names):
    """The mosaic tile as a coloured grid labelled with sensor names (0-based indices)."""
    if tile is None:
        return hv.Text(0.5, 0.5, "no mosaic: every pixel has every sensor").opts(
            frame_height=160, frame_width=200, xaxis=None, yaxis=None, title="Mosaic tile")
    t = np.asarray(tile)
    if t.ndim == 3:
        t = t[..., 0]
    n, m = t.shape
    rgb = colors[t]
    labels = hv.Labels([(j + 0.5, n - i - 0.5, f"{t[i, j]}:{names[t[i, j]]}") for i in range(n) for j in range(m)])
    grid = hv.RGB(rgb, bounds=(0, 0, m, n))
    return (grid * labels.opts(text_color="black", text_font_size="11pt")).opts(
        hv.opts.RGB(frame_height=40 * n + 80, data_aspect=1, xaxis=None, yaxis=None, title="Mosaic tile", toolbar=None))


def _hex(rgb):
    r, g, b = (int(round(255 * float(np.clip(c, 0, 1)))) for c in rgb)
    return f"#{r:02x}{g:02x}{b:02x}"
