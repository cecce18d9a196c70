"""A page built for its request sends its scripts first: the browser loads them while the server builds.

A request with arguments (a shared link, a saved design) gets a page built
for it (no spare page, :mod:`.spare_session`, can hold its parameters):
1-2 s for a link with pinned designs. Bokeh's page handler answers only
once the page's session is built, and only then does the browser start on
the page's scripts (Bokeh's and Panel's, about 3 MB: fetched, compiled and
run, about a second in a browser that has not cached them). Their list is the
same in every page of the explorer. So when the last two pages served for a
path began alike, the next request for that path gets that beginning at once
(the head up to its first stylesheet: the title, the page's own styles and
every script element) while its session is built; the rest of the page
(stylesheets, which depend on the page's components, and the body with the
document) follows it. The browser parses and runs the scripts as they
arrive, on its own core, during the build.

When the page built does not begin as sent (another list of scripts), the
rest of the answer is a refresh: the next request builds its page without
the early head (the path is not steady until two pages begin alike again).
When the session cannot be made (an error in Bokeh's or Panel's code: an
error in the explorer's is a page Panel makes), the rest of the answer is a
one-line message; the server's log has the error.

Private internals, in this one module: Panel's page handler's
``get_session`` (wrapped: the head is written and flushed before the build)
and its ``write`` (the page written after the build loses the part already
sent). Tornado's ``RequestHandler.flush`` and the Content-Security-Policy
transform (:mod:`camsim_explorer.csp`, which gives each part's inline
scripts the response's nonce) are public. :func:`install` returns False and
the server logs a warning when Panel's handler lacks either method.

Written by hand: neither Bokeh nor Panel sends a page before its session.
"""

from __future__ import annotations

import logging

__all__ = ["install", "installed", "head_of", "rest_of", "REFRESH", "FAILED"]

_log = logging.getLogger("camsim.serve")
_installed = []
#: path -> the beginning (:func:`head_of`) of the last page served for it
_heads: dict = {}
#: path -> True when the last two pages served for it began alike
_steady: dict = {}
#: Where the part sent first ends: the page's first stylesheet (Panel lists the stylesheets of the components the
#: page uses, so they differ from page to page; the scripts before them do not).
MARK = '<link rel="stylesheet"'
#: The rest of an answer whose page does not begin as sent: the browser asks again (and gets a whole page).
REFRESH = '<meta http-equiv="refresh" content="0">\n</head>\n<body></body>\n</html>\n'
#: The rest of an answer whose page could not be built.
FAILED = ("</head>\n<body><p>camsim explorer: this page could not be built; the server's log says why. "
          "<a href=\"\">Try again</a>.</p></body>\n</html>\n")


def head_of(page):
    """The part of ``page`` (Bokeh's HTML for a session) that can be sent before the session is built: up to its
    first stylesheet link; None when the page has none inside its head.

    Examples
    --------
    >>> head_of('<html><head><script src="b.js"></script><link rel="stylesheet" href="a.css"></head>')
    '<html><head><script src="b.js"></script>'
    >>> head_of('<html><head></head><body><link rel="stylesheet" href="a.css"></body>') is None
    True
    """
    i = page.find(MARK)
    if i < 0 or "</head>" in page[:i].lower():
        return None
    return page[:i]


def rest_of(page, sent):
    """What to write of ``page`` after ``sent`` went first: the page past ``sent`` when it begins with it, else
    :data:`REFRESH`.

    Examples
    --------
    >>> rest_of("<head><script src='b.js'></script><link rel=...", "<head><script src='b.js'></script>")
    '<link rel=...'
    >>> rest_of("<head><script src='c.js'></script><link rel=...", "<head><script src='b.js'></script>") == REFRESH
    True
    """
    return page[len(sent):] if page.startswith(sent) else REFRESH


def _note(path, page):
    """Keep the beginning of the page served for ``path``; the path is steady when it is the one kept before."""
    head = head_of(page)
    _steady[path] = head is not None and head == _heads.get(path)
    if head is None:
        _heads.pop(path, None)
    else:
        _heads[path] = head


def installed():
    """True once :func:`install` has wrapped Panel's page handler."""
    return bool(_installed)


def matches_panel():
    """True when Panel's page handler has the methods :func:`install` wraps."""
    try:
        from panel.io.server import DocHandler
    except ImportError:
        return False
    return bool(_installed) or (callable(getattr(DocHandler, "get_session", None))
                                and callable(getattr(DocHandler, "write", None)))


def install():
    """Send a steady path's page head before its session is built, from now on (once per process); True when
    installed. Install it before :mod:`.spare_session` (a spare page, already built, is sent whole)."""
    if _installed:
        return True
    if not matches_panel():
        return False
    from panel.io.server import DocHandler

    original_get_session = DocHandler.get_session
    original_write = DocHandler.write

    async def get_session(self):
        return await session_after_head(self, original_get_session, original_write)

    def write(self, chunk):
        if isinstance(chunk, str) and chunk.lstrip().lower().startswith("<!doctype html"):
            _note(self.request.path, chunk)
            sent = self.__dict__.pop("_camsim_head_sent", None)
            if sent is not None:
                chunk = rest_of(chunk, sent)
                if chunk is REFRESH:
                    _steady[self.request.path] = False
                    _log.warning("a page for %s did not begin as its head sent first; the browser asks again",
                                 self.request.path)
        return original_write(self, chunk)

    get_session.original = original_get_session
    write.original = original_write
    DocHandler.get_session = get_session
    DocHandler.write = write
    _installed.append((original_get_session, original_write))
    return True


async def session_after_head(handler, get_session, write):
    """``await get_session(handler)``, the head of the page sent first when its path is steady; a failure then
    finishes the answer with :data:`FAILED` (and is raised: Tornado logs it)."""
    sent = _send_head(handler, write)
    try:
        session = await get_session(handler)
    except BaseException:
        if sent is not None and not handler._finished:
            handler.finish(FAILED)  # the browser shows a line instead of a head alone
        raise
    if sent is not None:
        handler._camsim_head_sent = sent
    return session


def _send_head(handler, write):
    """Write and flush the head of ``handler``'s path when the path is steady; what was sent, or None."""
    path = handler.request.path
    head = _heads.get(path)
    if head is None or not _steady.get(path) or handler.request.method != "GET" or _login_required():
        return None
    handler.set_header("Content-Type", "text/html")
    handler.set_header("Server-Timing", 'session;desc="built"')  # headers go now: what the spare hook says after
    write(handler, head)
    handler.flush()
    return head


def _login_required():
    """Panel checks a login in the page handler's ``get_session`` and may answer with a redirect instead."""
    from panel.config import config

    return bool(getattr(config, "oauth_provider", None) or getattr(config, "basic_auth", None))
