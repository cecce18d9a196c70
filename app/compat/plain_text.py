"""A ``Str`` pane that shows its text as text: Panel's own puts it into ``<pre>`` unescaped.

Overrides ``Str._transform_object``, a private method of Panel's panes (Panel
1.8-1.9): the one place the pane's text becomes its model's HTML. Panel has no
public way to escape a ``Str`` pane's content. ``tests/app/test_compat.py``
checks that the method is still there; the explorer's escaping tests
(``tests/app/test_safe_text.py``, the browser XSS test) check the result.

Written by hand: no setting of Panel's escapes a pane's text.
"""

from __future__ import annotations

import html

import panel as pn

__all__ = ["PlainText"]


class PlainText(pn.pane.Str):
    """A ``Str`` pane that shows its text as text, in ``<pre>`` (``object`` stays the text itself).

    Examples
    --------
    >>> from camsim_explorer.compat.plain_text import PlainText
    >>> PlainText("<b>x</b>")._transform_object("<b>x</b>")["object"]
    '&lt;pre&gt;&amp;lt;b&amp;gt;x&amp;lt;/b&amp;gt;&lt;/pre&gt;'
    """

    def _transform_object(self, obj):
        text = " " if obj is None or (isinstance(obj, str) and obj == "") else str(obj)
        # escaped once for the page, once more for the model (the browser decodes that one, as for Panel's own)
        return dict(object=html.escape("<pre>" + html.escape(text) + "</pre>"))
