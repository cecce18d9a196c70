"""A server that pings its pages: tabs closed mid-change leave no traceback, and the pings keep coming.

``camsim serve --keep-alive S`` pings each page every S seconds (a proxy in between keeps a quiet page's
connection open). A tab closed while its changes are still on their way (its renderer gone: the socket closes with
no close frame) must leave the server's log free of tracebacks whenever a ping comes: Bokeh's own keep-alive let go
of such a page's session before Bokeh's handlers saw the close, and each change still on its way, then the close
itself, logged an ``AssertionError`` with its traceback. A page that does not answer the pings is not closed for it
(a laptop shut for a while finds its page again); a page that answers computes as ever.

The pages are driven over Bokeh's protocol (``ws_session``), with no browser; the page that does not answer is a
bare socket that opened the page's websocket and reads what the server sends.
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

#: Seconds between two pings in these tests (the shortest ``--keep-alive``).
PING_S = 1.0
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
    page.vanish()


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
    """A bare socket that opens the page's websocket as a browser does, then never answers: returns it and the
    bytes that came after the server's answer."""
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
    head, _, rest = answer.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 101"), head[:200]
    return sock, rest


def _frames(sock, buffered, seconds):
    """``(opcode, monotonic s)`` of each frame the server sends over ``seconds`` (RFC 6455 section 5.2; a server's
    frames are not masked); stops early, with opcode None, if the server closes the connection."""
    out, data, end = [], bytearray(buffered), time.monotonic() + seconds
    sock.settimeout(0.2)
    while time.monotonic() < end:
        while len(data) >= 2:
            n, at = data[1] & 0x7F, 2
            if n == 126:
                n, at = int.from_bytes(data[2:4], "big"), 4
            elif n == 127:
                n, at = int.from_bytes(data[2:10], "big"), 10
            if len(data) < at + n:
                break
            out.append((data[0] & 0x0F, time.monotonic()))
            del data[:at + n]
        try:
            chunk = sock.recv(1 << 16)
        except socket.timeout:
            continue
        if not chunk:
            out.append((None, time.monotonic()))
            break
        data += chunk
    return out


def test_pings_come_every_keep_alive_seconds_unanswered_or_not_and_a_page_that_answers_computes(pinging_server):
    quiet, buffered = _open_websocket_and_go_quiet(pinging_server)
    try:
        frames = _frames(quiet, buffered, 5 * PING_S)
    finally:
        quiet.close()
    pings = [t for op, t in frames if op == 0x9]
    assert None not in [op for op, _ in frames], "the server closed a page that did not answer its pings"
    assert len(pings) >= 3, frames  # every PING_S seconds, whether answered or not
    gaps = [b - a for a, b in zip(pings, pings[1:])]
    assert all(0.5 * PING_S < g < PING_S + 3 for g in gaps), gaps  # + 3 s: a loaded machine's event loop
    assert asyncio.run(_answering_page_sees_a_change(pinging_server, 2 * PING_S))
