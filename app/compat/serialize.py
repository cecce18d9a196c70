"""Bokeh's serialization of a model without computing the defaults it then throws away.

Every model a page sends to the browser (a page's first document, a tab shown
again, a pinned design's plots) goes through
``HasProps.query_properties_with_values(include_defaults=False)``. Bokeh's
loop there reads the value of every property before it looks whether the
property is one to send (its own comment: "this should happen before
get_value()"); for a property left at its default, reading the value makes
the default anew (the class's overridden defaults merged over its whole
hierarchy, the default copied, then validated) and the value is dropped. A
figure has about a hundred properties, few of them set.

:func:`skip_discarded_defaults` replaces that method with the same loop in
which a property not to be sent is skipped before its value is made, except
where reading the value does something: a property without a default
(reading it raises ``UnsetValueError``, or gives ``Undefined`` when undefined
values are asked for) and one whose default is made per object (reading it
records the object's own default, sent from then on). The dictionary returned
is the same; ``tests/app/test_serialize_defaults.py`` compares it with
Bokeh's own method for every model of an explorer page.

Measured (2026-11-29, Bokeh 3.9): a document of 20 figures serialized in
51-97 ms instead of 340-560 ms, the same JSON; Bokeh's default making was 39 %
of the thread that builds a page for a link with four pinned designs.

The replacement is installed only over the method it was written against
(:data:`BOKEH_SOURCE_SHA256`, a digest of its source): on another Bokeh the
explorer keeps Bokeh's own method, and :func:`camsim_explorer.compat.apply`
logs it (``tests/app/test_compat.py`` fails).

Written by hand: Bokeh offers no setting for it.
"""

from __future__ import annotations

import hashlib
import inspect

__all__ = ["skip_discarded_defaults", "matches_bokeh", "BOKEH_SOURCE_SHA256"]

#: The digest of ``HasProps.query_properties_with_values``'s source (Bokeh 3.8 and 3.9) that the replacement
#: repeats; another source means another loop, and the replacement is not installed.
BOKEH_SOURCE_SHA256 = "e864a09d384658f4"

_installed = {}
#: Per model class: the names of the properties whose value is read even when it is not sent (see
#: :func:`_must_read`); a class's properties and defaults are fixed when it is made.
_MUST_READ = {}


def _digest(fn):
    return hashlib.sha256(inspect.getsource(fn).encode()).hexdigest()[:16]


def _must_read(obj):
    """The names of ``obj``'s properties whose value Bokeh's loop reads with an effect: no default (reading
    raises, or gives ``Undefined``) or a default made per object (reading records it). Kept per class."""
    cls = type(obj)
    names = _MUST_READ.get(cls)
    if names is None:
        from bokeh.core.property.singletons import Undefined

        overrides = cls._overridden_defaults()
        names = set()
        for name in cls.properties(_with_props=True):
            descriptor = cls.lookup(name)
            default = overrides[name] if name in overrides else descriptor.property._default
            if default is Undefined or descriptor.has_unstable_default(obj):
                names.add(name)
        names = _MUST_READ[cls] = frozenset(names)
    return names


def matches_bokeh():
    """True when Bokeh's method is the one the replacement was written against (or already replaced)."""
    from bokeh.core.has_props import HasProps

    return bool(_installed) or _digest(HasProps.query_properties_with_values) == BOKEH_SOURCE_SHA256


def skip_discarded_defaults():
    """Install the replacement of ``HasProps.query_properties_with_values`` (idempotent); True when installed.

    Returns
    -------
    bool
        False when Bokeh's method is not the one it was written against (Bokeh's own is kept).

    Examples
    --------
    >>> from bokeh.models import Range1d
    >>> from camsim_explorer.compat.serialize import skip_discarded_defaults
    >>> skip_discarded_defaults()
    True
    >>> Range1d(start=2).properties_with_values(include_defaults=False)
    {'start': 2}
    """
    if _installed:
        return True
    if not matches_bokeh():
        return False
    from bokeh.core.has_props import HasProps
    from bokeh.core.property.descriptors import UnsetValueError
    from bokeh.core.property.singletons import Undefined
    from bokeh.core.property.wrappers import PropertyValueContainer

    original = HasProps.query_properties_with_values

    def query_properties_with_values(self, query, *, include_defaults=True, include_undefined=False):
        if include_defaults:  # every value is wanted: Bokeh's own loop
            return original(self, query, include_defaults=True, include_undefined=include_undefined)
        # Bokeh's loop (its comments' TODOs aside), with the keys not selected skipped before their value is made
        selected_keys = set(self._property_values.keys()) | set(self._unstable_default_values.keys())
        themed_keys = set()
        themed_values = self.themed_values()
        if themed_values is not None:
            themed_keys = set(themed_values.keys())
            selected_keys |= themed_keys
        must_read = _must_read(self)
        result = {}
        for key in self.properties(_with_props=True):
            descriptor = self.lookup(key)
            if not query(descriptor):
                continue
            if key not in selected_keys and key not in must_read:
                continue  # a default Bokeh would make, then drop
            try:
                value = descriptor.get_value(self)
            except UnsetValueError:
                if include_undefined:
                    value = Undefined
                else:
                    raise
            else:
                if key not in selected_keys:
                    continue
                if key not in themed_keys:
                    if isinstance(value, PropertyValueContainer) and key in self._unstable_default_values:
                        continue
            result[key] = value
        return result

    query_properties_with_values.original = original
    HasProps.query_properties_with_values = query_properties_with_values
    _installed["query_properties_with_values"] = original
    return True
