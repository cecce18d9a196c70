"""The Experiments tab: a small version of the sensors sweep (chapter Figure 1.14).

The sweep itself is the engine's (:func:`camsim_core.experiments.sensors.run`);
this view only asks for a small grid, runs it off the server's event loop
(so other sessions stay responsive) and plots mean S-CIELAB dE against alpha,
one panel per rendering method, one curve per noise level.
"""

from __future__ import annotations

import threading

import panel as pn

from camsim_core.errors import CamsimError

from .curves import Curve, CurvesPlot
from .safe_text import md_text
from .shown import next_tick
from .views import once

__all__ = ["ExperimentsView", "sensors_curves", "sensors_plot"]

METHODS = ("baseline", "illuminant")


#: The curves' colours, one per noise level in turn.
_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")


def sensors_curves(records):
    """The curves of Figure 1.14 from the engine's sweep records: ``{method: [Curve, ...]}``, mean S-CIELAB
    dE against alpha, one curve per noise sigma (in increasing order), for each rendering method.

    Examples
    --------
    >>> records = [{"alpha": a, "sigma": s, "baseline": a + s, "illuminant": a} for a in (0, 1) for s in (0, 5)]
    >>> [(c.name, list(c.ys)) for c in sensors_curves(records)["baseline"]]
    [('sigma 0', [0.0, 1.0]), ('sigma 5', [5.0, 6.0])]
    """
    sigmas = sorted({float(r["sigma"]) for r in records})
    out = {}
    for method in METHODS:
        out[method] = []
        for i, s in enumerate(sigmas):
            pts = sorted((float(r["alpha"]), float(r[method])) for r in records if float(r["sigma"]) == s)
            out[method].append(Curve(f"sigma {s:g}", _COLOURS[i % len(_COLOURS)], [p[0] for p in pts],
                                     [p[1] for p in pts]))
    return out


def _panel(method):
    # alpha is a mixture's weight, 0 to 1: the axis shows that range whatever was run (one alpha drew -1 to 1);
    # the legend under the plot: in its top-left corner eight sigmas' names covered the points at alpha 0
    return CurvesPlot(f"{method}: not run yet", "alpha", "mean S-CIELAB dE", frame_width=320, frame_height=240,
                      legend_location="below", points=True, x_range=(-0.05, 1.05))


def sensors_plot(records):
    """Two panels like Figure 1.14 (a list of two Bokeh figures, baseline and illuminant rendering): mean
    S-CIELAB dE against alpha, one curve (line and points) per noise sigma.

    Examples
    --------
    >>> records = [{"alpha": a, "sigma": 0, "baseline": a, "illuminant": a / 2} for a in (0, 0.5, 1)]
    >>> [f.title.text for f in sensors_plot(records)]
    ['baseline rendering', 'illuminant rendering']
    """
    figures = []
    for method, curves in sensors_curves(records).items():
        plot = _panel(method)
        plot.update(curves, title=f"{method} rendering")
        figures.append(plot.figure)
    return figures


#: The longest text taken in the alphas or sigmas box (characters): 30 configurations need far fewer.
MAX_TEXT = 400


class ExperimentsView:
    """Widgets, a run button and the plot of a small sensors sweep."""

    def __init__(self, run):
        self.run = run
        self.alphas = pn.widgets.TextInput(label="alphas", value="0, 0.5, 1", css_classes=["w-exp-alphas"], width=200)
        self.sigmas = pn.widgets.TextInput(label="noise sigmas", value="0, 5", css_classes=["w-exp-sigmas"], width=200)
        self.button = pn.widgets.Button(label="Run small sweep", color="primary", css_classes=["w-exp-run"])
        self.button.on_click(self._start)
        self.message = pn.pane.Markdown(
            "A small version of Figure 1.14 (one seed, cacaphony290, no mosaic): cameras "
            "(1 - alpha) x cones + alpha x DCS-200. The chapter's set-up, not the sidebar's: 3.32 m, 8 bits, one "
            "exposure for every camera (its most sensitive at 90 % of the range), the chapter's ideal image, "
            "S-CIELAB at the camera's 102.6 samples/deg. The full sweep: `camsim experiment sensors`.",
            css_classes=["camsim-exp-message"])
        self.curves = {m: _panel(m) for m in METHODS}
        self.plots = [pn.Column(pn.pane.Bokeh(c.figure), css_classes=["camsim-exp-plot"], margin=0)
                      for c in self.curves.values()]
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
            next_tick(doc, once(self._show, *outcome))  # records not kept by the callback once shown
        else:
            self._show(*outcome)

    def _show(self, records, error):
        if error:
            self.message.object = error
        else:
            for method, curves in sensors_curves(records).items():
                self.curves[method].update(curves, title=f"{method} rendering")
            self.plot_row.visible = True
            n = len(records)
            self.message.object = (f"Done: {n} configuration{'s' if n != 1 else ''} (mean S-CIELAB dE against the "
                                   "ideal image).")
        self.button.disabled = False

    def panel(self):
        return pn.Column(pn.Row(self.alphas, self.sigmas, self.button), self.message, self.plot_row, name="Experiments")
