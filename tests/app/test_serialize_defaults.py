"""Bokeh's serialization with the explorer's replacement (``camsim_explorer.compat.serialize``) gives what
Bokeh's own method gives: the same properties and values for every model of an explorer page, with every
tab built, and the same behaviour for a property left without a value and a default made per object."""

from __future__ import annotations

import pytest
from bokeh.core.has_props import HasProps
from bokeh.core.property.descriptors import UnsetValueError
from bokeh.core.property.singletons import Undefined
from bokeh.document import Document

from camsim_explorer.compat import serialize


@pytest.fixture(scope="module")
def bokehs_own():
    """Bokeh's own method (kept by the replacement), the replacement installed."""
    assert serialize.skip_discarded_defaults(), "the replacement does not apply to this Bokeh"
    return HasProps.query_properties_with_values.original


def _both(bokehs_own, model, **kw):
    serialized = lambda descriptor: descriptor.serialized  # noqa: E731 (what to_serializable asks)
    return (bokehs_own(model, serialized, include_defaults=False, **kw),
            model.query_properties_with_values(serialized, include_defaults=False, **kw))


def _same(a, b):
    """Equal dictionaries; numpy arrays compared by value, models by identity."""
    import numpy as np

    assert a.keys() == b.keys()
    for key in a:
        x, y = a[key], b[key]
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            assert np.array_equal(x, y), key
        else:
            assert x is y or x == y, key


def test_every_model_of_an_explorer_page_serializes_as_bokeh_serializes_it(bokehs_own):
    import panel as pn

    from camsim_explorer.main import _release, create_app

    template = create_app()
    doc = Document()
    try:
        template.server_doc(doc)
        tabs = next(o for root in template.main for o in root.select(pn.Tabs))
        checked, classes = 0, set()
        for index in range(len(tabs.objects)):  # each tab built and in the document in turn
            tabs.active = index
            for model in list(doc.models):
                _same(*_both(bokehs_own, model))
                _same(*_both(bokehs_own, model, include_undefined=True))
                checked += 1
                classes.add(type(model).__name__)
        assert checked > 1000 and {"figure", "ImageRGBA", "GlyphRenderer", "ColumnDataSource", "Tabs"} <= classes
        # and the document as a whole: the same JSON as Bokeh's own method gives
        ours = doc.to_json()
        HasProps.query_properties_with_values = bokehs_own
        try:
            theirs = doc.to_json()
        finally:
            serialize._installed.clear()
            assert serialize.skip_discarded_defaults()
        assert _strip_buffers(ours) == _strip_buffers(theirs)
    finally:
        _release(template.state, template.body, template)


def _strip_buffers(doc_json):
    """The document's JSON as text, buffers' memory addresses left out (the same arrays, two views)."""
    import re

    return re.sub(r"<memory at 0x[0-9a-f]+>", "<memory>", repr(doc_json))


def test_a_property_without_a_value_raises_or_reads_undefined_as_in_bokeh(bokehs_own):
    from bokeh.models import Slider

    slider = Slider(start=0, end=1, step=0.1)  # value: required, never set
    with pytest.raises(UnsetValueError):
        bokehs_own(slider, lambda d: d.serialized, include_defaults=False)
    with pytest.raises(UnsetValueError):
        slider.query_properties_with_values(lambda d: d.serialized, include_defaults=False)
    theirs, ours = _both(bokehs_own, slider, include_undefined=True)
    assert ours["value"] is Undefined and theirs["value"] is Undefined
    _same(theirs, ours)


def test_a_default_made_per_object_is_recorded_and_sent_as_in_bokeh(bokehs_own):
    from bokeh.models import Plot

    # passed as Undefined, a per-object default (the toolbar) is made only when read: Bokeh's serialization reads
    # it, records it, and sends it from the next serialization on
    theirs_plot, ours_plot = Plot(toolbar=Undefined), Plot(toolbar=Undefined)
    serialized = lambda d: d.serialized  # noqa: E731
    first = (bokehs_own(theirs_plot, serialized, include_defaults=False),
             ours_plot.query_properties_with_values(serialized, include_defaults=False))
    second = (bokehs_own(theirs_plot, serialized, include_defaults=False),
              ours_plot.query_properties_with_values(serialized, include_defaults=False))
    assert "toolbar" not in first[0] and "toolbar" not in first[1]
    assert "toolbar" in second[0] and "toolbar" in second[1]
    assert first[0].keys() == first[1].keys() and second[0].keys() == second[1].keys()


def test_include_defaults_is_bokehs_own_answer(bokehs_own):
    from bokeh.models import Range1d

    r = Range1d(start=2)
    assert r.properties_with_values(include_defaults=True) == bokehs_own(r, lambda d: True, include_defaults=True)
    assert r.properties_with_values(include_defaults=False) == {"start": 2}
