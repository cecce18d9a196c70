"""A number box over a slider, for one number of the explorer's state.

Panel's ``EditableFloatSlider`` links its box to its slider in the browser:
whatever the box holds becomes the slider's end (or start) when it lies
beyond it. A typed ``1e999`` (Infinity) or an emptied box (null) became the
slider's range, and the slider library threw "'range' value isn't numeric"
in the page, before the server could refuse the value.

:class:`NumberSlider` is two public widgets linked on the server instead:
the box takes any number (the state refuses one out of its range and says
why, and the box shows the value in force again), the slider moves within
its own range and shows the value clamped to it. Written here because no
Panel widget keeps a typed value out of the slider's range.
"""

from __future__ import annotations

import math

import panel as pn
import param

from .compat.number_box import FloatInput

__all__ = ["NumberSlider"]


class NumberSlider(pn.viewable.Viewer):
    """A ``FloatInput`` (CSS class ``css``: tests and scripts type into ``.css input``) over a ``FloatSlider``.

    ``value`` is the number shown; a change from either widget sets it, and
    setting it moves both (the slider to the nearest end of its range).
    """

    value = param.Number(default=None, allow_None=True, doc="The number shown (any: the state checks it)")
    disabled = param.Boolean(default=False, doc="Both widgets disabled")
    visible = param.Boolean(default=True, doc="Shown at all")

    def __init__(self, *, label, css, start, end, step, value, **params):
        super().__init__(value=value, **params)
        self._range = (start, end)
        self.box = FloatInput(label=label, value=value, step=step, css_classes=[css],
                                         sizing_mode="stretch_width")
        self.slider = pn.widgets.FloatSlider(start=start, end=end, step=step, value=self._on_slider(value),
                                             show_value=False, css_classes=[f"{css}-slider"],
                                             sizing_mode="stretch_width", margin=(0, 10, 5, 10))
        self._showing = False  # set while the widgets are being moved to ``value`` (their events are echoes)
        self.box.param.watch(self._from_widget, "value")
        self.slider.param.watch(self._from_widget, "value")
        self._layout = pn.Column(self.box, self.slider, sizing_mode="stretch_width", margin=0)

    def _on_slider(self, value):
        """Where the slider shows ``value``: clamped to its range (its start when there is no finite value)."""
        start, end = self._range
        if value is None or not math.isfinite(value):
            return self.slider.value if hasattr(self, "slider") else start
        return min(max(value, start), end)

    def _from_widget(self, event):
        if not self._showing:
            self.value = event.new

    @param.depends("value", watch=True)
    def _show_value(self):
        self._showing = True
        try:
            self.box.value = self.value
            self.slider.value = self._on_slider(self.value)
        finally:
            self._showing = False

    @param.depends("disabled", "visible", watch=True)
    def _show_state(self):
        self.box.disabled = self.slider.disabled = self.disabled
        self._layout.visible = self.visible

    def __panel__(self):
        return self._layout
