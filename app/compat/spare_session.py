"""The next visitor's page, built while the server is idle.

A browser asking for the explorer waits for its whole session to be built
before it gets the page's HTML: the explorer's state and views, then the
Bokeh models Panel makes of them (about 0.7 s of the server's event loop,
measured with cProfile: ``create_app`` 0.27 s, Panel's models 0.35-0.40 s).
Only then does it fetch the scripts (0.5-0.8 s), open the websocket and
pull the document, which the server serializes then (0.15-0.25 s with the
first result's images). Here the server keeps one session per page path
built in advance (a *spare*), its document serialized once its first result
is in: a request for the plain page (no query arguments) takes it, with a
fresh token made from that request, and its pull gets the serialized
document unless the document changed since. A build holds the event loop
~0.7 s, so the next spare is built only when every page served has
connected (a loading page's scripts and pull would wait behind it), no
session is computing and no page has sent a message for ``QUIET_S``: a user
busy with a page is not held up, and pages asked for back to back are built
as before. A change made just as a build starts waits for it (once per page
served, the build a visitor's request would otherwise have waited for).

A request with arguments (a shared link, a saved design) builds its own
session as before: its parameters are read while the session is built.

Written by hand: neither Bokeh nor Panel builds sessions ahead of requests.
Panel's ``reuse_sessions`` sends every visitor the HTML of the first session
built, whose root ids are not those of the visitor's own document; the
Bootstrap template then loses its styles (seen in screenshots).
"""

from __future__ import annotations

import logging
import time
import weakref

from . import build_off_loop as _build_off_loop

__all__ = ["install", "prepare_at_start", "note_messages", "idle_for", "busy", "SPARE_DELAY_S"]

#: Seconds after the last page served has connected (its scripts loaded, its document pulled) before a spare
#: is built: the page's first layout sends the server its sizes meanwhile.
SPARE_DELAY_S = 1.0
#: Seconds without a message from any page (a change, a zoom, a tab opened) before a spare is built: a build
#: holds the event loop ~0.7 s, and a user busy with a page should not wait behind it.
QUIET_S = 2.0
#: The longest wait for a served page to connect before a spare is built anyway (s).
CONNECT_WAIT_S = 10.0
#: How often the builder checks whether the server is idle (s).
POLL_S = 0.25

_log = logging.getLogger("camsim.explorer")
_installed = []
# path -> ServerSession ready to be handed out; path -> (application context, Bokeh's tornado app, request)
_spares: dict = {}
_sources: dict = {}
_scheduled: set = set()
_in_flight = weakref.WeakKeyDictionary()  # session served -> [served at, connected at] (monotonic s)
_last_message = [0.0]  # when a page last sent the server a message (monotonic s)


def busy():
    """A session computing a result: a build now would hold its result back on the event loop."""
    from .. import main

    return any(getattr(s, "computing", False) for s in main.live_states())


def _plain_request(request):
    """The request a spare is built for: the path and host of ``request``, no arguments, headers or cookies
    (a spare is handed to another visitor; the browser sends its own address once the page connects)."""
    from tornado.httputil import HTTPHeaders, HTTPServerRequest, RequestStartLine

    host = request.host or "127.0.0.1"
    plain = HTTPServerRequest(headers=HTTPHeaders({"Host": host}),
                              start_line=RequestStartLine("GET", request.path, "HTTP/1.1"))
    plain.protocol = getattr(request, "protocol", "http")
    return plain


def _token(tornado_app, session_id, payload):
    from bokeh.util.token import generate_jwt_token

    return generate_jwt_token(session_id, secret_key=tornado_app.secret_key, signed=tornado_app.sign_sessions,
                              expiration=tornado_app.session_token_expiration, extra_payload=payload)


async def _build(path):
    from bokeh.util.token import generate_session_id

    from .. import main

    context, tornado_app, request = _sources[path]
    session_id = generate_session_id(secret_key=tornado_app.secret_key, signed=tornado_app.sign_sessions)
    token = _token(tornado_app, session_id, {"headers": {}, "cookies": {}, "arguments": {}})
    t0 = time.perf_counter()
    before = set(main.live_states())
    speculative = _build_off_loop.SPECULATIVE.set(True)  # built at background priority when built off the loop
    try:
        session = await context.create_session_if_needed(session_id, request, token)
    finally:
        _build_off_loop.SPECULATIVE.reset(speculative)
    session.block_expiration()  # not reaped as an unused session while it waits
    _spares[path] = session
    _log.info("a spare page for %s built in %.0f ms", path, 1000 * (time.perf_counter() - t0))
    new = [s for s in main.live_states() if s not in before]
    if len(new) == 1:
        _serialize_when_settled(session, new[0], wanted=lambda: _spares.get(path) is session, speculative=True)


def _serialize_when_settled(session, state, wanted, speculative):
    """Once the page's first result is in its document and ``wanted()`` still holds: give its stylesheets the
    addresses Panel gives them when it writes the page, and serialize it for its first pull, off the event
    loop (at background priority when ``speculative``: a spare nobody waits for yet)."""
    from tornado.ioloop import IOLoop

    def check():
        if not wanted() or session.destroyed or session.connection_count > 0:
            return  # handed out, or connected, before it settled: its pull serializes as usual
        if state.computing:
            IOLoop.current().call_later(POLL_S / 5 if not speculative else POLL_S, check)
            return
        _page_stylesheets(session.document)
        IOLoop.current().add_callback(_serialize_for_pull, session, speculative)

    IOLoop.current().call_later(POLL_S / 5 if not speculative else POLL_S, check)


#: The longest a page's first pull waits for its first result before it is serialized anyway (s).
PULL_SETTLE_S = 10.0
#: Serializations off the event loop a first pull tries (the page changed during each) before Bokeh's own.
PULL_TRIES = 3


def serialize_built_page(session):
    """A page built for its request (a link with arguments, or no spare at hand): serialize its document off
    the event loop once its first result is in, for the pull its browser makes after loading the scripts
    (0.5-0.8 s later). Serialized on the loop, a page with its first images held every other page for
    150-250 ms (the server's loop watch, in the hostile load test).

    A pull that comes first (a class arriving at once: the first results queue for the cores) waits for the
    page's first result and has the document serialized off the loop then: 200-560 ms stalls per page
    connecting, in the hostile load test, were these pulls serialized on the loop."""
    from .. import main

    state = main.state_of(session.document)
    if state is None or not _build_off_loop.installed():
        return
    _serialize_when_settled(session, state, wanted=lambda: True, speculative=False)
    _pull_waits_for_the_first_result(session, state)


def _pull_waits_for_the_first_result(session, state):
    """Until a serialization made off the loop is ready for it, the page's first pull waits for the page's
    first result and serializes the document in the builder thread; Bokeh's own pull when that fails."""
    import asyncio

    bokehs = session._handle_pull
    doc = session.document

    async def pull_off_the_loop(message, connection):  # as Bokeh's: a coroutine
        if session.__dict__.get("_handle_pull") is pull_off_the_loop:
            del session._handle_pull  # later pulls: Bokeh's own
        deadline = time.monotonic() + PULL_SETTLE_S
        while state.computing and time.monotonic() < deadline:
            await asyncio.sleep(POLL_S / 5)
        for _ in range(PULL_TRIES):  # a page whose designs are computing changes as each comes: serialized again
            unchanged = _Unchanged(doc)
            try:
                serialized = await _build_off_loop.run_in_builder(doc.to_json)
            except Exception:  # changed under the serializer
                serialized = None
            finally:
                unchanged.stop()
            if serialized is not None and unchanged.holds():
                break
        if serialized is None or not unchanged.holds():
            _log.info("a page's pull came before its serialization and the page changed meanwhile: serialized "
                      "on the event loop")
            return await bokehs(message, connection)  # Bokeh's (a coroutine: it takes the document's lock)
        _log.info("a page's first pull came first and was answered with a serialization made off the event loop")
        return connection.protocol.create("PULL-DOC-REPLY", message.header["msgid"], _AsSerialized(serialized))

    session._handle_pull = pull_off_the_loop


def _page_stylesheets(doc):
    """What Panel does to the document's stylesheets when it writes a page (``server_html_page_for_session``):
    the package's CSS from this server, not from the CDN. Done for a spare before its serialization; Panel
    doing it again at hand-out changes nothing, and a stylesheet it does change makes the pull serialize anew."""
    from panel.io.resources import CDN_DIST, LOCAL_DIST, patch_model_css, use_cdn
    from panel.io.state import set_curdoc, state

    with set_curdoc(doc):
        dist_url = CDN_DIST if use_cdn() else (f"{state.rel_path}/{LOCAL_DIST}" if state.rel_path else LOCAL_DIST)
        for root in doc.roots:
            patch_model_css(root, dist_url=dist_url)


def _stylesheet_urls(doc):
    from bokeh.models import ImportedStyleSheet

    return {m.id: m.url for m in list(doc.models) if isinstance(m, ImportedStyleSheet)}


class _Unchanged:
    """Watches a document from now on: :meth:`holds` while it is as it was (no change event, no change held
    back, and the same stylesheet addresses, which Panel changes at hand-out without an event), so that a
    serialization made meanwhile still stands for it."""

    def __init__(self, doc):
        self.doc, self.urls, self.changed = doc, _stylesheet_urls(doc), False
        doc.on_change(self._on_change)

    def _on_change(self, event):
        self.changed = True

    def stop(self):
        self.doc.remove_on_change(self._on_change)

    def holds(self):
        return (not self.changed and getattr(self.doc.callbacks, "hold_value", None) is None
                and _stylesheet_urls(self.doc) == self.urls)


class _AsSerialized:
    """Stands for a document in Bokeh's ``PULL-DOC-REPLY`` message: its serialization made earlier."""

    def __init__(self, serialized):
        self._serialized = serialized

    def to_json(self):
        return self._serialized


async def _serialize_for_pull(session, speculative=True):
    """Serialize the session's document now (off the event loop when pages are built off it, at background
    priority when ``speculative``); its first pull replies with that if the document has not changed since
    the serialization began (and is not holding back changes), else Bokeh serializes it anew."""
    if session.destroyed or session.connection_count > 0:
        return
    doc = session.document
    unchanged = _Unchanged(doc)  # before the serialization starts: a change made meanwhile makes it stale
    try:
        if _build_off_loop.installed():
            _build_off_loop.SPECULATIVE.set(speculative)  # this task's own context (a spare: at low priority)
            serialized = await _build_off_loop.run_in_builder(doc.to_json)
        else:
            serialized = doc.to_json()
    except Exception:  # changed under the serializer: the pull serializes it as usual
        unchanged.stop()
        return
    if session.destroyed or session.connection_count > 0 or unchanged.changed:
        unchanged.stop()
        return
    _log.info("a page (%s) serialized off the event loop", "spare" if speculative else "built for its request")
    bokehs = session._handle_pull

    async def handle_pull(message, connection):  # as Bokeh's: a coroutine
        del session._handle_pull  # later pulls: Bokeh's own
        unchanged.stop()
        if not unchanged.holds():
            _log.info("a spare page changed after it was serialized: its pull serializes it anew")
            return await bokehs(message, connection)
        _log.info("a page's first pull answered with its serialization made off the event loop")
        return connection.protocol.create("PULL-DOC-REPLY", message.header["msgid"], _AsSerialized(serialized))

    session._handle_pull = handle_pull


def _loading():
    """A page served lately that has not connected, or connected less than ``SPARE_DELAY_S`` ago: its scripts,
    its pull and its first layout would wait behind a build on the event loop."""
    now = time.monotonic()
    for session, entry in list(_in_flight.items()):
        if session.connection_count > 0 and entry[1] is None:
            entry[1] = now
        done = entry[1] is not None and now - entry[1] >= SPARE_DELAY_S
        if session.destroyed or done or now - entry[0] > CONNECT_WAIT_S:
            _in_flight.pop(session, None)
    return bool(_in_flight)


def _schedule(path):
    """Build the next spare for ``path`` once no page is loading, no session is computing and no page has sent
    a message for ``QUIET_S``."""
    from tornado.ioloop import IOLoop

    if path in _scheduled or path in _spares or path not in _sources:
        return
    _scheduled.add(path)
    loop = IOLoop.current()

    def check():
        if _loading() or busy() or idle_for() < QUIET_S:
            loop.call_later(POLL_S, check)
            return
        loop.add_callback(run)

    async def run():
        try:
            await _build(path)
        except Exception:  # a spare is an optimization: the next request builds its own page
            _log.exception("building a spare page for %s failed", path)
        finally:
            _scheduled.discard(path)

    loop.call_later(SPARE_DELAY_S, check)


def _login_required():
    """Panel checks a login in the page handler's ``get_session``; a spare is then never handed out."""
    from panel.config import config

    return bool(getattr(config, "oauth_provider", None) or getattr(config, "basic_auth", None))


def _take(handler):
    """The spare for this request's path, with a token made from this request; None when there is none."""
    request = handler.request
    if request.arguments or "Bokeh-Session-Id" in request.headers or _login_required():
        return None
    session = _spares.pop(request.path, None)
    if session is None or session.destroyed:
        return None
    from bokeh.server.contexts import _RequestProxy

    payload = handler._generate_token_payload()
    token = _token(handler.application, session.id, payload)
    session._token = token
    context = session.document.session_context
    if context is not None:
        context._token = token
        context._request = _RequestProxy(request, arguments=payload.get("arguments"),
                                         cookies=payload.get("cookies"), headers=payload.get("headers"))
    session._last_unsubscribe_time = time.monotonic() * 1000  # an unused session lingers from now, as a new one
    session.unblock_expiration()
    return session


def install():
    """Make Panel's page handler hand out spares (once per process); True when it did."""
    if _installed:
        return True
    try:
        from panel.io.server import DocHandler
    except ImportError:
        return False
    original = getattr(DocHandler, "get_session", None)
    if original is None or not hasattr(DocHandler, "_generate_token_payload"):
        return False

    async def get_session(self):
        t0 = time.perf_counter()
        session = _take(self)
        how = "spare" if session is not None else "built"
        if session is None:
            session = await original(self)
            serialize_built_page(session)
        # the browser's developer tools (and the tests) see how the page's session came about
        self.set_header("Server-Timing", f'session;desc="{how}";dur={1000 * (time.perf_counter() - t0):.1f}')
        if not self.request.arguments and self.request.path not in _sources:
            _sources[self.request.path] = (self.application_context, self.application, _plain_request(self.request))
        _in_flight[session] = [time.monotonic(), None]  # served at; connected at
        _schedule(self.request.path)
        return session

    get_session.original = original
    DocHandler.get_session = get_session
    _installed.append(original)
    note_messages()
    return True


def idle_for():
    """Seconds since a page last sent the server a message (a change, a zoom, a tab opened); counted from the
    server's start until :func:`note_messages` sees the first."""
    return time.monotonic() - _last_message[0]


def note_messages():
    """Keep the time of the last message any page sent (Bokeh's websocket handler), for ``QUIET_S`` and
    :func:`idle_for`; once per process."""
    from bokeh.server.views.ws import WSHandler

    bokehs = getattr(WSHandler, "on_message", None)
    if bokehs is None or getattr(bokehs, "noted", False):
        return

    async def on_message(self, fragment):
        _last_message[0] = time.monotonic()
        return await bokehs(self, fragment)

    on_message.noted = True
    WSHandler.on_message = on_message


def prepare_at_start(host, path="/"):
    """Build the first spare as soon as the server runs (call before starting its event loop)."""
    from tornado.ioloop import IOLoop

    def first():
        import panel as pn

        for server, *_ in list(pn.state._servers.values()):
            tornado_app = getattr(server, "_tornado", None)
            context = getattr(tornado_app, "applications", {}).get(path) if tornado_app is not None else None
            if context is None:
                continue
            request = _plain_request(_Address(host, path))
            _sources.setdefault(path, (context, tornado_app, request))
            _schedule(path)
            return

    IOLoop.current().add_callback(first)


class _Address:
    """The parts of a request a spare is built from."""

    def __init__(self, host, path):
        self.host, self.path, self.protocol = host, path, "http"
