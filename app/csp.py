"""The explorer's Content-Security-Policy: scripts come from the server itself, and nothing else runs.

Every HTML response of ``camsim serve`` gets a ``Content-Security-Policy``
header (a Tornado output transform, :class:`ContentSecurityPolicy`, passed
to the server as ``transforms``). The page Bokeh and Panel write holds
inline scripts of their own (the log level, the one that embeds the document
with this session's token, es-module-shims' options); the transform gives
each a nonce made for that response and allows that nonce only. So:

* script files from the server (``'self'``) and the page's own inline scripts run;
* event-handler attributes (``onerror=``, ``onload=``) never run
  (``script-src-attr 'none'``, and no ``'unsafe-inline'``), nor do
  ``javascript:`` links, nor any inline script that text put into the page
  later (a ``<script>`` an HTML pane re-creates has no nonce);
* no script, style, image, font or connection goes anywhere but this server.

A nonce, not hashes of the scripts: es-module-shims (which Panel loads to run
the page's ES-module components, such as the upload widget) tests the
browser's module support in a hidden frame with an inline script it writes
itself, and gives that script the page's nonce; without it the test never
answers and the page's components never render.

Two allowances the page needs, and why: ``blob:`` scripts and connections
(es-module-shims fetches and loads those components as modules it makes in
the browser), and ``'unsafe-eval'`` (Panel compiles its components' scripts
with ``new Function``, and BokehJS its ``CustomJS`` code: the presentation
toggle, the image views' hover formatters; without it no page renders).
Neither lets text from a link, a file or a name run: what is evaluated is
the code of Panel, Bokeh and the explorer. Styles keep ``'unsafe-inline'``:
Bokeh and Panel style every element inline, and a style cannot run script.

The page's HTML is the server's own (Panel's template and Bokeh's): user
text reaches the page only later, through the websocket, and never gets a
nonce.
"""

from __future__ import annotations

import re
import secrets

from tornado.web import OutputTransform

__all__ = ["ContentSecurityPolicy", "policy", "add_nonce", "HEADER"]

HEADER = "Content-Security-Policy"

#: An inline script element of the page, its text skipped (a "<script" inside a script's text is not a tag).
_SCRIPT = re.compile(rb"<script(?P<attrs>(?:\s[^>]*)?)>(?P<body>.*?)</script\s*>", re.S | re.I)
_SRC_OR_NONCE = re.compile(rb"""\s(?:src|nonce)\s*=""", re.I)


def policy(nonce):
    """The policy's text, allowing the inline scripts that carry ``nonce``."""
    return "; ".join([
        "default-src 'self'",
        f"script-src 'self' 'nonce-{nonce}' blob: 'unsafe-eval'",
        "script-src-attr 'none'",
        "style-src 'self' 'unsafe-inline'",
        "img-src 'self' data: blob:",
        "font-src 'self' data:",
        "connect-src 'self' blob:",
        "worker-src 'self' blob:",
        "object-src 'none'",
        "base-uri 'self'",
        "form-action 'self'",
    ])


def add_nonce(page, nonce):
    """``page`` (bytes) with ``nonce="..."`` on each inline script element (those without ``src``)."""
    attribute = b' nonce="' + nonce.encode("ascii") + b'"'

    def mark(m):
        if _SRC_OR_NONCE.search(m.group("attrs")):
            return m.group(0)
        return b"<script" + attribute + m.group(0)[len(b"<script"):]

    return _SCRIPT.sub(mark, page)


class ContentSecurityPolicy(OutputTransform):
    """Gives every HTML response :func:`policy` with a nonce of its own, and its inline scripts that nonce.

    Bokeh's page handler writes the page in one piece; in a page sent in
    parts, a script element split between two of them gets no nonce (it is
    blocked, never allowed by mistake).
    """

    def __init__(self, request):
        super().__init__(request)
        self._nonce = None

    def transform_first_chunk(self, status_code, headers, chunk, finishing):
        if headers.get("Content-Type", "").lower().startswith("text/html") and HEADER not in headers:
            self._nonce = secrets.token_urlsafe(18)
            headers[HEADER] = policy(self._nonce)
            chunk = add_nonce(chunk, self._nonce)
            if "Content-Length" in headers:
                if finishing:
                    headers["Content-Length"] = str(len(chunk))
                else:
                    del headers["Content-Length"]
        return status_code, headers, chunk

    def transform_chunk(self, chunk, finishing):
        return add_nonce(chunk, self._nonce) if self._nonce is not None else chunk
