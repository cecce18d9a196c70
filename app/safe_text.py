"""Text from users shown as text: the one place the explorer escapes what it did not write itself.

Panel's Markdown panes (and so its Alert), its HTML pane and even its ``Str``
pane put their content into the page as HTML: a scene name, a pinned design's
name, a link's parameter or an error message quoting one would otherwise run
as markup (``<img src=x onerror=...>``) in the page of whoever opens the link
or the file. Every such string goes through one of these before it reaches a
pane:

* :func:`html_text` for HTML (the compare table, the :class:`~camsim_explorer.views.Text` labels);
* :func:`md_text` for Markdown (messages, the alert, tables): HTML-escaped and
  every Markdown punctuation mark backslash-escaped, so that neither tags,
  ``[links](javascript:...)``, emphasis, code spans, tables, emoji codes
  nor math come out of it; on a line of its own it stays one line;
* :class:`PlainText`, a ``Str`` pane whose content is shown as text (Panel's own
  wraps it in ``<pre>`` unescaped; in :mod:`camsim_explorer.compat.plain_text`: it overrides a
  private method of Panel's pane).
"""

from __future__ import annotations

import html
import re

from .compat.plain_text import PlainText

__all__ = ["html_text", "md_text", "PlainText"]

#: ASCII punctuation: CommonMark lets a backslash make any of it literal.
_PUNCTUATION = re.compile(r"""([!#$%()*+,\-./:;=?@\[\\\]^_`{|}~])""")
#: The five characters HTML needs escaped, as entities (which Markdown decodes to text).
_ENTITIES = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#x27;"}
_LINE_BREAKS = re.compile(r"[\r\n\t\f\v\u2028\u2029\x85]+")


def html_text(value):
    """``value`` as text inside HTML (element content or a quoted attribute): ``&<>"'`` escaped."""
    return html.escape(str(value), quote=True)


def md_text(value):
    """``value`` as literal text inside Markdown: shown exactly, never markup.

    Line breaks become spaces (a message stays on its line, a table cell in
    its cell); ``&<>"'`` become entities; every other ASCII punctuation mark
    gets a backslash.
    """
    text = _LINE_BREAKS.sub(" ", str(value))
    out = []
    for part in re.split(r"""([&<>"'])""", text):
        out.append(_ENTITIES[part] if part in _ENTITIES else _PUNCTUATION.sub(r"\\\1", part))
    return "".join(out)
