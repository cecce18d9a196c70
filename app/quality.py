"""The explorer's "Image quality" view: MTF curve with MTF50, SNR, Macbeth patch dE, PSNR / SSIM.

Display only: every number comes from the engine's
:func:`camsim_core.metrics.report.measure_images` on the session's pipeline
result. What is measured follows the scene, as ``camsim measure`` does:
the slanted-edge chart gives the MTF, the uniform field the SNR, the Macbeth
chart the per-patch CIEDE2000; every scene gets PSNR and SSIM against the
ideal image.
"""

from __future__ import annotations

import numpy as np
import panel as pn

from camsim_core.errors import CamsimError
from camsim_core.metrics.report import default_measures, measure_images

from .curves import Curve, CurvesPlot, Mark
from .safe_text import md_text
from .shown import now, off_the_loop
from .tab import TabView

__all__ = ["QualityView", "exposure_caveat", "hint", "measures_for", "channel_colours", "mtf_figure", "CHANNEL_COLOURS"]

_HINT = "Pick the **slanted-edge** chart for the MTF, **uniform** for the SNR, **macbeth** for the patch dE."
#: The charts this tab measures, by name in the scene list.
_MEASURED_CHARTS = {"slanted-edge": "the MTF", "uniform": "the SNR", "macbeth": "the patch dE"}


def exposure_caveat(res, report):
    """A warning above measures made on a badly exposed frame (the engine's exposure flags), or "".

    A clipped edge's MTF50 read 0.74 cycles/pixel where the unclipped frame's was 0.38 (diffraction theory:
    0.40), and an edge of one or two digital units 0.70: numbers of the exposure, not of the camera, which the
    Results tab flagged but this tab showed plainly.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> res = SimpleNamespace(exposure=SimpleNamespace(flags=("clipped: 50.0 % of pixels at full scale",)))
    >>> print(exposure_caveat(res, {"mtf": {}}))
    ⚠ **Exposure**: clipped...pixels at full scale. The measures below describe this exposure, not the camera: ...
    >>> exposure_caveat(SimpleNamespace(exposure=SimpleNamespace(flags=())), {"mtf": {}})
    ''
    """
    measured = getattr(res, "exposure", None)
    flags = tuple(getattr(measured, "flags", ()) or ())
    if not flags or not any(k in report for k in ("mtf", "snr", "color", "similarity")):
        return ""
    return (f"⚠ **Exposure**: {md_text('; '.join(flags))}. The measures below describe this exposure, not the camera: "
            "a clipped edge reads sharper, a dark one is quantization noise (change the exposure, or pick the chart "
            "again for its own).")


def hint(scene):
    """What to do for a measure, under a scene that gave none: pick a chart; or, for one of those charts (made
    too small to measure by its options), pick it again from the scene list, which fits it to the frame.

    Examples
    --------
    >>> hint("cacaphony290") == _HINT
    True
    >>> print(hint("slanted-edge:size=19"))
    Picked from the scene list, the **slanted-edge** chart is sized to the camera's frame for the MTF.
    """
    base = str(scene).partition(":")[0]
    if base not in _MEASURED_CHARTS:
        return _HINT
    return f"Picked from the scene list, the **{base}** chart is sized to the camera's frame for {_MEASURED_CHARTS[base]}."


def measures_for(scene_name, result):
    """The measures the scene and the pipeline result allow."""
    names = [m for m in default_measures(scene_name) if m != "similarity"]
    if result.rendered is not None and result.ideal is not None:
        names.append("similarity")
    elif "color" in names:
        names.remove("color")
    return tuple(names)


#: Each channel's colour in the MTF plot (the luminance black and bold); other sensors take the palette in turn.
CHANNEL_COLOURS = {"R": "#d62728", "G": "#2ca02c", "B": "#1f77b4", "luminance": "black"}
_PALETTE = ("#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")
_MTF_AXES = dict(x_label="Frequency (cycles/pixel)", y_label="MTF", x_range=(0, 1), y_range=(0, 1.1))


def channel_colours(names):
    """``{name: colour}`` for the MTF curves: R red, G green, B blue, luminance black, others in turn."""
    others = iter(_PALETTE * (1 + len(names) // len(_PALETTE)))
    return {n: CHANNEL_COLOURS.get(n) or next(others) for n in names}


def mtf_figure(mtf):
    """What the MTF plot shows of a report's ``mtf``: ``(curves, marks, title)`` for :meth:`CurvesPlot.update`.

    One curve per channel (the luminance bold, black), the Nyquist frequency
    dotted and the luminance MTF50 dashed (when the curve reaches 0.5).

    Examples
    --------
    >>> curves, marks, title = mtf_figure({"luminance": {"frequency": [0, 0.5], "mtf": [1, 0.3], "mtf50": 0.25}})
    >>> [(c.name, c.colour, c.width) for c in curves], [m.x for m in marks], title
    ([('luminance', 'black', 3.0)], [0.5, 0.25], 'MTF50 0.250 cy/px (dashed)')
    """
    colours = channel_colours(list(mtf))
    curves = [Curve(name, colours[name], v["frequency"], v["mtf"], 3.0 if name == "luminance" else 1.5)
              for name, v in mtf.items()]
    lum = mtf.get("luminance") or next(iter(mtf.values()))
    marks = [Mark(0.5, "gray", "dotted")]
    if np.isfinite(lum["mtf50"]):
        marks.append(Mark(lum["mtf50"], "black", "dashed"))
    return curves, marks, f"MTF50 {lum['mtf50']:.3f} cy/px (dashed)"


def _snr_table(snr):
    rows = [f"| {k} | {v['mean']:.2f} | {v['sigma']:.3f} | {v['snr_db']:.2f}{' (saturated)' if v['saturated'] else ''} |"
            for k, v in snr["channels"].items()]
    y0, y1, x0, x1 = snr["roi"]
    shading = ", its shading (lens fall-off) removed" if snr.get("detrended") else ""
    return (f"**SNR** of the raw on the central region (rows {y0}-{y1}, columns {x0}-{x1}){shading}\n\n"
            "| channel | mean (DU) | sigma (DU) | SNR (dB) |\n|---|---|---|---|\n" + "\n".join(rows))


def _color_table(color):
    de = np.asarray(color["per_patch"])
    rows = ["| " + " | ".join(f"{v:.2f}" for v in de[6 * r : 6 * r + 6]) + " |" for r in range(4)]
    return (f"**Macbeth chart, CIEDE2000 per patch against the ideal image**: mean {color['mean']:.2f}, "
            f"max {color['max']:.2f}\n\n| | | | | | |\n|---|---|---|---|---|---|\n" + "\n".join(rows))


class QualityView(TabView):
    """MTF curve, SNR table, patch dE table and similarity line, following the state's result.

    A :class:`~camsim_explorer.tab.TabView`: it updates when the state's result changes, at once while its
    tab is shown, once when the tab is next shown otherwise.
    While the tab is shown, a new result is measured in the session's computing thread with the rest of
    the result (:meth:`prepare`, one of ``ExplorerState.preparers``); a result the tab had not measured when
    it opens is measured in a session thread. The event loop, which serves every page, only shows the
    numbers: an SSIM of a frame-sized chart, measured on it, held every page 0.6-5 s in the test suite.

    Parameters
    ----------
    state : ExplorerState
        The session's state, whose pipeline result is measured.
    when_shown : callable, optional
        The tab's gate: ``when_shown(fn)`` is ``fn`` run now or when the tab is shown.

    Examples
    --------
    >>> from camsim_explorer.state import ExplorerState
    >>> view = QualityView(ExplorerState())
    >>> "similarity" in view.report and "mtf" not in view.report  # the default scene: no slanted edge
    True
    """

    def __init__(self, state, when_shown=now, **params):
        self.report = {}
        self.curves = CurvesPlot("Slanted-edge MTF", **_MTF_AXES, frame_width=420, frame_height=240, marks=2)
        self.mtf_plot = pn.pane.Bokeh(self.curves.figure)
        # shown and hidden as a whole (the Bokeh pane's own ``visible`` would be passed to the figure)
        self.mtf = pn.Column(self.mtf_plot, css_classes=["camsim-mtf"], visible=False, margin=0)
        self.text = pn.pane.Markdown("", css_classes=["camsim-quality"], sizing_mode="stretch_width")
        self._measured = None  # (result, measures, (report, problem)) made by ``prepare`` or a session thread
        self._measuring = None  # (result, measures) being measured in a session thread
        super().__init__(state, when_shown, **params)
        state.preparers.append(self.prepare)
        self._layout = pn.Column(self.mtf, self.text, name="Image quality", sizing_mode="stretch_width")
        self.update()

    def _measure(self, what, res):
        """``(report, problem)``: the engine's measures ``what`` of ``res``, or why they were not made."""
        try:
            report = measure_images(what, raw=res.raw, demosaiced=res.demosaiced, rendered=res.rendered,
                                    ideal=res.ideal, monitor=self.state.monitor, camera=getattr(res, "camera", None))
        except CamsimError as exc:
            return {}, f"**Not measured**: {md_text(exc)}"
        return report, exposure_caveat(res, report)

    def prepare(self, res):
        """Measure a new result while the tab is shown (in the computing thread: ``ExplorerState.preparers``).

        :meth:`update` shows these numbers when its result and measures are
        the ones it would make (a chart fitted meanwhile is named otherwise,
        and measures the same); it measures on its own otherwise.
        """
        if res is None or res.raw is None or not self._tab_shown():
            return
        what = measures_for(self.state.scene, res)
        self._measured = (res, what, self._measure(what, res))

    def update(self):
        """Show the measures of the state's result: made by :meth:`prepare` already, else measured now outside
        a server, or in a session thread in one (the tab says so meanwhile) and shown on the page's next tick."""
        res = self.state.result
        if res is None or res.raw is None:
            return
        what = measures_for(self.state.scene, res)
        held = self._measured
        if held is not None and held[0] is res and held[1] == what:
            return self._show(*held[2])
        if self._measuring is not None and self._measuring[0] is res and self._measuring[1] == what:
            return  # already in a thread

        def measured(outcome):  # on the page's next tick: shown if the tab still wants it, held otherwise
            self._measured, self._measuring = (res, what, outcome), None
            self._update_when_shown()

        self._measuring = (res, what)
        if off_the_loop(lambda: self._measure(what, res), measured,
                        lambda exc: ({}, f"**Not measured**: {md_text(f'{type(exc).__name__}: {exc}')}")):
            self.mtf.visible = False
            self.text.object = "Measuring the result shown..."

    def _show(self, report, problem):
        """The numbers of one report (or why there are none), as tables, a line and the MTF plot."""
        self.report = report
        parts = [problem] if problem else []
        if "mtf" in self.report:
            self._plot_mtf(self.report["mtf"])
            lines = [f"| {k} | {v['mtf50']:.3f} | {v['mtf_nyquist']:.3f} |" for k, v in self.report["mtf"].items()]
            parts.append("| channel | MTF50 (cycles/px) | MTF at Nyquist |\n|---|---|---|\n" + "\n".join(lines))
        self.mtf.visible = "mtf" in self.report
        if "snr" in self.report:
            parts.append(_snr_table(self.report["snr"]))
        if "color" in self.report:
            parts.append(_color_table(self.report["color"]))
        if "similarity" in self.report:
            s = self.report["similarity"]
            parts.append(f"**Against the ideal image**: PSNR {s['psnr_db']:.2f} dB · SSIM {s['ssim']:.4f} · "
                         f"mean dE\\*ab {s['mean_delta_e_ab']:.2f}")
        if not any(k in self.report for k in ("mtf", "snr", "color")):
            parts.append(hint(self.state.scene))  # not "pick the slanted-edge chart" under the slanted edge
        self.text.object = "\n\n".join(parts)

    def _plot_mtf(self, mtf):
        """Draw ``mtf`` as new data for the plot's figure (made once: a new number of curves, a camera with
        other sensors, shows or hides curves of the same figure)."""
        curves, marks, title = mtf_figure(mtf)
        self.curves.update(curves, marks, title=title)
