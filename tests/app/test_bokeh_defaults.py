"""Bokeh's defaults with the explorer's replacements (``camsim_explorer.compat.bokeh_defaults``) are what
Bokeh's own methods give: the same properties and values serialized for every model of an explorer page,
with every tab built; the same behaviour for a property left without a value and a default made per object;
the same default read for every property of the page left unset; a theme's value, not the kept default."""

from __future__ import annotations

import pytest
from bokeh.core.has_props import HasProps
from bokeh.core.property.descriptors import UnsetValueError
from bokeh.core.property.singletons import Undefined
from bokeh.document import Document

from camsim_explorer.compat import bokeh_defaults


@pytest.fixture(scope="module")
def bokehs_own():
    """Bokeh's own method (kept by the replacement), the replacement installed."""
    assert bokeh_defaults.skip_discarded_defaults(), "the replacement does not apply to this Bokeh"
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


def _each_tab():
    """An explorer page in a Bokeh document, each of its tabs built and shown in turn: yields the document once
    per tab (the page released after the last)."""
    import panel as pn

    from camsim_explorer.main import _release, create_app

    template = create_app()
    doc = Document()
    try:
        template.server_doc(doc)
        tabs = next(o for root in template.main for o in root.select(pn.Tabs))
        for index in range(len(tabs.objects)):
            tabs.active = index
            yield doc
    finally:
        _release(template.state, template.body, template)


def test_every_model_of_an_explorer_page_serializes_as_bokeh_serializes_it(bokehs_own):
    checked, classes = 0, set()
    for doc in _each_tab():
        for model in list(doc.models):
            _same(*_both(bokehs_own, model))
            _same(*_both(bokehs_own, model, include_undefined=True))
            checked += 1
            classes.add(type(model).__name__)
        # and the document as a whole: the same JSON as Bokeh's own method gives
        ours = doc.to_json()
        HasProps.query_properties_with_values = bokehs_own
        try:
            theirs = doc.to_json()
        finally:
            del bokeh_defaults._installed["query_properties_with_values"]
            assert bokeh_defaults.skip_discarded_defaults()
        assert _strip_buffers(ours) == _strip_buffers(theirs)
    assert checked > 1000 and {"figure", "ImageRGBA", "GlyphRenderer", "ColumnDataSource", "Tabs"} <= classes


def _strip_buffers(doc_json):
    """The document's JSON as text, buffers' ids and memory addresses left out (each serialization numbers the
    buffers it makes; the same arrays, two views)."""
    import re

    text = re.sub(r"<memory at 0x[0-9a-f]+>", "<memory>", repr(doc_json))
    return re.sub(r"Buffer\(id='[^']*'", "Buffer(id=?", text)


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


@pytest.fixture(scope="module")
def bokehs_own_default():
    """Bokeh's own ``_get_default`` (kept by the wrapper), the wrapper installed."""
    from bokeh.core.property.descriptors import PropertyDescriptor

    assert bokeh_defaults.plain_defaults_once(), "the wrapper does not apply to this Bokeh"
    return PropertyDescriptor._get_default.original


def test_every_unset_property_of_an_explorer_page_reads_bokehs_own_default(bokehs_own_default):
    import numpy as np
    from bokeh.core.property.descriptors import PropertyDescriptor

    compared = 0
    for doc in _each_tab():
        for _ in range(2):  # the second time from the kept defaults
            for model in list(doc.models):
                for name in model.properties(_with_props=True):
                    if name in model._property_values or name in model._unstable_default_values:
                        continue
                    descriptor = model.lookup(name)
                    if not isinstance(descriptor, PropertyDescriptor):
                        continue  # an alias of another property (read through it)
                    if descriptor.has_unstable_default(model):
                        continue  # made per object: Bokeh's own read (not kept)
                    ours, theirs = descriptor._get_default(model), bokehs_own_default(descriptor, model)
                    same = ours == theirs or (ours is None and theirs is None) or (
                        isinstance(ours, float) and np.isnan(ours) and np.isnan(theirs))
                    assert same, (type(model).__name__, name, ours, theirs)
                    compared += 1
    assert compared > 20_000 and len(bokeh_defaults._PLAIN_DEFAULTS) > 500


def test_a_themes_value_is_read_not_the_kept_default(bokehs_own_default):
    from bokeh.models import Title

    title = Title(text="t")
    assert title.text_font_size == "13px"  # Bokeh's default, now kept for Title
    title.apply_theme({"text_font_size": "30px"})  # presentation mode's theme
    assert title.text_font_size == "30px"
    title.unapply_theme()
    assert title.text_font_size == "13px"
    assert Title(text="u").text_font_size == "13px"


def test_a_subclass_overriding_a_default_keeps_its_own(bokehs_own_default):
    from bokeh.core.properties import Override
    from bokeh.models import Range1d

    class WideRange(Range1d):
        end = Override(default=10)

    assert Range1d().end == 1 and WideRange().end == 10 and Range1d().end == 1 and WideRange().end == 10


def test_a_mutable_default_is_made_per_object(bokehs_own_default):
    from bokeh.models import Plot

    a, b = Plot(), Plot()
    assert a.renderers == [] and a.renderers is not b.renderers  # a list: each plot its own
