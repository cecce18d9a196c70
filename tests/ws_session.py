"""A page's websocket without the page: an explorer session driven over Bokeh's protocol, for load tests.

A load test of the server on a 2-core machine cannot run its ten visitors as
Chromium pages on the same cores: each change costs a page ~0.13 s of
rendering, ten pages take the cores from the server (sampled: Chromium's
renderers used 1.5-2.8 of the 2 cores through a load test, the server
0.1-0.3), and the times measured are then the test's own browsers'. A
:class:`WsSession` is what a page is to the server (it fetches the page,
opens its websocket with the page's token, pulls the document, reports the
document ready, and sends a widget's new value as the browser does) at
almost no CPU: it parses only the messages' JSON, never renders.

Written by hand: Bokeh's own ``bokeh.client`` runs a blocking loop per
session, and ten of them cannot share one event loop.
"""

from __future__ import annotations

import asyncio
import html
import json
import re
import time
import urllib.parse
import urllib.request
from itertools import count

from tornado.httpclient import HTTPRequest
from tornado.websocket import websocket_connect

_ids = count(1)


async def until(predicate, what, timeout=90.0):
    """Wait (on the running asyncio loop) until ``predicate()`` holds; an AssertionError naming ``what`` after
    ``timeout`` seconds."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while not predicate():
        if loop.time() > deadline:
            raise AssertionError(f"never: {what}")
        await asyncio.sleep(0.02)


def _frames(msgtype, content):
    header = {"msgid": f"load{next(_ids)}", "msgtype": msgtype}
    return [json.dumps(header), "{}", json.dumps(content)]


def _walk(node, found):
    if isinstance(node, dict):
        if node.get("type") == "object" and "id" in node:
            found[node["id"]] = node
        for v in node.values():
            _walk(v, found)
    elif isinstance(node, list):
        for v in node:
            _walk(v, found)


def _references(node, found):
    """The ids of the models ``node`` refers to (``{"id": ...}``), not counting binary buffers."""
    if isinstance(node, dict):
        if node.get("type") == "bytes":
            return
        if set(node) == {"id"}:
            found.add(node["id"])
        for v in node.values():
            _references(v, found)
    elif isinstance(node, list):
        for v in node:
            _references(v, found)


def _status(text):
    """The status pane's JSON from its model's text (Panel escapes the pane's HTML once more for its model:
    unescape, drop <pre>, unescape the JSON); None when it is not JSON."""
    inner = re.fullmatch(r"\s*<pre>(.*)</pre>\s*", html.unescape(text), re.S)
    try:
        return json.loads(html.unescape(inner.group(1))) if inner else None
    except ValueError:
        return None


class WsSession:
    """One explorer session over its websocket. ``await WsSession.open(url)``; then :meth:`change` a widget
    (by its CSS class) and :meth:`shown` the time until the status pane shows the result."""

    def __init__(self, url):
        self.url = url
        self.ws = None
        self.models = {}
        self.status_id = None
        self.statuses = []  # (monotonic s, status dict) as they arrive
        #: (message number, ids) of each message that referred to models not sent before it (the browser
        #: drops such a change with "reference ... isn't known"): empty when the server keeps its order
        self.unknown_references = []
        self.patches = 0
        self._reader = None

    @classmethod
    async def open(cls, url, timeout=90.0, page=None):
        """Open the session of the page at ``url`` (of the page's HTML ``page`` when fetched already)."""
        self = cls(url)
        if page is None:
            page = await asyncio.to_thread(lambda: urllib.request.urlopen(url, timeout=timeout).read().decode())
        token = re.search(r'"token":"([^"]+)"', page).group(1)
        host = urllib.parse.urlsplit(url).netloc
        request = HTTPRequest(f"ws://{host}/ws", headers={"Origin": f"http://{host}"})
        self.ws = await websocket_connect(request, subprotocols=["bokeh", token], max_message_size=1 << 30)
        await self._message()  # ACK
        await self._send("PULL-DOC-REQ", {})
        header, reply = await self._message()
        while header["msgtype"] == "PATCH-DOC":  # changes made before the pull: BokehJS drops them (the pull has them)
            header, reply = await self._message()
        _walk(reply["doc"], self.models)
        self.status_id = self.find("camsim-status", "HTML")
        self._reader = asyncio.ensure_future(self._read())
        await self._send("PATCH-DOC", {"events": [{"kind": "MessageSent", "msg_type": "bokeh_event", "msg_data": {
            "type": "event", "name": "document_ready", "values": {"type": "map", "entries": []}}}]})
        return self

    def find(self, css, kind=None):
        """The id of the model with CSS class ``css`` (of type ``kind``), or of the first model with a ``value``
        among its children (a Panel widget is a layout around its input)."""
        for model in self.models.values():
            attrs = model.get("attributes", {})
            if css in (attrs.get("css_classes") or []):
                if kind is None or model.get("name", "").rsplit(".", 1)[-1] == kind:
                    if kind is not None or "value" in attrs:
                        return model["id"]
                    found = {}
                    _walk(attrs.get("children"), found)
                    for inner in found.values():
                        if "value" in inner.get("attributes", {}):
                            return inner["id"]
        raise LookupError(f"no model with CSS class {css!r}")

    async def _send(self, msgtype, content):
        for frame in _frames(msgtype, content):
            await self.ws.write_message(frame)

    async def _message(self):
        header = json.loads(await self.ws.read_message())
        await self.ws.read_message()  # metadata
        content = json.loads(await self.ws.read_message())
        for _ in range(header.get("num_buffers", 0)):
            await self.ws.read_message()  # the buffer's header
            await self.ws.read_message()  # its bytes
        return header, content

    async def _read(self):
        while True:
            try:
                header, content = await self._message()
            except (TypeError, AttributeError):  # closed (read_message gave None)
                return
            if header["msgtype"] != "PATCH-DOC":
                continue
            self.patches += 1
            _walk(content, self.models)
            used = set()
            _references(content, used)
            if used - self.models.keys():
                self.unknown_references.append((self.patches, sorted(used - self.models.keys())))
            for event in content.get("events", []):
                if event.get("kind") == "ModelChanged" and "id" in event.get("model", {}):
                    self.models.get(event["model"]["id"], {}).setdefault("attributes", {})[event["attr"]] = event["new"]
                if event.get("kind") == "ModelChanged" and event.get("model", {}).get("id") == self.status_id \
                        and event.get("attr") == "text":
                    status = _status(event["new"])
                    if status is not None:
                        self.statuses.append((time.monotonic(), status))

    def text(self, css, kind="HTML"):
        """The latest text of the model with CSS class ``css`` (as pulled, then as changed); "" when none."""
        return self.models[self.find(css, kind)].get("attributes", {}).get("text", "") or ""

    def pulled_status(self):
        """The status the page's document held when it was pulled (a dict; None when it held none)."""
        return _status(self.models[self.status_id]["attributes"].get("text", ""))

    async def change(self, css, value):
        """Send widget ``css``'s new ``value`` as the browser does; returns the monotonic time it was sent."""
        model = self.find(css)
        sent = time.monotonic()
        await self._send("PATCH-DOC", {"events": [{"kind": "ModelChanged", "model": {"id": model},
                                                   "attr": "value", "new": value}]})
        return sent

    async def click(self, css):
        """Click the button with CSS class ``css`` as the browser does (it must have been sent already)."""
        await self._send("PATCH-DOC", {"events": [{"kind": "MessageSent", "msg_type": "bokeh_event", "msg_data": {
            "type": "event", "name": "button_click",
            "values": {"type": "map", "entries": [["model", {"id": self.find(css, "Button")}]]}}}]})

    async def wait_for_model(self, css, kind=None, timeout=60.0):
        """Wait until the model with CSS class ``css`` has been sent (a tab's contents come when it opens)."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                return self.find(css, kind)
            except LookupError:
                if time.monotonic() > deadline:
                    raise
                await asyncio.sleep(0.02)

    async def shown(self, name, value, sent, timeout=120.0):
        """Seconds from ``sent`` to the first status showing parameter ``name`` at ``value`` (not computing)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for t, status in self.statuses:
                if t >= sent and not status.get("computing") and status.get("params", {}).get(name) == value:
                    return t - sent
            await asyncio.sleep(0.01)
        raise AssertionError(f"no status with {name} = {value} within {timeout:.0f} s (last: {self.statuses[-1:]})")

    async def close(self):
        if self.ws is not None:
            self.ws.close()
        if self._reader is not None:
            self._reader.cancel()

    def vanish(self):
        """Drop the connection with no close frame, as a page whose renderer is gone does."""
        if self.ws is not None and self.ws.protocol is not None:
            self.ws.protocol.stream.close()
        if self._reader is not None:
            self._reader.cancel()
