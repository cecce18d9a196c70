"""Pages built in a thread of their own, not on the server's event loop.

Bokeh builds a visitor's document (the explorer's ``create_app``, then
Panel's models of it) inside the event loop's coroutine that makes the
session: about 1-1.4 s in which no other page gets an answer (the server's
loop watch logged a stall of that length for each of 12 pages opened in a
load test, and the same for each spare page). Here the build runs in one
builder thread, one page at a time, while the loop goes on serving every
other page; the session itself is then made on the loop, as Bokeh makes it.
The build is Python, so it shares the interpreter: at the server's GIL
switch interval (``camsim_explorer.serve.GIL_SWITCH_S``) the loop gets it
back within a fraction of a millisecond whenever it has work.

Private Bokeh and Panel internals, in this one module:
``ApplicationContext.create_session_if_needed`` is replaced by a version that
differs from Bokeh's only in where ``initialize_document`` runs, and Panel's
claim of the document for the building thread (``state._thread_id_``) is
handed to the loop's thread once the build is done. The replacement is
installed only when Bokeh's method is the one it was written against (its
source's digest, :data:`BOKEH_SOURCE_SHA256`); otherwise the server logs a
warning and builds on the loop as before, and ``tests/app/test_build_off_loop.py``
and ``tests/app/test_compat.py`` fail, so an upgrade of Bokeh cannot switch it off unnoticed.

Written by hand: neither Bokeh nor Panel offers to build documents off the
event loop (Panel's ``--num-threads`` runs callbacks in threads, not builds).
"""

from __future__ import annotations

import asyncio
import contextvars
import hashlib
import inspect
import logging
import os
import threading
import time
import weakref
from concurrent.futures import ThreadPoolExecutor

from camsim_core._parallel import BACKGROUND_NICE

__all__ = ["install", "BOKEH_SOURCE_SHA256", "installed", "matches_bokeh", "run_in_builder", "SPECULATIVE"]

#: Digest of Bokeh 3.9's ``ApplicationContext.create_session_if_needed`` (sha256 of its source, first 16 hex).
BOKEH_SOURCE_SHA256 = "047e758c152be0f6"

_log = logging.getLogger("camsim.serve")
_installed = []
#: True while the current task builds a spare page (``camsim_explorer.compat.spare_session``): built at background priority.
SPECULATIVE = contextvars.ContextVar("camsim_speculative_build", default=False)


def _nice(level):
    def lower():
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), level)
        except (AttributeError, OSError):  # not Linux: the build still leaves the loop free
            pass
    return lower


#: A visitor's page is built in this thread, at the priority of the loop (the visitor waits for it); a page
#: built in advance, for whoever comes next, in the other, at a sweep's priority (nobody waits for it yet).
_builder = ThreadPoolExecutor(1, thread_name_prefix="camsim-build")
_speculative_builder = ThreadPoolExecutor(1, thread_name_prefix="camsim-build-ahead",
                                          initializer=_nice(BACKGROUND_NICE))


def run_in_builder(fn, *args):
    """``fn(*args)`` in the builder thread (the speculative one inside :data:`SPECULATIVE`); an awaitable."""
    pool = _speculative_builder if SPECULATIVE.get() else _builder
    return asyncio.get_running_loop().run_in_executor(pool, fn, *args)


def _digest(fn):
    return hashlib.sha256(inspect.getsource(fn).encode()).hexdigest()[:16]


def matches_bokeh():
    """True when Bokeh's session maker is the one :func:`install` was written against (or already replaced)."""
    from bokeh.server import contexts

    return bool(_installed) or _digest(contexts.ApplicationContext.create_session_if_needed) == BOKEH_SOURCE_SHA256


def installed():
    """True once :func:`install` has replaced Bokeh's session maker."""
    return bool(_installed)


#: One page built at a time, in either builder thread. Panel is not thread-safe while a document is built:
#: ``param.edit_readonly`` lifts the read-only flag of the class's shared parameters for the time of an
#: update, so two builds at once (a visitor's and a spare's) could find ``Location.hostname`` read-only
#: again half-way ("Read-only parameter 'hostname' cannot be modified": the page never came, seen
#: under load). The builds share one interpreter, so running them one after the other costs little.
_BUILD_LOCK = threading.Lock()


def _initialize(application, doc):
    """Build ``doc`` (in a builder thread, one build at a time); the log says where and how long."""
    with _BUILD_LOCK:
        t0, cpu0 = time.perf_counter(), time.thread_time()
        application.initialize_document(doc)
    # the thread's own CPU time beside the wall time: the rest is waiting (for the interpreter, for a core)
    _log.info("a page built in %.0f ms (%.0f ms of its thread's CPU) in thread %s",
              1000 * (time.perf_counter() - t0), 1000 * (time.thread_time() - cpu0), threading.current_thread().name)


def install():
    """Build every page's document in the builder thread from now on; True when installed."""
    if _installed:
        return True
    from bokeh.document import Document
    from bokeh.protocol.exceptions import ProtocolError
    from bokeh.server import contexts
    from bokeh.server.session import ServerSession
    from bokeh.util.token import get_token_payload
    from panel.io.state import state as panel_state
    from tornado import gen

    original = contexts.ApplicationContext.create_session_if_needed
    found = _digest(original)
    if found != BOKEH_SOURCE_SHA256:
        _log.warning("Bokeh's ApplicationContext.create_session_if_needed is not the one camsim knows (digest %s, "
                     "expected %s): pages are built on the event loop", found, BOKEH_SOURCE_SHA256)
        return False

    async def create_session_if_needed(self, session_id, request=None, token=None):
        if len(session_id) == 0:
            raise ProtocolError("Session ID must not be empty")
        if session_id not in self._sessions and session_id not in self._pending_sessions:
            future = self._pending_sessions[session_id] = gen.Future()
            doc = Document()
            session_context = contexts.BokehSessionContext(session_id, self.server_context, doc,
                                                           logout_url=self._logout_url)
            if request is not None:
                payload = get_token_payload(token) if token else {}
                if "cookies" in payload and "headers" in payload and "Cookie" not in payload["headers"]:
                    payload["headers"]["Cookie"] = "; ".join(f"{k}={v}" for k, v in payload["cookies"].items())
                session_context._request = contexts._RequestProxy(request, arguments=payload.get("arguments"),
                                                                  cookies=payload.get("cookies"),
                                                                  headers=payload.get("headers"))
            session_context._token = token
            doc._session_context = weakref.ref(session_context)
            try:
                await self._application.on_session_created(session_context)
            except Exception as e:
                contexts.log.error("Failed to run session creation hooks %r", e, exc_info=True)
            try:  # the one change: the build runs in the builder thread while the loop serves the others
                await run_in_builder(_initialize, self._application, doc)
            except BaseException as exc:
                del self._pending_sessions[session_id]
                future.set_exception(exc)
                future.exception()  # retrieved: a request waiting on it gets it, none is logged as lost
                raise
            panel_state._thread_id_[doc] = threading.get_ident()  # the document is the loop's from now on
            session = ServerSession(session_id, doc, io_loop=self._loop, token=token)
            del self._pending_sessions[session_id]
            self._sessions[session_id] = session
            session_context._set_session(session)
            self._session_contexts[session_id] = session_context
            future.set_result(session)
        if session_id in self._pending_sessions:
            return await self._pending_sessions[session_id]
        return self._sessions[session_id]

    create_session_if_needed.original = original
    contexts.ApplicationContext.create_session_if_needed = create_session_if_needed
    _installed.append(original)
    return True
