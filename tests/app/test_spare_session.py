"""The next page built in advance (``app.compat.spare_session``): what a spare is built from, and which requests
never get one. The browser test ``test_a_page_built_in_advance_is_the_page_a_request_builds`` checks the page."""

from tornado.httputil import HTTPHeaders, HTTPServerRequest, RequestStartLine

from camsim_explorer.compat import spare_session as spare


def _request(uri, headers=None):
    h = HTTPHeaders({"Host": "class.example:5006", **(headers or {})})
    return HTTPServerRequest(headers=h, start_line=RequestStartLine("GET", uri, "HTTP/1.1"))


def test_a_spare_is_built_from_the_path_and_host_only():
    asked = _request("/?noise_sigma=3", {"Cookie": "user=someone", "User-Agent": "a browser"})
    plain = spare._plain_request(asked)
    assert plain.path == "/" and plain.uri == "/" and plain.arguments == {}
    assert plain.host == "class.example:5006"
    assert dict(plain.headers) == {"Host": "class.example:5006"}  # another visitor's cookies stay theirs
    assert plain.cookies == {}


class _Handler:
    def __init__(self, request):
        self.request = request


def test_links_with_parameters_and_named_sessions_never_take_the_spare(monkeypatch):
    sentinel = object()
    monkeypatch.setitem(spare._spares, "/", sentinel)
    for request in (_request("/?noise_sigma=3"), _request("/?scene="), _request("/", {"Bokeh-Session-Id": "abc"})):
        assert spare._take(_Handler(request)) is None
    assert spare._spares["/"] is sentinel  # still there for a plain request
    monkeypatch.delitem(spare._spares, "/")
    assert spare._take(_Handler(_request("/"))) is None  # none built yet: the request builds its own


def test_the_next_page_is_built_once_pages_have_connected_and_are_quiet(monkeypatch):
    """A build holds the event loop: never while a served page is still loading, nor while a page sends
    messages (a user at work); then once, ``QUIET_S`` after the last message."""
    import asyncio
    import time

    monkeypatch.setattr(spare, "SPARE_DELAY_S", 0.05)
    monkeypatch.setattr(spare, "QUIET_S", 0.3)
    monkeypatch.setattr(spare, "POLL_S", 0.02)
    monkeypatch.setattr(spare, "busy", lambda: False)
    monkeypatch.setitem(spare._sources, "/quiet", object())
    monkeypatch.setattr(spare, "_last_message", [0.0])
    built = []

    async def build(path):
        built.append((path, time.monotonic()))

    monkeypatch.setattr(spare, "_build", build)

    class Served:  # a page's session as the builder sees it
        connection_count = 0
        destroyed = False

    page = Served()

    async def scenario():
        spare._in_flight[page] = [time.monotonic(), None]
        spare._schedule("/quiet")
        spare._schedule("/quiet")  # asked twice: built once
        await asyncio.sleep(0.5)
        assert built == []  # the served page has not connected
        page.connection_count = 1
        for _ in range(6):  # someone at work on a page
            spare._last_message[0] = time.monotonic()
            await asyncio.sleep(0.1)
        assert built == []
        last = spare._last_message[0]
        await asyncio.sleep(0.8)
        assert [p for p, _ in built] == ["/quiet"]
        assert built[0][1] - last >= 0.3

    asyncio.run(scenario())
    assert "/quiet" not in spare._scheduled
