"""Panel's ``FloatInput`` that reads any number the browser sends: the explorer's number boxes.

A number typed into a box travels as JSON, and JavaScript writes a whole number
below 1e21 in full ("100000000000000000000" for 1e20), which Python reads as an
``int``. Panel's number boxes test what arrives with ``np.isnan``, which takes
no integer beyond 64 bits: 99999999999999999999 typed into the noise seed (or
any box) raised ``TypeError`` in Panel's callback, a traceback in the server's
log, no message in the page, and the box out of step with the result. Here a
whole number from the browser is read as the float it was in the page before
Panel's test (one too large for a float, which only a hand-made message can
hold, as an infinity): the state then accepts or refuses it with a message.

Overrides ``_process_property_change``, a private method of Panel's widgets
(Panel 1.8-1.9): the one place a browser's value reaches the widget.
``tests/app/test_compat.py`` sends a box such a value through Panel's own event
processing and fails when it raises (a Panel that no longer calls the method).

Written by hand: Panel has no setting for it.
"""

from __future__ import annotations

import math

import panel as pn

__all__ = ["FloatInput", "as_float"]


def as_float(value):
    """A whole number from the browser as a float (an infinity of its sign beyond the float range); any other
    value as it is.

    Examples
    --------
    >>> as_float(100000000000000000000), as_float(-10 ** 400), as_float(2.5), as_float(None), as_float(True)
    (1e+20, -inf, 2.5, None, True)
    """
    if isinstance(value, int) and not isinstance(value, bool):
        try:
            return float(value)
        except OverflowError:
            return math.inf if value > 0 else -math.inf
    return value


class FloatInput(pn.widgets.FloatInput):
    """Panel's ``FloatInput``, with whole numbers from the browser read as floats (:func:`as_float`).

    Examples
    --------
    >>> box = FloatInput(value=1.0)
    >>> box._process_property_change({"value": 100000000000000000000})["value"]
    1e+20
    """

    def _process_property_change(self, props):
        props = {k: as_float(v) if k in ("value", "value_throttled") else v for k, v in props.items()}
        return super()._process_property_change(props)
