"""The next page built in advance (``app._spare_session``): what a spare is built from, and which requests
never get one. The browser test ``test_a_page_built_in_advance_is_the_page_a_request_builds`` checks the page."""

from tornado.httputil import HTTPHeaders, HTTPServerRequest, RequestStartLine

from app import _spare_session as spare


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
