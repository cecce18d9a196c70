"""The explorer's smaller uses of Panel and Bokeh internals, each in one function here.

Each was measured or seen to matter (the reason is in its docstring). Each
checks that the internal it uses is still there and, when it is not, returns
False (or None) and the explorer falls back to Panel's own behaviour; the
fallback is logged once by :func:`camsim_explorer.compat.apply`, and
``tests/app/test_compat.py`` fails on a Panel or Bokeh in which any of them
no longer applies.

Written by hand: Panel offers none of these as settings.
"""

from __future__ import annotations

import logging

__all__ = ["served_without_cdn", "pages_without_mathjax", "link_values_kept_as_text", "forget_js_links", "flush_stranded_writes",
           "connected_at_pull", "pages_get_every_change",
           "undelay", "DataURIFavicon", "address_writer", "tornado_app", "HOOKS"]

_log = logging.getLogger("camsim.explorer")


def pages_without_mathjax():
    """Pages load without Bokeh's MathJax bundle (1.8 MB of script to fetch and compile on every first
    visit). Panel adds it whenever a page holds an HTML or Markdown pane, in case one shows TeX; no text of
    the explorer does (its panes run with TeX off), so nothing is lost. True when applied."""
    import panel.io.resources as resources

    if not hasattr(resources, "_panel_use_mathjax"):
        return False
    if getattr(resources._panel_use_mathjax, "camsim", False):
        return True

    def no_mathjax(roots):
        return False

    no_mathjax.camsim = True
    resources._panel_use_mathjax = no_mathjax
    return True


def link_values_kept_as_text():
    """A link's value Panel cannot convert is kept as text, not an HTTP 500. True when applied.

    Panel reads the address's values with ``panel.util.parse_query``, which
    turns a value of digits into an int: one of more than 4,300 digits raised
    ValueError (Python's limit on ``int()`` of a text) while the page was being
    made, and the server answered HTTP 500 with a traceback in its log. Kept as
    text, the value reaches the explorer's own checks: the page says the link's
    value is too long or refused.
    """
    import panel.io.location as location

    parse = getattr(location, "parse_query", None)
    if parse is None:
        return False
    if getattr(parse, "camsim", False):
        return True
    from urllib.parse import parse_qsl, urlencode

    def parse_query(query):
        try:
            return parse(query)
        except Exception:  # any value Panel's parser chokes on: parsed one by one below
            pass
        values = {}
        for key, value in dict(parse_qsl(str(query)[1:])).items():
            try:
                values.update(parse("?" + urlencode({key: value})))
            except Exception:
                values[key] = value
        return values

    parse_query.camsim = True
    location.parse_query = parse_query
    return True


def forget_js_links(roots):
    """Drop the browser-side links of a closed session's widgets from Panel's registry.

    ``panel.links.Callback.registry`` is a weak-keyed dict whose values (the
    links) hold their source widget strongly, so an entry never goes away by
    itself: it kept every closed session's widgets, state and arrays alive.
    Returns the number of entries dropped, or None when Panel has no such registry.
    """
    from panel.links import Callback

    registry = getattr(Callback, "registry", None)
    if registry is None:
        return None
    mine = set()
    for root in roots:
        for obj in root.select() if hasattr(root, "select") else []:
            mine.add(id(obj))
    dropped = 0
    for key in list(registry.keys()):
        if id(key) in mine:
            registry.pop(key, None)
            dropped += 1
    return dropped


def _write_queue():
    """Panel's per-document queue of unsent messages, its write block and its dispatcher, or None."""
    from panel.io import document as pdoc

    parts = (getattr(pdoc, "_WRITE_MSGS", None), getattr(pdoc, "_WRITE_BLOCK", None),
             getattr(pdoc, "_dispatch_write_task", None), getattr(pdoc, "_dispatch_msgs", None))
    return None if any(p is None for p in parts) else parts


def flush_stranded_writes(doc):
    """Send changes Panel queued for the browser and then forgot; True when there were some.

    Panel (1.9) queues the changes made while a websocket write is under way
    (``_WRITE_MSGS``) and schedules a task that sends them while the write
    block (``_WRITE_BLOCK``) is set. An earlier such task that finishes in
    between clears the block, and the new task then returns without sending:
    the page keeps its previous result although the session has the new one,
    until some later change happens to send them along (seen as a "lost
    update" in long browser walks and under load). Each session runs this
    check periodically: it re-arms the block and the task for queued messages
    that no task will send.
    """
    queue = _write_queue()
    if queue is None:  # another Panel: nothing known to flush (logged by compat.apply)
        return False
    msgs, block, dispatch, send = queue
    if msgs.get(doc) and doc not in block:
        block[doc] = True
        dispatch(doc, send, doc)
        _log.info("re-sent %d stranded message group(s)", len(msgs[doc]))
        return True
    return False


def _pull_and_connected():
    """Bokeh's pull handler (a classmethod), Panel's connected sessions and its dispatch of the events it kept
    for the connection, or None."""
    import importlib

    from bokeh.server.session import ServerSession

    pull = ServerSession.__dict__.get("pull")
    connected = getattr(importlib.import_module("panel.io.state").state, "_connected", None)
    dispatch = getattr(importlib.import_module("panel.io.document"), "_dispatch_unconnected_events", None)
    if not isinstance(pull, classmethod) or not hasattr(connected, "get") or dispatch is None:
        return None
    return pull, connected, dispatch


def connected_at_pull():
    """A page's session counts as connected (for Panel) once its browser has pulled the document, not only
    once the page reports itself ready. True when applied.

    Panel drops the changes made in a hold while a session is not connected
    (``panel.io.document.hold``: "the Document is serialized in full once the
    session connects"), and it marks a session connected when the page
    reports "document ready". Between the browser's pull of the document and
    that report the page is already on the screen (it reports once every view
    has drawn), and every change a click made there was dropped: the pull
    that would have carried it had gone. A tab opened in that moment stayed
    empty for good. Marked connected as soon as the pull's reply is made
    (the document serialized), the changes after it go to the page as
    patches, written after the reply on the same websocket.
    """
    from bokeh.server.session import ServerSession

    parts = _pull_and_connected()
    if parts is None:
        return False
    pull, connected, dispatch = parts
    if pages_get_every_change():
        return True
    bokehs = pull.__func__

    async def pull_then_connected(cls, message, connection):
        reply = await bokehs(cls, message, connection)
        doc = getattr(connection.session, "document", None)
        if reply is not None and doc is not None and not connected.get(doc):
            connected[doc] = True
            dispatch(doc)  # what Panel kept for the connection (custom messages), on the next tick
        return reply

    pull_then_connected.camsim = True
    pull_then_connected.original = bokehs
    ServerSession.pull = classmethod(pull_then_connected)
    return True


def pages_get_every_change():
    """True when :func:`connected_at_pull` is in place: a change made in a session then reaches its page
    whenever it is made (before the page's pull, in the pull; after it, as a patch), and nothing needs to wait
    for the page's "document ready" report."""
    from bokeh.server.session import ServerSession

    pull = ServerSession.__dict__.get("pull")
    return isinstance(pull, classmethod) and getattr(pull.__func__, "camsim", False)  # connected_at_pull's mark


def undelay(widget):
    """The widget's changes reach the server at once: Panel holds each change from the browser for 50 ms
    (to gather a burst into one) before acting on it. A burst costs nothing here (a newer change supersedes
    the computation of an older one), and 50 ms is a third of the time a slider has to answer.
    True when applied."""
    if not hasattr(widget, "_debounce"):
        return False
    widget._debounce = 0
    return True


class DataURIFavicon:
    """A template mixin: Panel knows a page icon's type by its file name's ending; the explorer's icon is a
    data URI, whose type it states itself."""

    @staticmethod
    def _get_favicon_type(favicon):
        import panel as pn

        if str(favicon).startswith("data:"):
            return str(favicon)[5:].split(";", 1)[0].split(",", 1)[0]
        return pn.template.BootstrapTemplate._get_favicon_type(favicon)


def address_writer(location, state):
    """Take over the writing of ``state``'s synced parameters into the page's address.

    After ``location.sync(state, ...)``, Panel writes every change into the
    address at once. This removes Panel's watcher and returns Panel's own
    writer, ``write(query)`` (it marks the address as written by the page, so
    that the change does not come back as a navigation), for the caller to
    call when it chooses; or None when this Panel keeps its writing to itself
    (the address is then written by Panel at every change, as before).
    """
    entry = next((e for e in getattr(location, "_synced", ()) if e[0] is state), None)
    update = getattr(location, "_update_query", None)
    if entry is None or not callable(update):
        return None
    state.param.unwatch(entry[2])
    return lambda query: update(query=query)


def served_without_cdn():
    """Panel's choice between its CDN and this server for the files a page loads is always this server.

    Panel asks ``panel.io.resources.use_cdn()`` each time a component's stylesheets are made (its
    loading spinner's CSS, a design's files); it reads Bokeh's process-wide resource mode, which
    :func:`panel.io.resources.set_resource_mode` changes for the duration of a rendering. Twice, under
    load, a page of the compare tab loaded 182 stylesheets from cdn.holoviz.org (refused by the page's
    Content-Security-Policy, and unreachable without the internet); the mode was pinned to ``server``
    (``camsim_explorer.serve.serve_resources_locally``) and it happened again. For ``camsim serve`` the
    answer is always "this server".

    A second path led there too (a third time, 219 stylesheets, in a sweep's plot): Panel points a
    component's stylesheets at the page's ``dist_url`` (``panel.io.resources.patch_stylesheet``), and at
    the CDN when the document has none yet, as a page's document has while it is built (before Panel writes
    the page) or a model made for no document. ``patch_stylesheet`` is wrapped so that a CDN target is this
    server's path. True when applied. Not applied in a notebook, which may use the CDN.
    """
    import panel.io.resources as resources
    import panel.reactive as reactive
    import panel.template.base as template

    original = getattr(resources, "use_cdn", None)
    patch = getattr(resources, "patch_stylesheet", None)
    if getattr(original, "camsim", False):
        return True
    if original is None or patch is None or not hasattr(template, "use_cdn") \
            or getattr(reactive, "patch_stylesheet", None) is not patch:
        return False

    def use_cdn():
        return False

    def patch_stylesheet(stylesheet, dist_url):
        if dist_url == resources.CDN_DIST:  # no page's address known: this server's, as Panel's own server gives
            from panel.io.state import state

            dist_url = f"{state.rel_path}/{resources.LOCAL_DIST}" if state.rel_path else resources.LOCAL_DIST
        return patch(stylesheet, dist_url)

    use_cdn.camsim = patch_stylesheet.camsim = True
    use_cdn.original, patch_stylesheet.original = original, patch
    resources.use_cdn = template.use_cdn = use_cdn
    resources.patch_stylesheet = reactive.patch_stylesheet = patch_stylesheet
    return True


def tornado_app(server):
    """The Tornado application of a Bokeh server made by ``pn.serve(..., start=False)``, or None."""
    return getattr(server, "_tornado", None)


def _has(module, *path):
    import importlib

    obj = importlib.import_module(module)
    for name in path:
        if not hasattr(obj, name):
            return False
        obj = getattr(obj, name)
    return True


#: Each hook and the Panel or Bokeh internals it needs: ``compat.status()`` checks that they are all there.
HOOKS = {
    "pages_without_mathjax": lambda: _has("panel.io.resources", "_panel_use_mathjax"),
    "link_values_kept_as_text": lambda: _has("panel.io.location", "parse_query"),
    "forget_js_links": lambda: _has("panel.links", "Callback", "registry"),
    "flush_stranded_writes": lambda: _write_queue() is not None,
    "connected_at_pull": lambda: _pull_and_connected() is not None,
    "undelay": lambda: _has("panel.widgets", "FloatSlider") and hasattr(__import__("panel").widgets.FloatSlider(), "_debounce"),
    "favicon_type": lambda: _has("panel.template", "BootstrapTemplate", "_get_favicon_type"),
    "plain_text": lambda: _has("panel.pane", "Str", "_transform_object"),
    "address_writer": lambda: _has("panel.io.location", "Location", "_update_query")
    and hasattr(__import__("panel").io.location.Location(), "_synced"),
    "served_without_cdn": lambda: _has("panel.io.resources", "use_cdn") and _has("panel.template.base", "use_cdn")
    and "use_cdn()" in __import__("inspect").getsource(__import__("panel").io.resources.get_dist_path)
    and _has("panel.io.resources", "patch_stylesheet") and _has("panel.reactive", "patch_stylesheet")
    and "patch_stylesheet(stylesheet, dist_url)" in __import__("inspect").getsource(__import__("panel").reactive.Reactive),
    "tornado_app": lambda: _has("bokeh.server.server", "Server") and "_tornado" in _init_names("bokeh.server.server", "BaseServer"),
}


def _init_names(module, cls):
    """Attribute names that ``cls.__init__`` assigns on self (read from its source)."""
    import importlib
    import inspect
    import re

    source = inspect.getsource(getattr(importlib.import_module(module), cls).__init__)
    return set(re.findall(r"self\.(\w+)\s*=", source))
