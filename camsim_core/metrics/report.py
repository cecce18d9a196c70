"""One call for the numbers a design review asks of a camera: MTF, SNR, colour accuracy, similarity.

:func:`quality_report` simulates the camera on a scene, processes the raw
as the explorer does (demosaic, render) and measures what the scene allows:

* ``"mtf"`` - slanted-edge MTF of the demosaiced linear sensor image, per
  channel and luminance (:mod:`.sharpness`);
* ``"snr"`` - SNR of the raw (per sensor class) on the central half of a
  uniform field (:mod:`.snr`);
* ``"color"`` - per-patch CIEDE2000 of the rendered Macbeth chart against
  the ideal image (:mod:`.chart`);
* ``"similarity"`` - PSNR and SSIM of the rendered image against the
  ideal image, beside the mean CIELAB dE (:mod:`.similarity`, :mod:`.cielab`).

The ideal image is by default the scene's (``reference="scene"`` of
:func:`camsim_core.ideal_image`: the scene through the cones on the camera's
pixel grid, an ideal lens, unquantized, normalised by the scene's white), so
the measures do not reward a dim or coarsely quantized camera with a
reference as dim or coarse as itself; ``reference="chapter"`` compares with
the chapter's 8-bit cone camera at the camera's exposure. ``camsim measure``
uses the scene's.

The result holds plain numbers and lists (JSON-ready).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["quality_report", "measure_images", "MEASURES", "default_measures"]

MEASURES = ("mtf", "snr", "color", "similarity")
_BY_SCENE = {"slanted-edge": ("mtf",), "uniform": ("snr",), "macbeth": ("color",)}


def default_measures(scene_name):
    """The measures a scene allows by its name: edge -> mtf, uniform -> snr, macbeth -> color, else similarity.

    A chart's options (``slanted-edge:size=860,...``, as a chart fitted to the frame is named) do not change
    what it measures.

    Examples
    --------
    >>> default_measures("slanted-edge:size=860,angle=5")
    ('mtf',)
    >>> default_measures("cacaphony290")
    ('similarity',)
    """
    return _BY_SCENE.get(str(scene_name).partition(":")[0].strip().lower(), ("similarity",))


def _central(shape, fraction=0.5):
    h, w = shape[:2]
    dy, dx = int(h * (1 - fraction) / 2), int(w * (1 - fraction) / 2)
    return (dy, h - dy, dx, w - dx)


def measure_images(what, *, raw, demosaiced=None, rendered=None, ideal=None, monitor="simtoolbox-test", patches="layout",
                   camera=None):
    """The measures ``what`` on images already simulated and processed (the explorer's pipeline result).

    ``raw``: the camera image (SNR); ``demosaiced``: full sensor planes (MTF;
    ``raw`` itself when not mosaiced); ``rendered`` and ``ideal``: rendered
    monitor images (colour, similarity); ``patches``: where the chart's
    patches come from ("layout" of the chart generator, or "detect"ed in the
    ideal image, see :func:`~camsim_core.metrics.chart.macbeth_delta_e`); ``camera``: the camera that made ``raw``
    (an unquantized electron-level sensor's full well marks a saturated SNR). Returns the JSON-ready dict of
    :func:`quality_report` without the scene and camera names.
    """
    from ..monitor import load_monitor
    from ..rendering import to_xyz, white_xyz
    from .chart import macbeth_delta_e
    from .cielab import delta_e
    from .sharpness import edge_mtf
    from .similarity import psnr, ssim
    from .snr import region_snr

    unknown = sorted(set(what) - set(MEASURES))
    if unknown:
        raise ParameterError("what", f"unknown measure(s) {unknown}; valid: {', '.join(MEASURES)}")
    full = demosaiced if demosaiced is not None else raw
    if getattr(full, "mosaiced", False):
        raise ParameterError("demosaiced", "the MTF needs a demosaiced image")
    mon = load_monitor(monitor)
    out = {"image_shape": list(raw.data.shape[:2])}
    if ("color" in what or "similarity" in what) and (rendered is None or ideal is None):
        raise ParameterError("rendered", "colour accuracy and similarity need the rendered and the ideal image")
    if "mtf" in what:
        res = edge_mtf(full)
        out["mtf"] = {k: {"mtf50": v["mtf50"], "mtf_nyquist": v["mtf_nyquist"], "frequency": v["frequency"].tolist(),
                          "mtf": v["mtf"].tolist()} for k, v in res.items()}
    if "snr" in what:
        roi = _central(raw.data.shape)
        # the field's low-frequency shading (lens fall-off) removed before the noise is measured (ISO 15739)
        out["snr"] = {"roi": list(roi), "channels": region_snr(raw, roi, camera=camera, detrend=True), "detrended": True}
    if "color" in what:
        d = macbeth_delta_e(rendered, ideal, mon, patches=patches)
        out["color"] = {"method": "CIE 2000", "per_patch": d["per_patch"].tolist(), "mean": d["mean"], "max": d["max"],
                        "boxes": [list(b) for b in d["boxes"]], "patches": d["patches"]}
    if "similarity" in what:
        x1, x2 = to_xyz(rendered, mon), to_xyz(ideal, mon)
        out["similarity"] = {"psnr_db": psnr(rendered, ideal), "ssim": ssim(rendered, ideal),
                             "mean_delta_e_ab": float(np.mean(delta_e(x1, x2, white_xyz(mon))))}
    return out


def quality_report(scene, camera, what=None, *, demosaic="bilinear", monitor="simtoolbox-test", patches=None,
                   reference="scene", **simulate_kwargs):
    """Simulate ``camera`` on ``scene`` and measure ``what`` (names of :data:`MEASURES`; default by scene name).

    ``patches`` (colour accuracy): "layout" or "detect"; by default the
    generator's layout for the Macbeth chart scene, and a chart found in
    the image for any other scene (a photo with a chart in it).
    ``reference``: the ideal image colour accuracy and similarity compare
    with, "scene" (default) or "chapter" (:func:`camsim_core.ideal_image`).
    """
    from .. import demosaic as run_demosaic
    from .. import ideal_image, load_camera, load_monitor, load_scene, render, simulate
    from ..rendering.ideal import check_reference

    reference = check_reference(reference)
    scene = load_scene(scene)
    cam = load_camera(camera)
    names = tuple(what) if what else default_measures(scene.name)
    unknown = sorted(set(names) - set(MEASURES))
    if unknown:
        raise ParameterError("what", f"unknown measure(s) {unknown}; valid: {', '.join(MEASURES)}")
    raw = simulate(scene, cam, **simulate_kwargs)
    full = run_demosaic(raw, demosaic) if raw.mosaiced else raw
    mon = load_monitor(monitor)
    rendered = ideal = None
    if "color" in names or "similarity" in names:
        rendered = render(full, mon)
        ideal = ideal_image(scene, cam, mon, reference=reference, **simulate_kwargs)
    out = {"scene": scene.name, "camera": cam.name}
    if ideal is not None:
        out["reference"] = reference
    if patches is None:
        patches = "layout" if str(scene.name).lower() == "macbeth" else "detect"
    out.update(measure_images(names, raw=raw, demosaiced=full, rendered=rendered, ideal=ideal, monitor=mon, patches=patches))
    return out
