"""Chromium driven the way a user's browser runs: through the DevTools protocol's Runtime alone.

Playwright enables the protocol's Network domain on every page it drives (it
reports requests and responses to its driver). With it on, Chromium copies
every WebSocket frame the page receives to the driver, base64-encoded, in
the renderer and in the browser process: the explorer's results arrive as
binary frames of up to a few megabytes, and that copying is part of what a
Playwright-timed action measures (a chart pick, 8 MB of images: 550-660 ms
with the Network domain on, 430-500 ms without; a noise change 105-120 ms
against 70-75 ms; same server, same machine). No user's browser does it.

This module launches the system Chromium with a DevTools port and speaks
the protocol to it over a WebSocket (Tornado's client, in a thread of its
own): pages are made with ``Target.createTarget`` (each in a browser context of
its own when asked: nothing cached), scripts added with
``Page.addScriptToEvaluateOnNewDocument``, loaded with ``Page.navigate``, and
everything else is JavaScript run by ``Runtime.evaluate``. The only domain
enabled is Page (which runs the added scripts; its events are a few per load). Hand-written: the protocol clients on PyPI
(pyppeteer, pychrome) are unmaintained, and Playwright's is the one being
avoided.

:class:`PlaywrightDriver` offers the same interface over Playwright (``--driver
playwright`` in ``browser.py``): the difference is the instrumentation's cost.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import re
import shutil
import subprocess
import tempfile
import threading

__all__ = ["CdpDriver", "PlaywrightDriver"]

#: Switches of a headless browser that are not automation: a profile of its own, no first-run pages.
_SWITCHES = ["--headless", "--no-first-run", "--no-default-browser-check", "--hide-scrollbars", "--mute-audio",
             "--force-color-profile=srgb", "--disable-extensions", "--remote-debugging-port=0"]


class _Connection:
    """One DevTools WebSocket: ``call(method, **params)`` sends a command and waits for its result.
    Events (none are enabled) are read and dropped."""

    def __init__(self, loop, url, timeout):
        self._loop, self._timeout, self._ids = loop, timeout, itertools.count(1)
        self._waiting = {}
        self._ws = self._run(self._connect(url))

    async def _connect(self, url):
        from tornado.websocket import websocket_connect

        ws = await websocket_connect(url, max_message_size=1 << 30)
        asyncio.ensure_future(self._read(ws))
        return ws

    async def _read(self, ws):
        while True:
            msg = await ws.read_message()
            if msg is None:  # closed: every waiting command fails
                for fut in self._waiting.values():
                    if not fut.done():
                        fut.set_exception(ConnectionError("the browser closed the DevTools connection"))
                return
            data = json.loads(msg)
            fut = self._waiting.pop(data.get("id"), None)
            if fut is not None and not fut.done():
                fut.set_result(data)

    def _run(self, coro, timeout=None):
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout or self._timeout)

    async def _call(self, method, params):
        mid = next(self._ids)
        fut = self._waiting[mid] = asyncio.get_running_loop().create_future()
        await self._ws.write_message(json.dumps({"id": mid, "method": method, "params": params}))
        return await fut

    def call(self, method, timeout=None, **params):
        data = self._run(self._call(method, params), timeout)
        if "error" in data:
            raise RuntimeError(f"{method}: {data['error'].get('message')}")
        return data["result"]

    def close(self):
        self._run(self._close())

    async def _close(self):
        self._ws.close()


class CdpPage:
    """A page (tab) of :class:`CdpDriver`."""

    def __init__(self, driver, target, context, width, height):
        self._driver, self._target, self._context = driver, target, context
        self._conn = _Connection(driver._loop, f"ws://127.0.0.1:{driver.port}/devtools/page/{target}", driver.timeout)
        self._conn.call("Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1,
                        mobile=False)
        self._conn.call("Page.enable")  # scripts added on new documents run only with it (its events are few)

    def add_init_script(self, source):
        """Run ``source`` (an expression) in every document this page loads, before its own scripts."""
        self._conn.call("Page.addScriptToEvaluateOnNewDocument", source=source)

    def goto(self, url):
        """Start loading ``url`` (returns once the navigation is committed, not loaded)."""
        result = self._conn.call("Page.navigate", url=url)
        if result.get("errorText"):
            raise RuntimeError(f"{url}: {result['errorText']}")

    def evaluate(self, function, arg=None, timeout=None):
        """``function(arg)`` (JavaScript source of a function) in the page; its value, a promise awaited.
        A document still loading (``goto``) is waited for: the call retries until the page's realm answers."""
        expression = f"({function})({json.dumps(arg)})"
        for _ in range(600):
            result = self._conn.call("Runtime.evaluate", timeout=timeout, expression=expression,
                                     awaitPromise=True, returnByValue=True)
            details = result.get("exceptionDetails")
            if details is None:
                return result["result"].get("value")
            text = json.dumps(details)[:600]
            if "Execution context was destroyed" in text or "Inspected target navigated" in text:
                continue  # a navigation replaced the document meanwhile
            raise RuntimeError(f"JavaScript error in the page: {text}")
        raise RuntimeError("the page never settled")

    def close(self):
        self._conn.close()
        self._driver._browser.call("Target.closeTarget", targetId=self._target)
        if self._context:
            self._driver._browser.call("Target.disposeBrowserContext", browserContextId=self._context)


class CdpDriver:
    """The system Chromium with a DevTools port; pages driven by :class:`CdpPage` (a context manager)."""

    def __init__(self, executable, args=(), timeout=240.0):
        self.executable, self.args, self.timeout = executable, list(args), timeout

    def __enter__(self):
        self._profile = tempfile.mkdtemp(prefix="camsim-bench-chromium-")
        self._proc = subprocess.Popen([self.executable, *self.args, *_SWITCHES, f"--user-data-dir={self._profile}",
                                       "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        url = None
        for line in self._proc.stderr:  # "DevTools listening on ws://127.0.0.1:PORT/devtools/browser/ID"
            found = re.search(r"DevTools listening on (ws://\S+)", line)
            if found:
                url = found.group(1)
                break
        if url is None:
            raise RuntimeError(f"{self.executable} gave no DevTools address (exit status {self._proc.poll()})")
        threading.Thread(target=self._proc.stderr.read, daemon=True).start()  # drain, never block the browser
        self.port = int(re.search(r":(\d+)/", url).group(1))
        self._loop = asyncio.new_event_loop()
        threading.Thread(target=self._loop.run_forever, daemon=True, name="cdp").start()
        self._browser = _Connection(self._loop, url, self.timeout)
        return self

    def new_page(self, width, height, fresh_context=False):
        """A new tab of ``width`` x ``height`` CSS pixels; in a browser context of its own (an empty cache)
        when ``fresh_context``, else in the browser's default context (one cache for its tabs)."""
        context = (self._browser.call("Target.createBrowserContext")["browserContextId"] if fresh_context else None)
        params = {"url": "about:blank"} | ({"browserContextId": context} if context else {})
        target = self._browser.call("Target.createTarget", **params)["targetId"]
        return CdpPage(self, target, context, width, height)

    def __exit__(self, *exc):
        try:
            self._browser.call("Browser.close", timeout=10)
        except Exception:
            pass
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._loop.call_soon_threadsafe(self._loop.stop)
        shutil.rmtree(self._profile, ignore_errors=True)
        return False


class _PlaywrightPage:
    def __init__(self, page):
        self._page = page
        page.set_default_timeout(240000)

    def add_init_script(self, source):
        self._page.add_init_script(source)

    def goto(self, url):
        self._page.goto(url, wait_until="commit")

    def evaluate(self, function, arg=None, timeout=None):
        return self._page.evaluate(function, arg)

    def close(self):
        self._page.close()


class PlaywrightDriver:
    """The same interface as :class:`CdpDriver`, over Playwright (its Network instrumentation included)."""

    def __init__(self, executable, args=(), timeout=240.0):
        self.executable, self.args = executable, list(args)

    def __enter__(self):
        from playwright.sync_api import sync_playwright

        self._pw = sync_playwright().start()
        self._browser = self._pw.chromium.launch(executable_path=self.executable, args=self.args)
        self._context = None
        return self

    def new_page(self, width, height, fresh_context=False):
        if fresh_context:
            return _PlaywrightPage(self._browser.new_page(viewport={"width": width, "height": height}))
        if self._context is None:
            self._context = self._browser.new_context(viewport={"width": width, "height": height})
        return _PlaywrightPage(self._context.new_page())

    def __exit__(self, *exc):
        self._browser.close()
        self._pw.stop()
        return False
