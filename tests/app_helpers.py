"""Helpers for the explorer's browser tests: a server subprocess and Playwright page utilities.

The page exposes what tests read in a small JSON pane (``.camsim-status``:
parameters, mean and median dE, content hashes of the raw and rendered
images, the tile, the steps that ran); widgets carry stable CSS classes
(``w-noise``, ``w-render``, ``w-mosaic``, ...).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ARTIFACTS = ROOT / "test-artifacts"
CHROMIUM = os.environ.get("CAMSIM_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking"]
TIMEOUT = 90.0  # generous: the machine running the tests may be shared
POLL = 0.05  # seconds between two looks of a polling wait (each look is a cheap read: the latency is the cost)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


#: The servers ``explorer_server`` runs, by base URL: ``(process, log path or None)``.
RUNNING = {}


def server_gone(url):
    """Why the server at ``url`` (one ``explorer_server`` started) no longer answers: its exit status and the
    end of its log; None while it runs. A test server that dies fails every later page on it with
    ``ERR_CONNECTION_REFUSED``; this says why instead."""
    proc, log = RUNNING.get(url, (None, None))
    if proc is None or proc.poll() is None:
        return None
    tail = ""
    if log is not None and Path(log).exists():
        tail = "".join(Path(log).read_text(errors="replace").splitlines(keepends=True)[-40:])
    return f"camsim serve at {url} exited with status {proc.returncode}; the end of its log ({log}):\n{tail}"


@contextmanager
def explorer_server(scene=None, extra_args=(), on_start=None, launcher=None):
    """``camsim serve`` on 127.0.0.1 and a free port, in a subprocess; yields the base URL.

    ``extra_args`` are more ``camsim serve`` flags; ``on_start(proc)`` is
    called with the server process once it answers (e.g. to watch its memory);
    ``launcher`` is a script run instead of ``-m camsim_core.cli`` (same arguments).
    """
    port = free_port()
    entry = [str(launcher)] if launcher else ["-m", "camsim_core.cli"]
    cmd = [sys.executable, *entry, "serve", "--port", str(port), "--address", "127.0.0.1"]
    if scene:
        cmd += ["--scene", scene]
    cmd += list(extra_args)
    # PYTHONFAULTHANDLER: a server that crashes (a signal, not an exception) writes every thread's stack to its log
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", BOKEH_LOG_LEVEL="warn", PYTHONFAULTHANDLER="1")
    log = open(ARTIFACTS / f"server-{port}.log", "w") if ARTIFACTS.exists() else subprocess.DEVNULL
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}/"
    try:
        deadline = time.monotonic() + TIMEOUT
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"camsim serve exited with status {proc.returncode} (see {getattr(log, 'name', 'log')})")
            try:  # the port answers (a GET would open a session: slow on a loaded machine)
                with socket.create_connection(("127.0.0.1", port), timeout=2):
                    break
            except OSError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"camsim serve did not answer on {url} within {TIMEOUT:.0f} s")
            time.sleep(POLL)
        if on_start is not None:
            on_start(proc)
        RUNNING[url] = (proc, getattr(log, "name", None))
        yield url
    finally:
        gone = server_gone(url)
        RUNNING.pop(url, None)
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
        if hasattr(log, "close"):
            log.close()
    if gone:
        raise RuntimeError(f"the server died while its tests used it: {gone}")


def chromium_path():
    """The system Chromium, or a clear failure message (never a download)."""
    path = CHROMIUM if os.path.exists(CHROMIUM) else shutil.which("chromium")
    if not path:
        raise RuntimeError(
            f"Chromium not found at {CHROMIUM} nor on PATH: install Debian's chromium (`make chromium` or "
            "`apt-get install chromium`); the browser tests drive the system browser and never download one")
    return path


#: The size of a test page, in CSS pixels.
VIEWPORT = {"width": 1500, "height": 1100}

#: One browser context per browser (``id(browser)`` -> context): its pages share the HTTP cache and compiled
#: scripts, as a student's tabs do. A page in a context of its own loaded and compiled Bokeh's and Panel's
#: scripts anew: 2.3 s to a page's first dE against 1.9 s (quiet machine, five pages each).
_CONTEXTS = {}


def new_page(browser):
    """A new page (:data:`VIEWPORT`) in ``browser``: a Playwright ``BrowserContext`` (the ``browser`` fixture's
    profile), or a ``Browser``, in its shared context (made on first use, closed with the browser)."""
    from playwright.sync_api import BrowserContext

    if isinstance(browser, BrowserContext):
        return browser.new_page()  # its pages have the size it was launched with (the fixture's VIEWPORT)
    ctx = _CONTEXTS.get(id(browser))
    if ctx is None or ctx.browser is not browser or not browser.is_connected():
        ctx = _CONTEXTS[id(browser)] = browser.new_context(viewport=VIEWPORT)
    return ctx.new_page()


class Page:
    """A Playwright page on the explorer, with its console messages."""

    def __init__(self, browser, url, while_loading=None):
        """Open ``url``; ``while_loading(playwright_page)``, when given, is called as soon as the page's answer
        begins (before the browser has all of it), then the page is awaited as usual."""
        self.page = new_page(browser)
        self.viewport = self.page.viewport_size
        self.console = []
        self.page.set_default_timeout(TIMEOUT * 1000)
        self.page.on("console", lambda m: self.console.append((m.type, f"{m.text} ({m.location.get('url', '')})")))
        self.page.on("pageerror", lambda e: self.console.append(("pageerror", str(e))))
        if while_loading is None:
            self.response = self.page.goto(url)
        else:
            self.response = self.page.goto(url, wait_until="commit")
            while_loading(self.page)
        self.page.locator(".camsim-status pre").first.wait_for(state="attached", timeout=TIMEOUT * 1000)
        self.wait_for(lambda s: s.get("mean_de") is not None)

    def session_made(self):
        """How the server made this page's session: "spare" (built in advance) or "built" (for the request)."""
        timing = self.response.headers.get("server-timing", "") if self.response is not None else ""
        return "spare" if 'desc="spare"' in timing else "built"

    def status(self):
        text = self.page.evaluate(STATUS_JS)
        try:
            return json.loads(text)
        except (TypeError, ValueError):
            return {}

    def wait_for(self, predicate, timeout=TIMEOUT):
        """Wait until ``predicate(status)`` holds; return the status. The page watches its status pane and
        answers when it changes (or after :data:`CHANGE_WAIT_MS`), so the predicate is evaluated for each new
        status and a few times a second meanwhile."""
        from playwright.sync_api import Error as PlaywrightError

        deadline = time.monotonic() + timeout
        try:
            text = self.page.evaluate(STATUS_JS)
        except PlaywrightError as exc:  # the page is navigating (a link, a reload, back or forward): watch anew
            if "context was destroyed" not in str(exc) and "navigat" not in str(exc):
                raise
            text = None
        while True:
            try:
                s = json.loads(text)
            except (TypeError, ValueError):
                s = {}
            if s and predicate(s):
                return s
            if time.monotonic() > deadline:
                raise AssertionError(f"status never satisfied the condition; last: {s}")
            try:
                text = self.page.evaluate(STATUS_CHANGE_JS, [text, CHANGE_WAIT_MS])
            except PlaywrightError as exc:  # the page navigated while it watched (a link, a reload): watch anew
                if "context was destroyed" not in str(exc) and "navigat" not in str(exc):
                    raise
                text = None

    def params(self):
        return self.status()["params"]

    def select(self, css, value):
        self.page.locator(f".{css} select").first.select_option(value)

    def type_number(self, css, value):
        box = self.page.locator(f".{css} input").first
        box.fill(str(value))
        box.press("Enter")

    def alert_text(self):
        """The text of the page's alert while it is shown ("" when hidden)."""
        return alert_text(self.page)

    def wait_for_alert(self, words, timeout=TIMEOUT):
        """Wait until the page's alert shows ``words``; return its text (a busy server may take a while)."""
        deadline = time.monotonic() + timeout
        while True:
            text = self.alert_text()
            if words in text:
                return text
            if time.monotonic() > deadline:
                raise AssertionError(f"the alert never said {words!r}; it shows {text!r}")
            self.page.wait_for_timeout(POLL * 1000)

    def text(self, css):
        """Visible text of a Markdown-like pane (its content lives in a shadow root)."""
        return inner_texts(self.page, f"{css} p")

    def shot(self, name, selector=None):
        ARTIFACTS.mkdir(exist_ok=True)
        path = ARTIFACTS / f"{name}.png"
        if selector:
            return self.page.locator(selector).first.screenshot(path=str(path))
        return self.page.screenshot(path=str(path), full_page=True)

    def errors(self):
        return [m for m in self.console if m[0] in ("error", "pageerror")]

    def close(self):
        self.page.close()

    def start_over(self, fresh, timeout=30.0):
        """Press the page's Start over button and wait until the page is as a new page was: ``fresh`` is that
        page's status, read when it had its first result. True once the parameters, the images computed (their
        hashes), the tab shown and the message are the new page's, at the page's first size; False if anything
        else holds (presentation mode on, pinned designs, the page or its session gone, not back within
        ``timeout`` s): the caller then opens a new page. The console messages gathered so far are dropped."""
        from playwright.sync_api import Error as PlaywrightError

        def same(s):
            return (not s.get("computing") and s.get("params") == fresh["params"]
                    and s.get("raw_hash") == fresh["raw_hash"] and s.get("rendered_hash") == fresh["rendered_hash"]
                    and s.get("mean_de") == fresh["mean_de"] and not s.get("message"))

        try:
            if self.page.is_closed():
                return False
            if self.page.viewport_size != self.viewport:  # a test looked at another screen size
                self.page.set_viewport_size(self.viewport)
            if self.page.evaluate("() => document.body.classList.contains('camsim-present')"):
                return False
            self.page.locator(".w-start-over button").first.click(timeout=timeout * 1000)
            self.wait_for(same, timeout=timeout)
            wait_until(lambda: active_tab(self), timeout, "the Results tab shown", until=lambda t: t == "Results")
            # pinned designs stay through Start over (and are computed again at each change of scene)
            if "pinned=" in self.page.evaluate("() => window.location.search"):
                return False
        except (AssertionError, PlaywrightError):
            return False
        self.console.clear()
        return True


# A wait polls the page every POLL seconds while the server works, so what a poll reads is read in one call into
# the page: a Playwright locator costs a round trip of its own (``count``, ``is_visible``, ``all_inner_texts``:
# three), each resolving its selector anew, and the alert read that way took 15 ms of CPU (Chromium and
# Playwright's driver) a look against 5 ms for one ``evaluate``. Selectors pierce open shadow roots as
# Playwright's CSS does ("A B": a B anywhere under an A, shadow roots included).
_DEEP_JS = """
const deepAll = (root, sel, out = []) => {
  for (const el of root.querySelectorAll('*')) { if (el.matches(sel)) out.push(el); if (el.shadowRoot) deepAll(el.shadowRoot, sel, out); }
  return out;
};
const under = (el, sel) => deepAll(el.shadowRoot ? el.shadowRoot : el, sel, el.shadowRoot ? deepAll(el, sel) : []);
const select = css => css.split(',').flatMap(part => {
  const steps = part.trim().split(/\\s+/);
  let found = deepAll(document, steps[0]);
  for (const step of steps.slice(1)) found = found.flatMap(el => under(el, step));
  return found;
});
const shown = el => el.getClientRects().length > 0 && getComputedStyle(el).visibility !== 'hidden';
"""
#: JS: the status pane's text element, found once and kept while it is in the page (a wait reads it 20 times a
#: second: finding it walks the page's ~3,000 elements and their shadow roots, 2.5 ms of the renderer's CPU a look).
_STATUS_PRE_JS = ("const statusPre = () => { let pre = window.__camsimStatusPre;"
                  " if (!pre || !pre.isConnected) { pre = select('.camsim-status pre')[0] || null;"
                  " window.__camsimStatusPre = pre; } return pre; };")
#: JS: the text of the status pane (what a test reads of the result shown), or null before it exists.
STATUS_JS = "() => {" + _DEEP_JS + _STATUS_PRE_JS + "const pre = statusPre(); return pre ? pre.textContent : null; }"
#: JS ``([last, ms])``: the status pane's text once it differs from ``last``, or after ``ms`` milliseconds
#: (looked at every 20 ms in the page: a wait makes a round trip to the page when the status changes, not 20 times
#: a second).
STATUS_CHANGE_JS = ("async ([last, ms]) => {" + _DEEP_JS + _STATUS_PRE_JS +
                    " const t0 = performance.now(); for (;;) { const pre = statusPre();"
                    " const text = pre ? pre.textContent : null;"
                    " if (text !== last || performance.now() - t0 > ms) return text;"
                    " await new Promise(r => setTimeout(r, 20)); } }")
#: Longest a wait leaves the status pane unread in the page before its condition is evaluated again (ms): a
#: condition may read more than the status (an alert, a pane).
CHANGE_WAIT_MS = 250
_TEXTS_JS = "css => {" + _DEEP_JS + "return select(css).map(el => el.innerText); }"
_ALERT_JS = ("() => {" + _DEEP_JS + "const box = select('.camsim-alert')[0]; if (!box || !shown(box)) return '';"
             " return select('.camsim-alert p').map(el => el.innerText).join(' '); }")


_ACTIVE_TAB_JS = ("() => {" + _DEEP_JS + "const tab = select('.bk-tab').find(el => el.classList.contains('bk-active'));"
                  " return tab ? tab.textContent : null; }")


_PANE_TEXT_JS = ("css => {" + _DEEP_JS + "const e = select(css)[0]; if (!e) return ''; const r = e.shadowRoot || e;"
                 " return (r.querySelector('.markdown') || r.querySelector('div') || e).innerText; }")


def pane_text(page, css):
    """The rendered text of the first pane ``css`` selects in ``page`` ("" when there is none), in one call."""
    return _pw(page).evaluate(_PANE_TEXT_JS, css)


def active_tab(page):
    """The title of the tab ``page`` shows (None before the tabs are drawn)."""
    return _pw(page).evaluate(_ACTIVE_TAB_JS)


def inner_texts(page, css):
    """The inner texts of the elements ``css`` selects in ``page`` (shadow roots included), joined by spaces:
    Playwright's ``locator(css).all_inner_texts()`` in one call."""
    return " ".join(_pw(page).evaluate(_TEXTS_JS, css))


def compare_status(page):
    """The Compare designs tab's status (its JSON pane: designs shown, pinned, busy, sweep, ...), read in one call
    into the page; {} while the pane is empty."""
    try:
        return json.loads(inner_texts(page, ".camsim-compare-status pre"))
    except ValueError:
        return {}


def wait_compare(page, predicate, timeout=3 * TIMEOUT):
    """Poll the Compare tab's status until ``predicate(status)`` holds; return the status."""
    return wait_until(lambda: compare_status(page), timeout, "the comparison satisfies the condition",
                      until=lambda s: bool(s) and predicate(s))


def alert_text(page):
    """The text of ``page``'s alert while it is shown ("" when hidden), read in one call."""
    return _pw(page).evaluate(_ALERT_JS)


def server_log(url):
    """The text ``camsim serve`` (from :func:`explorer_server`) has logged so far."""
    from urllib.parse import urlparse

    path = ARTIFACTS / f"server-{urlparse(url).port}.log"
    return path.read_text(errors="replace") if path.exists() else ""


def wait_for_log(url, text, count=1, timeout=TIMEOUT):
    """Wait until the server's log holds ``text`` at least ``count`` times; return how many times it does."""
    deadline = time.monotonic() + timeout
    while True:
        n = server_log(url).count(text)
        if n >= count:
            return n
        if time.monotonic() > deadline:
            raise AssertionError(f"the server logged {text!r} {n} times in {timeout:.0f} s, expected {count}")
        time.sleep(POLL)


def open_card(page, title, shown_css):
    """Open the sidebar card ``title`` and wait until ``shown_css`` (its content) is visible.

    A card makes its content on the server when first opened. A click made while the sidebar moves (a box shown
    or hidden by the change before) can miss its header: the card then stayed closed and the wait for its content
    timed out (a fresh clone's run, once). The header is clicked again while its chevron still says collapsed,
    looked at twice a second (a click flips the chevron in the page at once)."""
    header = page.page.locator(".card-header", has_text=title).first
    content = page.page.locator(shown_css).first

    def opened():
        if content.is_visible():
            return True
        if header.locator(".icon-tabler-chevron-right").count():  # still collapsed
            header.click()
        return False

    wait_until(opened, what=f"the {title!r} card open, {shown_css} shown", poll=0.5)


def wait_until(fn, timeout=TIMEOUT, what="the condition", until=bool, poll=POLL):
    """Call ``fn()`` until ``until(value)`` holds (by default: the value is truthy); return that value.

    Fails with ``what`` and the last value after ``timeout`` seconds. For a wait on what a test then asserts,
    instead of one read after a fixed sleep (which fails on a loaded machine and wastes time on an idle one).
    """
    deadline = time.monotonic() + timeout
    while True:
        value = fn()
        if until(value):
            return value
        if time.monotonic() > deadline:
            shown = repr(value)
            raise AssertionError(f"never within {timeout:.0f} s: {what} (last: {shown[:500]})")
        time.sleep(poll)


def eventually(check, timeout=TIMEOUT, poll=POLL):
    """Run ``check()`` (assertions) until it passes; return its value. After ``timeout`` seconds the last
    failure is raised, saying how long it was retried: the same assertions as one run, once the page is there."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return check()
        except AssertionError as exc:
            if time.monotonic() > deadline:
                raise AssertionError(f"still failing after {timeout:.0f} s: {exc}") from exc
        time.sleep(poll)


def _pw(page):
    """The Playwright page of a :class:`Page` (or the Playwright page itself)."""
    return getattr(page, "page", page)


def next_frames(page, n=2):
    """Wait until the browser has drawn ``n`` more animation frames (what arrived before is on screen)."""
    _pw(page).evaluate("n => new Promise(done => { const step = k => k ? requestAnimationFrame(() => step(k - 1))"
                       " : done(true); step(n); })", n)


def stable_boxes(page, selectors, timeout=TIMEOUT):
    """The bounding boxes of the first element of each CSS selector, once they are the same across two
    animation frames (the layout has settled after a resize or a change of mode)."""
    locators = [_pw(page).locator(css).first for css in selectors]

    def look():
        before = [loc.bounding_box() for loc in locators]
        next_frames(page)
        after = [loc.bounding_box() for loc in locators]
        return after if before == after and None not in after else None

    return wait_until(look, timeout, f"the boxes of {', '.join(selectors)} stay put for two frames")


def shot_until(page, selector, check, what, name=None, timeout=30.0):
    """Screenshots of ``selector`` (the whole page if None) until ``check(png_bytes)`` holds and the picture is
    the same two animation frames later (drawn, not half-way); return the PNG bytes. ``name``: also saved as
    ``test-artifacts/NAME.png``."""
    pw = _pw(page)

    def take():
        if selector:
            return pw.locator(selector).first.screenshot()
        return pw.screenshot(full_page=True)

    def look():
        png = take()
        if not check(png):
            return None
        next_frames(pw)
        return png if take() == png else None

    png = wait_until(look, timeout, what)
    if name:
        ARTIFACTS.mkdir(exist_ok=True)
        (ARTIFACTS / f"{name}.png").write_bytes(png)
    return png


def settled_shot(page, selector=None, name=None, timeout=30.0):
    """A screenshot once no pane shows the loading state and the picture is the same across two frames."""
    if hasattr(page, "status"):
        wait_until(lambda: loading_count(page) == 0, timeout, "no pane shows the loading state")
    return shot_until(page, selector, lambda png: True, f"{selector or 'the page'} stays the same for two frames",
                      name, timeout)


def shot_until_changed(page, selector, before, name=None, timeout=30.0):
    """A settled screenshot of ``selector`` that differs from the screenshot ``before`` (fails after ``timeout``
    seconds if the picture never changes)."""
    return shot_until(page, selector, lambda png: png != before,
                      f"the picture of {selector or 'the page'} changes (from the one taken before)", name, timeout)


def background_share(png_bytes, background=(255, 255, 255), tol=8):
    """Share of the pixels of a screenshot (PNG bytes) within ``tol`` of the background colour."""
    import io

    import numpy as np
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png_bytes)).convert("RGB"), int)
    return float(np.mean(np.all(np.abs(a - np.array(background)) <= tol, axis=-1)))


#: The image views of the Results tab (CSS class camsim-KEY-plot holds each figure).
IMAGE_VIEWS = ("raw", "demosaiced", "rendered", "ideal", "de")

# JS: ranges and data extent of each named image figure
FIGURES_JS = """() => {
  const out = {};
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.name && m.name.startsWith('camsim-') && m.name.endsWith('-figure') && m.x_range) {
      const r = m.renderers.find(g => g.data_source && g.data_source.data.dw);
      const d = r ? r.data_source.data : null;
      out[m.name] = {x: [m.x_range.start, m.x_range.end], y: [m.y_range.start, m.y_range.end],
                     ranges: [m.x_range.id, m.y_range.id],
                     dw: d ? d.dw[0] : null, dh: d ? d.dh[0] : null};
    }
  }
  return out;
}"""


def shows_whole_image(fig, w, h, margin=0.1):
    """A figure's ranges show the whole w x h image, filling one dimension exactly and the other
    within ``margin`` (centred, as a frame of another aspect ratio shows it)."""
    (x0, x1), (y0, y1) = fig["x"], fig["y"]
    covers = x0 <= 0 and x1 >= w and y0 <= 0 and y1 >= h
    fills = ([x0, x1] == [0, w] and y1 - y0 <= (1 + margin) * h) or ([y0, y1] == [0, h] and x1 - x0 <= (1 + margin) * w)
    centred = abs((x0 + x1) - w) < 1e-6 * w and abs((y0 + y1) - h) < 1e-6 * h
    return covers and fills and centred


def figures(page):
    return page.page.evaluate(FIGURES_JS)


# JS: the titles of the Bokeh plots shown in the page wider than the room their plots give them, measured with
# the font Bokeh draws them in. A title starts over the frame's left edge and the plot's canvas cuts it at its
# right edge, where the toolbar begins ("Nyquist do...", "10 exposure..." in issue 38).
_CUT_TITLES_JS = """() => {
  const cut = [];
  const ctx = document.createElement('canvas').getContext('2d');
  for (const doc of Bokeh.documents) for (const m of doc.all_models) {
    const t = m.title;
    if (!t || typeof t !== 'object' || !t.text || !m.toolbar) continue;
    let view = null;
    for (const root of Object.values(Bokeh.index)) { try { view = root.owner.find_one(m); } catch (e) {} if (view) break; }
    if (!view || !view.frame || !view.el.isConnected || view.el.getClientRects().length === 0) continue;
    ctx.font = `${t.text_font_style} ${t.text_font_size} ${t.text_font}`;
    // a title starts over the frame's left edge; the plot's canvas (its toolbar is beside it) ends it
    const width = ctx.measureText(t.text).width, room = view.bbox.width - view.frame.bbox.left;
    cut.push({text: t.text, cut: width > room + 1, sizes: `${Math.round(width)} px where ${Math.round(room)} px show`});
  }
  return cut;
}"""


def shown_titles(page):
    """The titles of the Bokeh plots shown in ``page``."""
    return [t["text"] for t in page.page.evaluate(_CUT_TITLES_JS)]


def cut_titles(page):
    """The plot titles shown in ``page`` that do not fit over their plots (text and sizes; [] when all fit)."""
    return [f"{t['text']} ({t['sizes']})" for t in page.page.evaluate(_CUT_TITLES_JS) if t["cut"]]


def loading_count(page):
    """How many elements show a busy mark, shadow roots included: the explorer's (``--camsim-busy`` in an
    element's styles, other than ``none``: the views' grid draws it as a "Computing..." label over its
    content) or Panel's loading state (class pn-loading)."""
    return page.page.evaluate("""() => { let n = 0; function walk(root) {
        for (const el of root.querySelectorAll('*')) {
          const mark = el.style.getPropertyValue('--camsim-busy').trim();
          if (el.classList.contains('pn-loading') || (mark && mark !== 'none')) n++;
          if (el.shadowRoot) walk(el.shadowRoot); } } walk(document); return n; }""")


_BUSY_LABEL_JS = ("() => {" + _DEEP_JS + "return select('.camsim-grid').map(el => "
                  "[getComputedStyle(el, '::before').content, getComputedStyle(el, '::after').content]); }")


def busy_label(page):
    """What the views' grid draws over its content: ``[label, veil]``, the computed ``content`` of its
    ``::before`` and ``::after`` (CSS strings such as ``'"Computing..."'``; ``'none'`` when not busy)."""
    found = _pw(page).evaluate(_BUSY_LABEL_JS)
    return found[0] if found else None


#: JS: the explorer's one-line labels (``.camsim-label``) whose text is cut off (wider than their box)
LABELS_CUT_JS = """() => {
  const cut = []; let labels = 0;
  const walk = (root) => {
    for (const el of root.querySelectorAll('*')) {
      if (el.classList && el.classList.contains('camsim-label') && el.shadowRoot) {
        for (const d of el.shadowRoot.querySelectorAll('div')) {
          if (getComputedStyle(d).whiteSpace !== 'nowrap' || !d.textContent.trim() || !d.getClientRects().length) continue;
          labels++;
          if (d.scrollWidth > d.clientWidth + 1) cut.push(d.textContent.trim());
        }
      }
      if (el.shadowRoot) walk(el.shadowRoot);
    }
  };
  walk(document);
  return {labels, cut};
}"""


#: JS: the labels of the Scene tab's spectra (clicked pixels, regions), or null before the tab is built.
SPECTRA_JS = """() => {
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.constructor && m.constructor.__name__ === 'ColumnDataSource' && 'xs' in m.data && 'label' in m.data)
      return Array.from(m.data.label);
  }
  return null;
}"""
