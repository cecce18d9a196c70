"""``camsim serve`` facing hostile visitors on a class network (issue 36, items 4, 5 and 7).

* The upload limit lives on the server: a page's script can change what the browser checks, not what the
  server counts, and the bytes of an upload are let go of once parsed.
* DNS rebinding: every route answers only requests naming one of the server's own hosts (``Host``), the
  page, the static files and the websocket alike.
* Values that raised in the server (a 5,000-digit link value, a 100,000-character viewing, ``spd:1e-300``,
  NaN in the parameters file, a NUL in a file name) get a message naming the field.

The browser side of these is in ``tests/browser/test_server_hostile_browser.py``.
"""

import asyncio
import base64
import http.client
import json
import re
from urllib.parse import urlparse

import pytest
from bokeh.document import Document

import camsim_explorer.main  # noqa: F401  (installs the explorer's reading of link values)
from camsim_explorer import state as state_module
from camsim_explorer.state import ExplorerState
from camsim_explorer.upload import BoundedUpload
from app_helpers import server_log
from camsim_explorer.serve import OTHER_HOST_MESSAGE, allowed_origins, host_allowed

MiB = 2**20


# -- item 4: the upload limit is the server's ---------------------------------------------------------------
def _browser_sets(upload, doc, attr, value):
    """What the server does with a change of ``attr`` sent by the page (a Bokeh patch from the browser)."""
    model = upload._models[next(iter(upload._models))][0]
    doc.apply_json_patch({"events": [{"kind": "ModelChanged", "model": {"id": model.data.id}, "attr": attr,
                                      "new": value}]}, setter="browser")


def _piece(name, index, total, data, size):
    return {"kind": "chunk", "name": name, "size": size, "index": index, "total": total,
            "data": base64.b64encode(data).decode()}


def test_the_page_cannot_lift_the_servers_upload_limit():
    upload = BoundedUpload(max_bytes=3 * MiB)
    doc = Document()
    model = upload.get_root(doc)
    doc.add_root(model)
    synced = model.data.properties_with_values()
    # the limit, the file and its name stay on the server; the page gets a copy of the limit for its own check
    assert not {"max_bytes", "value", "filename", "refused"} & set(synced)
    assert synced["browser_max_bytes"] == 3 * MiB
    # a page's script raises every limit it can see or name
    _browser_sets(upload, doc, "browser_max_bytes", 2**40)
    _browser_sets(upload, doc, "max_bytes", 2**40)  # not a property of the page's model: Bokeh drops it
    assert upload.browser_max_bytes == 2**40 and upload.max_bytes == 3 * MiB
    got = []
    upload.param.watch(lambda e: got.append(e.new), "value")
    # and claims a small file while sending 5 pieces of 1 MiB: refused on the bytes received
    for i in range(5):
        upload._handle_msg(_piece("big.npz", i, 5, bytes(MiB), size=10))
    assert got == []
    assert upload.refused.startswith("big.npz: is 4.0 MiB, more than the 3.0 MiB an upload may be")
    assert upload._parts == [] and upload._received == 0  # nothing of it kept
    # a file claiming more than the limit is refused at its first piece, and its other pieces are dropped
    for i in range(3):
        upload._handle_msg(_piece("huge.npz", i, 120, bytes(MiB), size=120 * MiB))
    assert "huge.npz: is 120.0 MiB, more than the 3.0 MiB" in upload.refused and upload._parts == []
    # a file within the limit still arrives
    upload._handle_msg(_piece("ok.npz", 0, 2, b"a" * 1000, size=2000))
    upload._handle_msg(_piece("ok.npz", 1, 2, b"b" * 1000, size=2000))
    assert got == [b"a" * 1000 + b"b" * 1000] and upload.refused == ""


def test_pieces_the_page_script_did_not_write_are_dropped_without_an_exception():
    upload = BoundedUpload(max_bytes=MiB)
    for msg in ({"kind": "chunk", "index": "x"}, {"kind": "chunk", "index": float("inf")},
                {"kind": "chunk", "index": 0, "total": 1, "data": "not base64!"}, {"kind": "too_large", "size": "big"},
                "not a dict", {"kind": "chunk", "index": 3, "total": 4, "data": ""}):
        upload._handle_msg(msg)
    assert upload.value is None and upload._parts == []


def test_an_uploads_bytes_are_let_go_of_once_parsed_success_or_failure():
    upload = BoundedUpload(max_bytes=MiB)
    doc = Document()
    model = upload.get_root(doc)
    seen = []

    def parse(event):
        seen.append((upload.filename, len(event.new)))
        if len(seen) == 2:
            raise ValueError("a parser that fails")

    upload.param.watch(parse, "value")
    upload._handle_msg(_piece("a.npz", 0, 1, bytes(1000), size=1000))
    assert seen == [("a.npz", 1000)]
    assert upload.value is None and upload._parts == []  # the session holds the parsed scene, not the file
    with pytest.raises(ValueError):
        upload._handle_msg(_piece("b.npz", 0, 1, bytes(2000), size=2000))
    assert seen[-1] == ("b.npz", 2000) and upload.value is None
    assert "value" not in model.data.properties_with_values()  # never sent back to the page


# -- item 7: each refusal names the field ------------------------------------------------------------------
@pytest.fixture(scope="module")
def state():
    return ExplorerState()


def _put_back(state, name, value):
    """Set ``name`` as a link or a widget does; return the message and the value in force afterwards."""
    state.message = ""
    setattr(state, name, value)
    return state.message, getattr(state, name)


def test_a_long_viewing_text_is_refused_by_name_and_put_back(state):
    message, now = _put_back(state, "viewing", "x" * 100_000)
    assert message.startswith("Refused: viewing: is 100000 characters long; at most 256 are allowed")
    assert now == state.shown["viewing"] == "camera"
    assert len(message) < 400  # the message quotes the text cut short
    for name in ("gaussian_centers", "gaussian_widths", "sensor", "custom_tile"):  # every text parameter
        message, now = _put_back(state, name, "1 " * 200)
        assert f"{name}: is 400 characters long" in message and now == state.shown[name], name


@pytest.mark.parametrize("viewing", ["spd:1e-300", "spd:1e300", "camera/1e-300", "display:1e-300mm@1m"])
def test_a_viewing_of_absurd_samples_per_degree_is_refused_by_name(state, viewing):
    message, now = _put_back(state, "viewing", viewing)
    assert message.startswith(f"Refused: viewing: '{viewing}' gives ")
    assert "samples per degree; the explorer takes 0.01 to 10000" in message
    assert "Error" not in message and now == "camera"
    message, now = _put_back(state, "viewing", "camera/10")  # a sensible one still applies
    assert message == "" and now == "camera/10" and state.result.params["viewing"] == "camera/10"
    _put_back(state, "viewing", "camera")


@pytest.mark.parametrize("text, entry", [
    ('{"wavelength": NaN}', "wavelength (NaN)"),
    ('{"wavelength": Infinity}', "wavelength (Infinity)"),
    ('{"wavelength": -Infinity}', "wavelength (-Infinity)"),
    ('{"wavelength": 1e999}', "wavelength (1e999)"),
    ('{"seed": %s}' % ("9" * 5000), "seed (a number of 5000 digits)"),
    ('{"pinned": [{"name": "a", "params": {"distance": NaN}}]}', "pinned[0].params.distance (NaN)"),
])
def test_a_parameters_file_with_nan_or_infinity_is_refused_by_name(state, text, entry):
    before = state.to_dict()
    assert not state.from_json(text)
    assert state.message.startswith(f"Parameters file refused: {entry}: numbers must be finite")
    assert state.to_dict() == before
    assert state.from_json('{"wavelength": 600}') and state.wavelength == 600  # a finite one applies
    state.from_json('{"wavelength": 550}')


def test_a_link_cannot_set_a_wavelength_that_is_not_a_number(state):
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match="wavelength"):
            state.wavelength = bad  # the address's values go through param: on_error names the entry
    assert state.wavelength == 550


def test_a_file_name_with_a_nul_byte_is_refused_by_name(state):
    scene = state.scene
    assert not state.add_upload("scene\x00.npz", b"PK\x03\x04")
    assert state.message == r"Upload refused: the file name 'scene\x00.npz' holds a control character"
    assert state.scene == scene


def test_a_link_value_panel_cannot_convert_is_kept_as_text():
    """Panel turned digits into an int: 5,000 of them raised ValueError and the page was an HTTP 500. The
    server's compat hooks keep such a value as text (applied here as ``camsim serve`` applies them: the test
    passed only when an earlier test in its process had built a page)."""
    from camsim_explorer import compat

    compat.apply()
    from panel.io.location import parse_query

    digits = "9" * 5000
    assert parse_query(f"?seed={digits}&noise_sigma=2&scene=cacaphony290") == {
        "seed": digits, "noise_sigma": 2, "scene": "cacaphony290"}
    assert parse_query("?seed=3&alpha=0.5&pinned=[1, 2]") == {"seed": 3, "alpha": 0.5, "pinned": [1, 2]}


# -- item 5: hosts ------------------------------------------------------------------------------------------
def test_the_hosts_allowed_are_the_servers_own_names_with_the_port():
    local = allowed_origins("127.0.0.1", 5006)
    assert set(local) == {"localhost:5006", "127.0.0.1:5006", "[::1]:5006"}
    for host in ("localhost:5006", "127.0.0.1:5006", "[::1]:5006", "LOCALHOST:5006"):
        assert host_allowed(host, local), host
    for host in ("evil.example:5006", "localhost:5007", "localhost", "127.0.0.1", "evil.example", "",
                 "localhost.evil.example:5006", "127.0.0.1:5006.evil.example", "*", "localhost:*"):
        assert not host_allowed(host, local), host
    lan = allowed_origins("0.0.0.0", 80, ["review.example.org"])
    assert host_allowed("review.example.org", lan) and host_allowed("review.example.org:80", lan)
    assert not host_allowed("evil.example", lan)


def _get(url, path, host):
    u = urlparse(url)
    conn = http.client.HTTPConnection(u.hostname, u.port, timeout=120)
    try:
        conn.request("GET", path, headers={"Host": host})
        res = conn.getresponse()
        return res.status, res.getheader("Content-Type", ""), res.read().decode("utf-8", "replace")
    finally:
        conn.close()


def _handshake(url, host, origin, token=None):
    """Open the server's websocket with these ``Host`` and ``Origin`` headers: "accepted" or the refusal."""
    from tornado.httpclient import HTTPClientError, HTTPRequest
    from tornado.websocket import websocket_connect

    port = urlparse(url).port

    async def connect():
        req = HTTPRequest(f"ws://127.0.0.1:{port}/ws", headers={"Host": host, "Origin": origin},
                          request_timeout=120, connect_timeout=120)
        try:
            conn = await websocket_connect(req, subprotocols=["bokeh", token] if token else None)
        except HTTPClientError as exc:
            return f"refused {exc.code}"
        conn.close()
        return "accepted"

    return asyncio.run(connect())


def test_a_page_asked_for_under_another_name_is_refused(server):
    port = urlparse(server).port
    for path in ("/", "/?seed=3", "/static/js/bokeh.min.js", "/favicon.ico", "/no-such-page"):
        status, kind, body = _get(server, path, f"evil.example:{port}")
        assert status == 403 and kind.startswith("text/plain"), path
        assert body == OTHER_HOST_MESSAGE and "<" not in body
    assert _get(server, "/static/js/bokeh.min.js", f"localhost:{port}")[0] == 200
    assert _get(server, "/static/js/bokeh.min.js", f"127.0.0.1:{port}")[0] == 200


def test_a_websocket_under_another_name_is_refused_and_under_the_servers_own_accepted(server):
    port = urlparse(server).port
    evil = f"evil.example:{port}"
    status, _, page = _get(server, "/", f"127.0.0.1:{port}")
    assert status == 200
    token = re.search(r'"token":"([^"]+)"', page).group(1)
    # DNS rebinding: the page's own name in both headers (Tornado lets an Origin equal to the Host through)
    assert _handshake(server, evil, f"http://{evil}", token) == "refused 403"
    # another site's page opening the websocket of this one (the Origin check)
    assert _handshake(server, f"127.0.0.1:{port}", f"http://{evil}", token) == "refused 403"
    assert _handshake(server, f"127.0.0.1:{port}", f"http://127.0.0.1:{port}", token) == "accepted"
    assert "Traceback" not in server_log(server)


def test_a_five_thousand_digit_link_value_gets_the_page_not_an_http_500(server):
    port = urlparse(server).port
    status, kind, body = _get(server, "/?seed=" + "9" * 5000 + "&noise_sigma=2", f"127.0.0.1:{port}")
    assert status == 200 and kind.startswith("text/html")
    log = server_log(server)
    # an HTTP 500 in Tornado's access log ("500 GET /?seed=... (127.0.0.1) 3.2ms"); the loop watch's "event loop
    # blocked 500 ms" is not one (the loaded fresh-clone run of this suite matched it)
    assert "Traceback" not in log and "Exceeds the limit" not in log
    assert not re.search(r"\b5\d\d (GET|POST|HEAD) /", log), log[-2000:]
