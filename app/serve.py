"""``camsim serve``: start the explorer (a Panel web app) on a local port.

This module is the explorer's (``camsim_explorer.serve``): the engine's
command line names the command and hands its arguments here when it runs
(:func:`camsim_core.cli.serve.main`), so the engine never imports Panel or
the explorer. Every bound a session is held to (upload size, zip members,
scene size, Gaussian sensors, tile size, text and JSON sizes, idle time) is
a flag here and listed in docs/serving.md (Limits).
"""

from __future__ import annotations

import logging
import os
import socket
import sys
import time

from camsim_core.errors import ParameterError

__all__ = ["register", "run", "WEBSOCKET_MAX_MESSAGE_BYTES"]

#: Largest websocket message the server accepts (Bokeh's default, set explicitly): uploads travel in 1 MiB pieces.
WEBSOCKET_MAX_MESSAGE_BYTES = 20 * 2**20
#: The server's GIL switch interval (s; CPython's default is 0.005). The event loop's callbacks give up the GIL
#: at every socket write, lock and numpy call, and each time wait for a computing thread to hand it back: at
#: 5 ms a wait, a result's 8 ms of Python took 50-220 ms on the loop while two sessions computed.
GIL_SWITCH_S = 0.0005


def _positive_int(text):
    try:
        v = int(text)
    except ValueError:
        raise ParameterError("limit", f"expected a whole number, got {text!r}") from None
    if v < 1:
        raise ParameterError("limit", f"must be at least 1, got {v}")
    return v


def _positive_float(text):
    try:
        v = float(text)
    except ValueError:
        raise ParameterError("limit", f"expected a number, got {text!r}") from None
    if not (v > 0 and v < float("inf")):
        raise ParameterError("limit", f"must be a positive number, got {text!r}")
    return v


#: Seconds between two pings to each page (Bokeh's own keep-alive period): proxies keep the page's websocket open.
KEEP_ALIVE_S = 37.0
#: The shortest ``--keep-alive``: more pings than one a second only cost the server and the pages.
MIN_KEEP_ALIVE_S = 1.0


def _keep_alive_seconds(text):
    import argparse

    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not (MIN_KEEP_ALIVE_S <= v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be at least {MIN_KEEP_ALIVE_S:g} s, got {text!r}")
    return v


def register(subparsers):
    from camsim_core.io.upload import UploadLimits

    up = UploadLimits()
    p = subparsers.add_parser("serve", help="start the explorer web app")
    p.add_argument("--port", type=int, default=5006, help="port to listen on (default 5006; 0 picks a free one)")
    p.add_argument("--address", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; 0.0.0.0 to serve a class or a review)")
    p.add_argument("--scene", default=None, help="scene sessions open on: a shipped name or a .Simg / .npz path")
    p.add_argument("--allow-websocket-origin", "--allow-origin", dest="allow_origin", action="append", default=[],
                   metavar="HOST[:PORT]", help="extra host:port allowed to open the websocket (repeatable)")
    p.add_argument("--show", action="store_true", help="open a browser tab")
    p.add_argument("--no-upload", action="store_true", help="offer no scene upload (for public demos)")
    p.add_argument("--no-spare-page", action="store_true",
                   help="build each page when it is asked for (by default the next page is built while the "
                        "server is idle, so that opening the explorer does not wait for it; it costs one "
                        "session's memory)")
    g = p.add_argument_group("limits")
    g.add_argument("--max-upload-mb", type=_positive_float, default=up.max_upload_bytes / 2**20,
                   help=f"largest uploaded file, MiB (default {up.max_upload_bytes / 2**20:g})")
    g.add_argument("--max-zip-members", type=_positive_int, default=up.max_members,
                   help=f"most members of an uploaded zip (default {up.max_members})")
    g.add_argument("--max-unzipped-mb", type=_positive_float, default=up.max_total_bytes / 2**20,
                   help=f"largest total uncompressed size of an uploaded zip, MiB (default {up.max_total_bytes / 2**20:g})")
    g.add_argument("--max-scene-values", type=_positive_int, default=up.max_scene_values,
                   help=f"most values (pixels x planes) of an uploaded scene (default {up.max_scene_values})")
    g.add_argument("--max-sensors", type=_positive_int, default=16, help="most Gaussian sensors (default 16)")
    g.add_argument("--max-tile", type=_positive_int, default=8, help="largest custom tile side (default 8)")
    g.add_argument("--max-text", type=_positive_int, default=256,
                   help="longest text field or URL value, characters (default 256)")
    g.add_argument("--max-json-kb", type=_positive_float, default=64, help="largest parameters JSON, KiB (default 64)")
    g.add_argument("--max-uploads", type=_positive_int, default=3, help="uploaded scenes a session keeps (default 3)")
    g.add_argument("--max-view-side", type=_positive_int, default=1280,
                   help="most pixels along a side of an image view sent to the browser; larger results are shown "
                   "averaged, and zooming in fetches detail (default 1280)")
    g.add_argument("--session-idle", type=_positive_float, default=60.0,
                   help="seconds after its last browser tab closes that a session is freed (default 60)")
    g.add_argument("--keep-alive", type=_keep_alive_seconds, default=KEEP_ALIVE_S,
                   help=f"seconds between two pings to each page (default {KEEP_ALIVE_S:g}): a proxy in between "
                        "keeps a quiet page's connection open")
    p.set_defaults(func=run)


def keep_alive_options(seconds):
    """The server options that ping each page every ``seconds``, with Tornado's websocket ping.

    Bokeh's own keep-alive is off (``keep_alive_milliseconds=0``): it lets go of a page's session as soon as a
    ping finds the page's websocket closing, before Bokeh's own handlers have seen the close, so the page's
    changes still being handled, and then the close itself, each met a connection without a session and put a
    traceback in the server's log (40 pages closed mid-change in 40 s: 28 tracebacks in one run, none in the
    next, as a ping every 37 s lands in the gap or not; 598 with a ping every 50 ms). Tornado's ping
    (``websocket_ping_interval``) only writes: a closing page goes through Bokeh's close handler as a closed tab
    does. No answer is awaited (``websocket_ping_timeout=0``), as with Bokeh's: a laptop shut for a few minutes
    finds its page again, and a page gone for good is closed when the system gives up sending it the pings.

    Parameters
    ----------
    seconds : float
        Seconds between two pings (``--keep-alive`` takes at least :data:`MIN_KEEP_ALIVE_S`).

    Returns
    -------
    dict
        Keyword arguments for ``panel.serve`` (Bokeh passes the two ``websocket_*`` ones to Tornado).

    References
    ----------
    RFC 6455, The WebSocket Protocol, sections 5.5.2-5.5.3 (Ping and Pong). Tornado's
    ``WebSocketHandler.ping_interval`` and ``ping_timeout``. Bokeh issue 13654 and pull request 13655 (a failed
    keep-alive ping lets go of the client).

    Examples
    --------
    >>> keep_alive_options(37)
    {'keep_alive_milliseconds': 0, 'websocket_ping_interval': 37.0, 'websocket_ping_timeout': 0}
    """
    return {"keep_alive_milliseconds": 0, "websocket_ping_interval": float(seconds), "websocket_ping_timeout": 0}


def limits_from(args):
    """The server's :class:`camsim_explorer.state.ServerLimits` from the parsed flags."""
    from camsim_core.io.upload import UploadLimits

    from .state import ServerLimits

    up = UploadLimits()
    total = int(args.max_unzipped_mb * 2**20)
    upload = UploadLimits(
        max_upload_bytes=int(args.max_upload_mb * 2**20),
        max_members=args.max_zip_members,
        max_member_bytes=min(up.max_member_bytes, total),
        max_total_bytes=total,
        max_scene_values=args.max_scene_values,
    )
    return ServerLimits(upload=upload, max_sensors=args.max_sensors, max_tile=args.max_tile, max_text=args.max_text,
                        max_json_bytes=int(args.max_json_kb * 1024), max_uploads=args.max_uploads,
                        max_view_side=args.max_view_side)


def _lan_address():
    """This machine's address on its network (no packet is sent), or its host name."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))
            return s.getsockname()[0]
    except OSError:
        return socket.gethostname()


def public_host(address):
    """The host the printed URL names: ``localhost`` locally, the machine's address for 0.0.0.0."""
    if address in ("127.0.0.1", "localhost", "::1"):
        return "localhost"
    if address in ("0.0.0.0", "", "::"):
        return _lan_address()
    return address


def _url_host(host):
    """``host`` as a URL writes it: an IPv6 address in brackets."""
    return f"[{host}]" if ":" in host and not host.startswith("[") else host


def allowed_origins(address, port, extra=()):
    """Hosts (``HOST:PORT``) the server answers and websocket origins it accepts: the printed URL's host and
    the loopback names (``localhost``, ``127.0.0.1``, ``[::1]``), plus ``extra``; never ``*``.

    The same list serves both checks: the websocket's ``Origin`` (Bokeh's) and every request's ``Host``
    header (:func:`refuse_other_hosts`).
    """
    hosts = {"localhost", "127.0.0.1", "[::1]", _url_host(public_host(address))}
    if address not in ("0.0.0.0", "", "::"):
        hosts.add(_url_host(address))
    origins = {f"{h}:{port}" for h in hosts}
    for e in extra:
        e = str(e).strip()
        if not e or "*" in e:
            raise ParameterError("--allow-websocket-origin", f"expected HOST or HOST:PORT without wildcards, got {e!r}")
        origins.add(e if ":" in e else f"{e}:{port}")
    return sorted(origins)


#: The answer to a request naming another host (see :func:`refuse_other_hosts`).
OTHER_HOST_MESSAGE = ("403: this server answers only to its own address; a page reached under another name (DNS "
                      "rebinding) gets nothing. camsim serve --allow-websocket-origin HOST[:PORT] adds a name.\n")


def host_allowed(host, allowed):
    """Whether a request's ``Host`` header (``HOST[:PORT]``; no port means 80) is one of ``allowed``."""
    from bokeh.server.util import check_allowlist

    host = str(host or "").strip().lower()
    return bool(host) and check_allowlist(host, [a.lower() for a in allowed])


def refuse_other_hosts(tornado_app, allowed):
    """Answer 403 (a plain text) to every request whose ``Host`` is not in ``allowed``: the page, the
    websocket, the static files, every route of ``tornado_app`` (the server's Tornado application).

    A page of another site whose name is made to point at this machine (DNS rebinding) is, to the
    browser, of that site: its requests name that site in ``Host``, and for the websocket in ``Origin``
    too, which Tornado accepts when it equals the ``Host``. Checked first, before any handler runs (a
    refused request makes no session).
    """
    from tornado.routing import Matcher, Rule
    from tornado.web import RequestHandler

    class OtherHost(Matcher):
        def match(self, request):
            return None if host_allowed(request.host, allowed) else {}

    class Refuse(RequestHandler):
        def prepare(self):
            self.set_status(403)
            self.set_header("Content-Type", "text/plain; charset=utf-8")
            self.finish(OTHER_HOST_MESSAGE)

    tornado_app.default_router.rules.insert(0, Rule(OtherHost(), Refuse))


def _return_freed_memory_to_the_system():
    """Let a closed session's memory go back to the operating system (glibc only; elsewhere a no-op).

    Each session computes in threads of its own, and glibc gives threads heaps
    (arenas) of their own whose freed pages it seldom returns: a server kept
    hundreds of MB after its sessions closed. Two arenas at most, and a trim
    of every heap after a session is released (``camsim_explorer.main.AFTER_RELEASE``),
    again after a full collection once the closes stop
    (:func:`_collect_and_trim_once_quiet`).
    A fixed mmap threshold would return memory too, but doubled the engine's
    time per change (every large temporary array mapped and unmapped).
    """
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-8, 2)  # M_ARENA_MAX
        return libc
    except (OSError, AttributeError):
        return None


def _freeze_startup_objects():
    """Leave the objects made at start (modules, classes, the shipped data, the warm-up's session) out of
    every later garbage collection: the collector walks every object it tracks, ~0.5 million of them
    here, most of them never garbage. Collected first, so nothing frozen is garbage."""
    import gc

    gc.collect()
    gc.freeze()


#: Seconds without a session released before the collection and trim of :func:`_collect_and_trim_once_quiet`.
QUIET_S = 2.0


def _collect_and_trim_once_quiet(libc, quiet_s=None):
    """A release hook: once no session has been released for ``QUIET_S`` seconds, one full garbage
    collection and a heap trim.

    Part of a closed session sits in reference cycles (Panel's one-shot callbacks) that only a full
    collection frees, which Python runs rarely: the trim at release time came before those arrays were
    freed, and their pages stayed with the process (the 10-session load test: +87-101 MB after all
    closed, +34-47 MB with this). A full collection pauses the event loop (30 ms after one session,
    250 ms after eleven: 273,000 objects, measured with the startup objects frozen), a pause Python's
    own collector would take anyway when it gets round to those cycles; here it comes once after a
    burst of closes, not per close.
    """
    import gc

    from tornado.ioloop import IOLoop

    pending = []

    def collect_and_trim():
        pending.clear()
        t0 = time.perf_counter()
        freed = gc.collect()
        if libc is not None:
            libc.malloc_trim(0)
        logging.getLogger("camsim.explorer").info("after closed sessions: %d objects collected, heaps trimmed, in %.0f ms",
                                                  freed, 1000 * (time.perf_counter() - t0))

    def schedule():
        loop = IOLoop.current()
        for handle in pending:
            loop.remove_timeout(handle)
        pending[:] = [loop.call_later(QUIET_S if quiet_s is None else quiet_s, collect_and_trim)]

    return schedule


def _full_collections_when_quiet(io_loop):
    """Python's own full garbage collections off; one when the pages are quiet instead (``app/collector.py``),
    looked for every second on the event loop."""
    from tornado.ioloop import PeriodicCallback

    from .collector import QuietCollector
    from .compat import spare_session

    spare_session.note_messages()  # the time of the pages' last message, with or without spare pages
    collector = QuietCollector(idle_for=spare_session.idle_for, busy=spare_session.busy)
    collector.start()
    io_loop.add_callback(lambda: PeriodicCallback(collector.check, 1000).start())  # on the server's loop
    return collector


def _log_to_stderr():
    """The server's own notes (``camsim.*`` loggers at INFO: spare pages built, memory returned after closed
    sessions, stranded changes re-sent) on stderr, one line each; without a handler Python drops them."""
    logger = logging.getLogger("camsim")
    if not any(getattr(h, "camsim", False) for h in logger.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("%(asctime)s %(name)s: %(message)s", "%H:%M:%S"))
        handler.camsim = True
        logger.addHandler(handler)
    logger.setLevel(logging.INFO)


def closed_page_exception_handler(loop, context):
    """asyncio's handler for exceptions nobody retrieved, in ``camsim serve``.

    A message written to a page's websocket after the page closed raises in a
    task nobody awaits; asyncio's default handler then prints "Task exception
    was never retrieved" and a traceback for what is a tab closing mid-update.
    Those are logged as one line; every other exception goes to the default
    handler.
    """
    from tornado.iostream import StreamClosedError
    from tornado.websocket import WebSocketClosedError

    if isinstance(context.get("exception"), (WebSocketClosedError, StreamClosedError)):
        logging.getLogger("camsim.explorer").info("a message to a closed page was dropped")
        return
    loop.default_exception_handler(context)


def serving_loop():
    """The event loop ``camsim serve`` runs on, made before anything asks Tornado for one: its turns are timed
    (:func:`~camsim_explorer.loop_watch.watched_event_loop`) and a write to a closed page is one log line
    (:func:`closed_page_exception_handler`). Set as the current loop by :func:`run`.

    Examples
    --------
    >>> loop = serving_loop()
    >>> loop.get_exception_handler() is closed_page_exception_handler
    True
    >>> loop.close()
    """
    from .loop_watch import watched_event_loop

    loop = watched_event_loop()
    loop.set_exception_handler(closed_page_exception_handler)
    return loop


def stop_on_terminate(loop):
    """Stop ``loop`` on SIGTERM as on Ctrl-C (Panel stops the loop on SIGINT), so that a server stopped by a
    service manager (``systemctl stop``, ``docker stop``, ``kill``) exits with status 0 and Python's exit
    handlers run: the upload readers' fork server removes its folder in the temporary directory. Killed
    by SIGTERM's default action, every stop left that folder behind (about 600 of them in ``/tmp`` after a
    day of test runs).

    Examples
    --------
    >>> import asyncio, os, signal
    >>> loop = asyncio.new_event_loop()
    >>> stop_on_terminate(loop)
    >>> _ = loop.call_soon(os.kill, os.getpid(), signal.SIGTERM)
    >>> loop.run_forever()  # returns: the signal stopped it
    >>> loop.remove_signal_handler(signal.SIGTERM)
    True
    >>> loop.close()
    """
    import signal

    def stop():
        logging.getLogger("camsim.serve").info("SIGTERM: stopping")
        loop.stop()

    loop.add_signal_handler(signal.SIGTERM, stop)


def _let_go_of_queued_work():
    """Cancel the sessions' work still queued once the server stops: exit waits for what runs now only (a
    sweep's queued points would otherwise all run first)."""
    from .state import SESSION_THREADS, UPLOAD_THREADS

    for pool in (SESSION_THREADS, UPLOAD_THREADS):
        pool.shutdown(wait=False, cancel_futures=True)


def serve_resources_locally():
    """Every page takes Bokeh's and Panel's scripts and stylesheets from this server, never from a CDN.

    Bokeh and Panel read the resource mode from one process-wide setting (``BOKEH_RESOURCES`` or a value
    set in the process); a ``cdn`` there, inherited from the environment or left by a notebook rendering,
    made a page load its stylesheets from cdn.holoviz.org (seen once in a browser test): a classroom
    without the internet got an unstyled page. The setting's own value is pinned to ``server`` (Panel's
    temporary changes restore it), and so is the environment's, for the upload readers' workers.
    """
    from bokeh.settings import settings

    os.environ["BOKEH_RESOURCES"] = "server"
    settings.resources.set_value("server")


def run(args):
    from camsim_core import load_scene

    if not 0 <= args.port <= 65535:
        raise ParameterError("--port", f"must be 0..65535, got {args.port}")
    if args.port == 0:
        with socket.socket() as s:
            s.bind((args.address if args.address not in ("0.0.0.0", "") else "", 0))
            args.port = s.getsockname()[1]
    scene = None
    if args.scene:
        scene = load_scene(args.scene)  # validate now: a clear error, not a broken page
        scene = args.scene if str(args.scene).lower() == scene.name else scene
    import asyncio

    # the loop the server runs on, before anything asks Tornado for one (a handler installed through
    # IOLoop.current() before this went to a loop that never ran: closed pages' writes logged tracebacks)
    loop = serving_loop()
    asyncio.set_event_loop(loop)
    stop_on_terminate(loop)  # from now: a SIGTERM during the start stops the loop as soon as it runs
    _log_to_stderr()
    serve_resources_locally()
    libc = _return_freed_memory_to_the_system()
    import panel as pn

    from . import main

    if libc is not None:
        main.AFTER_RELEASE.append(lambda: libc.malloc_trim(0))
    main.AFTER_RELEASE.append(_collect_and_trim_once_quiet(libc))

    limits = limits_from(args)
    main.configure(scene, limits=limits, upload=not args.no_upload)
    origins = allowed_origins(args.address, args.port, args.allow_origin)
    idle_ms = int(args.session_idle * 1000)
    main.warm_up()
    if not args.no_upload:  # uploads are read in worker processes forked from a server started now
        from camsim_core.io.isolated import warm_up as start_upload_readers

        start_upload_readers()
    from .state import start_session_threads

    start_session_threads()  # the sessions' threads, before the event loop would have to start them
    _freeze_startup_objects()
    from . import compat
    from .compat import build_off_loop as _build_off_loop  # pages built in a thread: the event loop serves the others meanwhile

    compat.apply()  # Panel's internals the explorer relies on: a warning in the log for each one missing
    compat.hooks.served_without_cdn()  # a served page's files come from this server, whatever Panel's mode
    _build_off_loop.install()
    from .compat import early_head as _early_head

    _early_head.install()  # a link's page sends its scripts while it is built (before the spare hook wraps it)
    if not args.no_spare_page:
        from .compat import spare_session as _spare_session

        if _spare_session.install():
            _spare_session.prepare_at_start(f"{public_host(args.address)}:{args.port}")
    from .csp import ContentSecurityPolicy  # the pages' Content-Security-Policy header (app/csp.py)

    print(f"camsim explorer on http://{public_host(args.address)}:{args.port}/ (Ctrl-C to stop)", flush=True)
    server = pn.serve(main.create_app, port=args.port, address=args.address, show=args.show, start=False,
             websocket_origin=[o for o in origins if not o.startswith("[")],  # Bokeh parses no IPv6 address
             title="camsim explorer", verbose=False,
             websocket_max_message_size=WEBSOCKET_MAX_MESSAGE_BYTES,
             unused_session_lifetime_milliseconds=idle_ms,
             check_unused_sessions_milliseconds=max(500, min(idle_ms, 10_000)),
             **keep_alive_options(args.keep_alive),
             transforms=[ContentSecurityPolicy])
    tornado = compat.hooks.tornado_app(server)
    if tornado is None:  # no Host check means a page of any site could reach this server (DNS rebinding)
        sys.exit("camsim serve: this Bokeh does not expose its Tornado application, so the Host header cannot be "
                 "checked; not serving (see camsim_explorer/compat)")
    refuse_other_hosts(tornado, origins)  # before the server takes its first request
    server.start()
    from .loop_watch import watch_event_loop, watch_garbage_collection

    watch_event_loop(server.io_loop.asyncio_loop)  # a line in the log for every stall of the event loop over 100 ms
    watch_garbage_collection()  # and for every garbage collection that held every thread over 100 ms
    _full_collections_when_quiet(server.io_loop)
    from .shown import serve_on

    serve_on(server.io_loop)  # other threads' callbacks to a page go through this loop (``shown.next_tick``)
    sys.setswitchinterval(GIL_SWITCH_S)
    try:
        server.io_loop.start()
    except RuntimeError:  # as pn.serve: a loop already running
        pass
    _let_go_of_queued_work()
    print("camsim explorer stopped", flush=True)
    return 0
