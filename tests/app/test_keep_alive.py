"""A server that pings its pages: tabs closed mid-change leave no traceback, a page that stops answering is closed.

``camsim serve --keep-alive S`` pings each page every S seconds. A tab closed while its changes are still on their
way (its renderer gone: the socket closes with no close frame) must leave the server's log free of tracebacks
whenever a ping comes: Bokeh's own keep-alive let go of such a page's session before Bokeh's handlers saw the
close, and each change still on its way, then the close itself, logged an ``AssertionError`` with its traceback.
A page that stops answering the pings (a laptop shut, a network gone) is closed as a closed tab is, so that its
session is freed; a page that answers stays.

The pages are driven over Bokeh's protocol (``ws_session``), with no browser; the page that stops answering is a
bare socket that opened the page's websocket and never answers a ping.
"""

from __future__ import annotations

import asyncio
import base64
import os
import re
import socket
import time
import urllib.parse
import urllib.request

import pytest

from app_helpers import ARTIFACTS, explorer_server, server_log
from ws_session import WsSession

pytestmark = pytest.mark.slow

#: Seconds between two pings in these tests: short, and long enough for a loaded machine to answer each in time.
PING_S = 2.0
#: Changes a page closed mid-change sends: the server is still handling them when a ping comes.
CHANGES = 500


@pytest.fixture(scope="module")
def pinging_server():
    ARTIFACTS.mkdir(exist_ok=True)
    with explorer_server(extra_args=["--keep-alive", str(PING_S), "--no-spare-page"]) as url:
        yield url


async def _closed_mid_change(url, first):
    """A page that sends CHANGES changes of the noise and is gone at once (its socket closed, no close frame): the
    server is still handling them when a ping comes."""
    page = await WsSession.open(url)
    for k in range(CHANGES):
        await page.change("w-noise", float((first + k) % 5 + 1))
    page.ws.protocol.stream.close()
    page._reader.cancel()


async def _pages_closed_mid_change(url, rounds, at_once):
    for r in range(rounds):
        await asyncio.gather(*(_closed_mid_change(url, r * at_once + k) for k in range(at_once)))
        await asyncio.sleep(PING_S / 2)  # a ping finds the last ones closing


async def _answering_page_sees_a_change(url, wait_s):
    page = await WsSession.open(url)
    try:
        await asyncio.sleep(wait_s)  # several pings, answered by the page's websocket
        sent = await page.change("w-noise", 4.0)
        await page.shown("noise_sigma", 4.0, sent)
        return page.ws.protocol is not None and not page.ws.protocol.is_closing()
    finally:
        await page.close()


def test_pages_closed_mid_change_leave_no_traceback(pinging_server):
    asyncio.run(_pages_closed_mid_change(pinging_server, rounds=2, at_once=2))
    time.sleep(2 * PING_S)  # pings meet the closed pages' connections, whatever Bokeh has handled of them
    log = server_log(pinging_server)
    for bad in ("Traceback", "AssertionError", "error handling message", "Uncaught exception"):
        assert bad not in log, log[max(0, log.find(bad) - 500):log.find(bad) + 2000]


def _open_websocket_and_go_quiet(url):
    """A bare socket that opens the page's websocket as a browser does, then never answers: returns it."""
    page = urllib.request.urlopen(url, timeout=90).read().decode()
    token = re.search(r'"token":"([^"]+)"', page).group(1)
    host = urllib.parse.urlsplit(url).netloc
    name, port = host.rsplit(":", 1)
    sock = socket.create_connection((name, int(port)), timeout=30)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                  f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                  f"Sec-WebSocket-Protocol: bokeh, {token}\r\nOrigin: http://{host}\r\n\r\n").encode())
    answer = b""
    while b"\r\n\r\n" not in answer:
        chunk = sock.recv(4096)
        assert chunk, f"the server closed the websocket's opening: {answer!r}"
        answer += chunk
    assert answer.startswith(b"HTTP/1.1 101"), answer[:200]
    return sock


def test_a_page_that_stops_answering_the_pings_is_closed_and_one_that_answers_stays(pinging_server):
    quiet = _open_websocket_and_go_quiet(pinging_server)
    started = time.monotonic()
    try:
        closed_after = None
        quiet.settimeout(1.0)
        while time.monotonic() - started < 60:
            try:
                if quiet.recv(1 << 16) == b"":  # read what the server sends (its ACK, pings) but answer nothing
                    closed_after = time.monotonic() - started
                    break
            except socket.timeout:
                pass
    finally:
        quiet.close()
    # a ping after PING_S, PING_S to answer it, then Tornado's 5 s for the close to be answered before it lets go
    assert closed_after is not None, "the server kept a page that answered no ping for 60 s"
    assert closed_after < 2 * PING_S + 5 + 20, closed_after
    assert asyncio.run(_answering_page_sees_a_change(pinging_server, 3 * PING_S))
