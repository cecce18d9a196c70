"""The Experiments tab: a small version of the sensors sweep (chapter Figure 1.14).

The sweep itself is the engine's (:func:`camsim_core.experiments.sensors.run`);
this view only asks for a small grid, runs it off the server's event loop
(so other sessions stay responsive) and plots mean S-CIELAB dE against alpha,
one panel per rendering method, one curve per noise level.
"""

from __future__ import annotations

import threading
import holoviews as hv
import holoviews.plotting.bokeh  # noqa: F401  (the bokeh backend, for .opts)
import panel as pn

from camsim_core.errors import CamsimError

from .safe_text import md_text
from .views import once

hv.Store.set_current_backend("bokeh")

__all__ = ["ExperimentsView", "sensors_plot"]

METHODS = ("baseline", "illuminant")


def sensors_plot(records):
    """Two panels like Figure 1.14 (a list of two Overlays): mean S-CIELAB dE vs alpha
    per noise sigma, for each rendering method."""
    sigmas = sorted({float(r["sigma"]) for r in records})
    panels = []
    for method in METHODS:
        curves = []
        for s in sigmas:
            pts = sorted((float(r["alpha"]), float(r[method])) for r in records if float(r["sigma"]) == s)
            curves.append(hv.Curve(pts, "alpha", "mean S-CIELAB dE", label=f"sigma {s:g}")
                          * hv.Scatter(pts, "alpha", "mean S-CIELAB dE", label=f"sigma {s:g}"))
        panels.append(hv.Overlay(curves).opts(title=f"{method} rendering", width=380, height=300,
                                              legend_position="top_left"))
    return panels


#: The longest text taken in the alphas or sigmas box (characters): 30 configurations need far fewer.
MAX_TEXT = 400


class ExperimentsView:
    """Widgets, a run button and the plot of a small sensors sweep."""

    def __init__(self, run):
        self.run = run
        self.alphas = pn.widgets.TextInput(name="alphas", value="0, 0.5, 1", css_classes=["w-exp-alphas"], width=200)
        self.sigmas = pn.widgets.TextInput(name="noise sigmas", value="0, 5", css_classes=["w-exp-sigmas"], width=200)
        self.button = pn.widgets.Button(name="Run small sweep", button_type="primary", css_classes=["w-exp-run"])
        self.button.on_click(self._start)
        self.message = pn.pane.Markdown(
            "A small version of Figure 1.14 (one seed, cacaphony290, no mosaic): cameras "
            "(1 - alpha) x cones + alpha x DCS-200. The full sweep: `camsim experiment sensors`.",
            css_classes=["camsim-exp-message"])
        self.plots = [pn.pane.HoloViews(hv.Curve([]).opts(width=380, height=300, title=f"{m}: not run yet"),
                                        css_classes=["camsim-exp-plot"], linked_axes=False) for m in METHODS]
        self.plot_row = pn.Row(*self.plots, visible=False)  # shown once a run has results: no empty axes before

    def _parse(self, text, name):
        if len(text) > MAX_TEXT:
            raise CamsimError(f"{name}: at most {MAX_TEXT} characters, got {len(text)}")
        try:
            return [float(v) for v in text.replace(",", " ").split()]
        except ValueError:
            raise CamsimError(f"{name}: expected numbers separated by commas, got {text!r}") from None

    def _start(self, event=None):
        try:
            alphas = self._parse(self.alphas.value, "alphas")
            sigmas = self._parse(self.sigmas.value, "sigmas")
        except CamsimError as exc:
            self.message.object = f"**Refused:** {md_text(exc)}"
            return
        if len(alphas) * len(sigmas) > 30:
            self.message.object = "**Refused:** at most 30 configurations here; use `camsim experiment sensors` for more."
            return
        self.button.disabled = True
        self.message.object = f"Running {len(alphas) * len(sigmas)} configurations..."
        doc = pn.state.curdoc
        threading.Thread(target=self._work, args=(alphas, sigmas, doc), daemon=True).start()

    def _work(self, alphas, sigmas, doc):
        """Run the sweep in a worker thread; show the outcome on the session's event loop."""
        try:
            records = self.run(alphas=alphas, sigmas=sigmas, seeds=1, workers=None)
            outcome = (records, None)
        except CamsimError as exc:
            outcome = (None, f"**Refused:** {md_text(exc)}")
        except Exception as exc:  # never a dead page
            outcome = (None, f"**Failed:** {type(exc).__name__}: {md_text(exc)}")
        if doc is not None and doc.session_context is not None:
            doc.add_next_tick_callback(once(self._show, *outcome))  # records not kept by the callback once shown
        else:
            self._show(*outcome)

    def _show(self, records, error):
        if error:
            self.message.object = error
        else:
            for pane, panel in zip(self.plots, sensors_plot(records)):
                pane.object = panel
            self.plot_row.visible = True
            self.message.object = f"Done: {len(records)} configurations (mean S-CIELAB dE against the ideal image)."
        self.button.disabled = False

    def panel(self):
        return pn.Column(pn.Row(self.alphas, self.sigmas, self.button), self.message, self.plot_row, name="Experiments")
