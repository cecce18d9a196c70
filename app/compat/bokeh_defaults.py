"""Bokeh's defaults made only when they are used, and a plain default made once per class.

A Bokeh model's property left at its default has no stored value: every read
makes the default anew (the class's overridden defaults merged over its
whole hierarchy, the default copied, then validated). The explorer's pages
hold a few thousand models of about a hundred properties each, few of them
set, and Bokeh reads them all often: to send a model to the browser, to walk
the page's models after every change (``Model.references``), to compare a
value about to be set with the old one. Two changes, each where the
explorer's server spent its time:

* :func:`skip_discarded_defaults` - every model a page sends (a page's first
  document, a tab shown again, a pinned design's plots) goes through
  ``HasProps.query_properties_with_values(include_defaults=False)``. Bokeh's
  loop there reads the value of every property before it looks whether the
  property is one to send (its own comment: "this should happen before
  get_value()"), and drops the defaults it made. The replacement is the same
  loop in which a property not to be sent is skipped before its value is
  made, except where reading it does something: a property without a
  default (reading raises ``UnsetValueError``, or gives ``Undefined`` when
  undefined values are asked for) and one whose default is made per object
  (reading records the object's own default, sent from then on). A document
  of 20 figures: 51-97 ms instead of 340-560 ms, the same JSON.
* :func:`plain_defaults_once` - a default that is a plain value (None, a
  number, a text, a tuple of them) and not made per object is the same value
  at every read: it is kept per model class and property after its first
  read, and given back as it is (Bokeh's own copy of such a value is the
  value). A theme's value (presentation mode) is never kept: a property the
  object's theme sets is read Bokeh's way.

Measured on ``camsim serve`` (2026-11-29, Bokeh 3.9, 18 switches between
tabs built before, the server's CPU): 5.5-5.8 s with Bokeh's own methods,
3.5-4.0 s with the first change, 2.7-3.0 s with both.
``tests/app/test_bokeh_defaults.py`` compares both with Bokeh's own methods
over every model of an explorer page.

Each is installed only over the Bokeh method it was written against (a digest
of its source, :data:`BOKEH_SOURCES`): on another Bokeh the explorer keeps
Bokeh's own, and :func:`camsim_explorer.compat.apply` logs it
(``tests/app/test_compat.py`` fails).

Written by hand: Bokeh offers no setting for either.
"""

from __future__ import annotations

import hashlib
import inspect

__all__ = ["skip_discarded_defaults", "plain_defaults_once", "matches_bokeh", "BOKEH_SOURCES"]

#: The digests of the sources of the Bokeh methods (3.9) that the replacements repeat or wrap; another source
#: means another method, and its replacement is not installed.
BOKEH_SOURCES = {"query_properties_with_values": "e864a09d384658f4", "_get_default": "6173b5a328b12fc3",
                 "themed_values": "668c1fc00de346e8"}

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


def _bokeh_methods():
    from bokeh.core.has_props import HasProps
    from bokeh.core.property.descriptors import PropertyDescriptor

    return {"query_properties_with_values": (HasProps, "query_properties_with_values"),
            "_get_default": (PropertyDescriptor, "_get_default"), "themed_values": (HasProps, "themed_values")}


def _install(name, replacement):
    """Put ``replacement(original)`` in place of Bokeh's method ``name`` (a key of :data:`BOKEH_SOURCES`), once,
    and only over the method it was written against; True when in place."""
    if name in _installed:
        return True
    if not matches_bokeh(name):
        return False
    owner, attr = _bokeh_methods()[name]
    original = getattr(owner, attr)
    new = replacement(original)
    new.original = original
    setattr(owner, attr, new)
    _installed[name] = original
    return True


def matches_bokeh(name="query_properties_with_values"):
    """True when Bokeh's method ``name`` (a key of :data:`BOKEH_SOURCES`) is the one its replacement was
    written against (or is already replaced)."""
    owner, attr = _bokeh_methods()[name]
    return name in _installed or _digest(getattr(owner, attr)) == BOKEH_SOURCES[name]


def skip_discarded_defaults():
    """Install the replacement of ``HasProps.query_properties_with_values`` (idempotent); True when installed.

    Returns
    -------
    bool
        False when Bokeh's method is not the one it was written against (Bokeh's own is kept).

    Examples
    --------
    >>> from bokeh.models import Range1d
    >>> from camsim_explorer.compat.bokeh_defaults import skip_discarded_defaults
    >>> skip_discarded_defaults()
    True
    >>> Range1d(start=2).properties_with_values(include_defaults=False)
    {'start': 2}
    """
    return _install("query_properties_with_values", _without_discarded_defaults)


def _without_discarded_defaults(original):
    """Bokeh's ``query_properties_with_values`` loop, the keys not to send skipped before their value is made."""
    from bokeh.core.property.descriptors import UnsetValueError
    from bokeh.core.property.singletons import Undefined
    from bokeh.core.property.wrappers import PropertyValueContainer

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

    return query_properties_with_values


#: (model class, property name) -> the plain default of that property for that class (see
#: :func:`plain_defaults_once`); filled as defaults are first read, never emptied (classes are few).
_PLAIN_DEFAULTS = {}
#: (model class, property name) whose default is not plain: made at each read, as Bokeh does, not tested again.
_NOT_PLAIN = set()
_PLAIN_TYPES = (type(None), bool, int, float, str)


def _plain(value):
    """True for a value Bokeh's copy gives back as it is: None, a bool, a number, a text, a tuple of them."""
    return type(value) in _PLAIN_TYPES or (type(value) is tuple and all(_plain(v) for v in value))


def plain_defaults_once():
    """Install the replacement of ``PropertyDescriptor._get_default`` (idempotent); True when installed.

    Returns
    -------
    bool
        False when Bokeh's method is not the one it was written against (Bokeh's own is kept).

    Examples
    --------
    >>> from bokeh.models import Range1d
    >>> from camsim_explorer.compat.bokeh_defaults import plain_defaults_once
    >>> plain_defaults_once()
    True
    >>> Range1d(start=2).end  # read twice: made once, then kept
    1
    >>> Range1d(start=3).end
    1
    """
    if not matches_bokeh("themed_values"):  # the theme is read as Bokeh 3.9 keeps it (see _plain_defaults_kept)
        return False
    return _install("_get_default", _plain_defaults_kept)


def _plain_defaults_kept(original):
    """Bokeh's ``PropertyDescriptor._get_default`` (3.9, repeated line for line), with a plain default kept per
    model class and property.

    An object's theme is read from its ``__dict__``, where Bokeh's ``HasProps.apply_theme`` puts it (what
    ``HasProps.themed_values`` returns): Bokeh's method looks the missing attribute up through
    ``HasProps.__getattr__``, which raises, 1.7 us a read against 0.13 us (14 % of the server's work at a tab
    switch went there). ``original`` (Bokeh's method, which ``_install`` hands to every replacement) is not
    called: it is kept as the replacement's ``original``."""
    from bokeh.core.property.wrappers import PropertyValueContainer

    missing = object()

    def _get_default(self, obj):
        name = self.name
        themed = obj.__dict__.get("__themed_values__")
        is_themed = themed is not None and name in themed  # the theme's value: Bokeh's way, never kept
        key = (type(obj), name)
        if not is_themed:
            kept = _PLAIN_DEFAULTS.get(key, missing)
            if kept is not missing and name not in obj._property_values:
                return kept
        if name in obj._property_values:
            raise RuntimeError("Bokeh internal error, does not handle the case of self.name already in "
                               "_property_values")
        unstable_dict = obj._unstable_themed_values if is_themed else obj._unstable_default_values
        if name in unstable_dict:
            return unstable_dict[name]
        default = self.instance_default(obj)
        if self.has_unstable_default(obj):
            if isinstance(default, PropertyValueContainer):
                default._register_owner(obj, self)
            unstable_dict[name] = default
        elif not is_themed and key not in _NOT_PLAIN:
            if _plain(default):
                _PLAIN_DEFAULTS[key] = default
            else:
                _NOT_PLAIN.add(key)
        return default

    return _get_default
