"""A plot of named curves made once, whose data is replaced: the explorer's one way to draw curves.

The Image quality tab's MTF, the Optics & sensor tab's diffraction MTF and
photon-transfer curve, the Experiments tab's panels and the Compare tab's
sweep are all "a few named curves and some vertical marks". Each is a
:class:`CurvesPlot`: one Bokeh figure made once per page, a line (and, if
asked, points) per curve made when first needed, and new data sent as new
column values. Nothing is made anew for a new result, so a plot never costs
the event loop a new figure (a HoloViews plot made for each result took
130-400 ms there), its number of curves may change from one result to the
next, and the document's theme (presentation mode's large text) reaches it
like every other Bokeh model.

Written by hand over Bokeh's public models (``figure``, ``ColumnDataSource``,
``Legend``, ``Span``): neither Bokeh nor Panel offers a figure whose curves
come and go by name.
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

from bokeh.events import Tap
from bokeh.models import ColumnDataSource, DataRange1d, Legend, LegendItem, Range1d, Span
from bokeh.plotting import figure

from .views import held

__all__ = ["CurvesPlot", "Curve", "Mark"]


class Curve(NamedTuple):
    """One curve: its legend name, line colour, x and y values, and line width (screen pixels).

    Examples
    --------
    >>> Curve("G", "#2ca02c", [0, 1], [1.0, 0.5]).width
    2.0
    """

    name: str
    colour: str
    xs: Sequence[float]
    ys: Sequence[float]
    width: float = 2.0


class Mark(NamedTuple):
    """A vertical line across the plot at ``x`` (data units), in ``colour``, ``dash`` a Bokeh dash pattern.

    Examples
    --------
    >>> Mark(0.5, dash="dotted")
    Mark(x=0.5, colour='gray', dash='dotted')
    """

    x: float
    colour: str = "gray"
    dash: str = "dashed"


class CurvesPlot:
    """A Bokeh figure of named curves and vertical marks, made once; :meth:`update` replaces what it shows.

    Parameters
    ----------
    title, x_label, y_label : str
        The figure's title and axis labels (:meth:`update` may change them).
    frame_width, frame_height : int
        The plotting area, screen pixels.
    x_range, y_range : (float, float), optional
        Fixed axis ranges (default: fitted to the data shown).
    legend_location : str
        Where the legend sits in the plot ("top_right", "top_left", ...), or "below": under the plotting area,
        four names a row, covering no curve.
    points : bool
        Draw each curve's points as well as its line.
    marks : int
        How many vertical marks the plot may show (made with the figure).
    on_click : callable, optional
        ``on_click(x, y)`` with a click's data coordinates, on the event loop of ``doc``
        (the session's document; default the current one).
    css_classes : sequence of str
        Classes of the figure's element in the page (for tests and styling).

    Attributes
    ----------
    figure : bokeh.plotting.figure
        The figure (put it in a page with ``pn.pane.Bokeh``).
    sources : list of ColumnDataSource
        One per curve slot, columns ``x`` and ``y``.
    lines, points : list of GlyphRenderer
        The slots' line and point renderers (``points`` empty without points).

    Examples
    --------
    >>> plot = CurvesPlot("MTF", "cycles/pixel", "MTF", x_range=(0, 1), marks=1)
    >>> plot.update([Curve("R", "#d62728", [0, 0.5], [1.0, 0.4]), Curve("G", "#2ca02c", [0, 0.5], [1.0, 0.6])],
    ...             marks=[Mark(0.5, dash="dotted")], title="MTF50 0.3")
    >>> plot.figure.title.text, plot.shown()
    ('MTF50 0.3', {'R': '#d62728', 'G': '#2ca02c'})
    >>> plot.update([Curve("L", "black", [0, 1], [1, 0])])  # fewer curves: the others are hidden, not remade
    >>> plot.shown(), len(plot.lines)
    ({'L': 'black'}, 2)
    """

    def __init__(self, title="", x_label="", y_label="", *, frame_width=420, frame_height=240, x_range=None,
                 y_range=None, legend_location="top_right", points=False, marks=0, on_click=None, doc=None,
                 css_classes=(), tools="pan,wheel_zoom,box_zoom,reset,save"):
        # Ranges fitted to the curves shown only: a slot hidden when fewer curves are shown keeps its last data,
        # which Bokeh's default ranges would still fit.
        ranges = {"x_range": Range1d(*x_range) if x_range is not None else DataRange1d(only_visible=True),
                  "y_range": Range1d(*y_range) if y_range is not None else DataRange1d(only_visible=True)}
        # a title is never empty: a title set later on a figure made with an empty one was not drawn (Bokeh 3.9)
        self.figure = figure(frame_width=frame_width, frame_height=frame_height, tools=tools, toolbar_location="right",
                             title=title or " ", x_axis_label=x_label, y_axis_label=y_label, **ranges)
        if css_classes:
            self.figure.css_classes = list(css_classes)
        if legend_location == "below":  # outside the plotting area, four names a row: it covers no point
            self.legend = Legend(items=[], location="top_left", ncols=4, padding=4, spacing=2)
            self.figure.add_layout(self.legend, "below")
        else:
            self.legend = Legend(items=[], location=legend_location)
            self.figure.add_layout(self.legend)
        self._points = bool(points)
        self.sources, self.lines, self.points, self.marks = [], [], [], []
        # With no curve shown, fitted ranges have nothing to fit: the browser logged "could not set initial
        # ranges" for each empty plot drawn. An undrawn unit square gives them an extent until a curve comes.
        self._extent = ColumnDataSource(dict(x0=[0.0], y0=[0.0], x1=[1.0], y1=[1.0]))
        self.figure.segment("x0", "y0", "x1", "y1", source=self._extent, line_alpha=0)
        # the marks are made with the figure: a Span added to a figure the page has hidden has no view in the
        # browser, whose next change of it then fails ("cannot find a view for Span", the plot not drawn again)
        for _ in range(int(marks)):
            span = Span(location=0, dimension="height", line_width=1, visible=False)
            self.figure.add_layout(span)
            self.marks.append(span)
        if on_click is not None:
            self.figure.on_event(Tap, held(lambda event: on_click(event.x, event.y), doc))

    def update(self, curves, marks=(), title=None, x_label=None, y_label=None):
        """Show ``curves`` (:class:`Curve` or ``(name, colour, xs, ys[, width])``) and ``marks``
        (:class:`Mark` or ``(x[, colour, dash])``); ``title`` and the labels, when given, replace the figure's.
        Only what changed is sent to the page."""
        curves = [c if isinstance(c, Curve) else Curve(*c) for c in curves]
        marks = [m if isinstance(m, Mark) else Mark(*m) for m in marks]
        fig = self.figure
        if title is not None and fig.title.text != (title or " "):
            fig.title.text = title or " "
        for axis, label in ((fig.xaxis[0], x_label), (fig.yaxis[0], y_label)):
            if label is not None and axis.axis_label != label:
                axis.axis_label = label
        while len(self.sources) < len(curves):  # the renderers of a slot, made when first needed
            src = ColumnDataSource(dict(x=[], y=[]))
            renderers = [fig.line("x", "y", source=src, line_width=2)]
            if self._points:
                renderers.append(fig.scatter("x", "y", source=src, size=7))
                self.points.append(renderers[-1])
            self.lines.append(renderers[0])
            self.sources.append(src)
            self.legend.items = list(self.legend.items) + [LegendItem(label="", renderers=renderers)]
        for i, src in enumerate(self.sources):
            shown = i < len(curves)
            if shown:
                c = curves[i]
                src.data = dict(x=list(map(float, c.xs)), y=list(map(float, c.ys)))
                line = self.lines[i].glyph
                if line.line_color != c.colour or line.line_width != c.width:
                    line.update(line_color=c.colour, line_width=c.width)
                    if self._points:
                        self.points[i].glyph.update(fill_color=c.colour, line_color=c.colour)
                if self.legend.items[i].label != {"value": c.name}:
                    self.legend.items[i].label = {"value": c.name}
            models = [self.lines[i], self.legend.items[i]] + ([self.points[i]] if self._points else [])
            for model in models:
                if model.visible != shown:
                    model.visible = shown
        extent = [] if curves else [0.0]
        if list(self._extent.data["x0"]) != extent:
            self._extent.data = dict(x0=extent, y0=extent, x1=[v + 1.0 for v in extent], y1=[v + 1.0 for v in extent])
        if len(marks) > len(self.marks):
            raise ValueError(f"{len(marks)} marks for a plot made with {len(self.marks)}")
        for i, span in enumerate(self.marks):
            if i < len(marks):
                m = marks[i]
                if (span.location, span.line_color, span.line_dash) != (m.x, m.colour, m.dash):
                    span.update(location=m.x, line_color=m.colour, line_dash=m.dash)
            if span.visible != (i < len(marks)):
                span.visible = i < len(marks)

    def shown(self):
        """``{name: colour}`` of the curves shown, in order (what the legend lists)."""
        return {item.label["value"]: line.glyph.line_color
                for item, line in zip(self.legend.items, self.lines) if item.visible}
