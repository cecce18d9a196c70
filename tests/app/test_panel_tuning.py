"""The explorer's removal of Panel per-event costs (``app.compat.tuning``) changes no result.

Each patch is compared with Panel's own method it replaces, on the same
inputs: the properties sent to the browser must be identical.
"""

from __future__ import annotations

import logging

import panel as pn
import param
from bokeh.document import Document

from camsim_explorer import compat
from camsim_explorer.compat import tuning as _panel_tuning

compat.apply()  # as the server does


def _events(widget, **values):
    return [param.parameterized.Event(what="value", name=k, obj=widget, cls=type(widget), old=None, new=v,
                                      type="changed") for k, v in values.items()]


def _plain(properties):
    """Properties with stylesheet models by their URL (each call makes new ones for a document without a cache)."""
    return {k: [getattr(v, "url", v) for v in vs] if k == "stylesheets" else vs for k, vs in properties.items()}


def _model_doc(widget):
    doc = Document()
    model = widget.get_root(doc)
    doc.add_root(model)
    return doc


def test_properties_sent_are_panels_own_for_values_and_stylesheets():
    from panel.reactive import Reactive

    patched = Reactive._update_properties
    original = patched.original
    widget = pn.widgets.FloatSlider(start=0, end=10, value=1, stylesheets=[":host { color: red; }"])
    doc = _model_doc(widget)
    for values in ({"value": 3.0}, {"name": "Noise", "disabled": True},
                   {"stylesheets": [":host { color: blue; }"]}):
        events = _events(widget, **values)
        assert _plain(patched(widget, *events, doc=doc)) == _plain(original(widget, *events, doc=doc)), values
    # a stylesheets change still carries the design's sheets before the widget's own
    sent = patched(widget, *_events(widget, stylesheets=[":host { color: blue; }"]), doc=doc)
    assert len(sent["stylesheets"]) > 1


def test_busy_tracking_is_off_and_panels_logger_builds_no_debug_records():
    from panel.io.state import state

    before = list(state._busy_counter)
    state._add_busy_event("test-event")
    assert list(state._busy_counter) == before and state.busy is False
    assert not logging.getLogger("panel.reactive").isEnabledFor(logging.DEBUG)
    assert logging.getLogger("panel").getEffectiveLevel() == logging.INFO


def test_patches_apply_once():
    assert _panel_tuning.skip_busy_tracking() is False
    assert _panel_tuning.design_only_for_stylesheets() is False
    from panel.reactive import Reactive

    assert not hasattr(Reactive._update_properties.original, "original")
