"""Hostile text in links, file names and files is shown as text, and the page runs no script but its own.

Each payload, if it ever became markup, would set ``window.__pwned`` (an
event handler, a script, a ``javascript:`` link). They go into every
parameter a link carries (``app.state.URL_PARAMETERS`` and the comparison's
``pinned`` and ``sweep``, with the Compare tab opened), into an uploaded
file's name and into the scene name inside an uploaded file. Each page is
checked once it shows the message (or the state) the hostile value leads
to: the payload is there as literal text, no element of the page (shadow
roots included) carries it as an attribute or a script, no script ran, and
the browser reported no Content-Security-Policy violation (nothing hostile
even got as far as being blocked). The last tests check the policy itself:
the header on the page response, and that an event handler, a script or a
``javascript:`` link put into the page by other means is blocked.
Screenshots of the messages go to ``test-artifacts/xss-*.png``.
"""

from __future__ import annotations

import io
import json
import re
import time
from urllib.parse import urlencode
from urllib.request import urlopen

import numpy as np
import pytest
import scipy.io

from app_helpers import ARTIFACTS, POLL, STATUS_JS, TIMEOUT, inner_texts, new_page, wait_compare, wait_until
from camsim_explorer.state import COMPARE_PARAMETERS, PAGE_PARAMETERS, URL_PARAMETERS

pytestmark = pytest.mark.browser

# Short (messages quote at most ~40 characters of a value); none starts with [ or { (Panel's reading of the
# address drops a value that does and is not JSON). Handlers run as scripts, so __pwned is window.__pwned.
IMG = "<img src=x onerror=__pwned=1>"
SVG = "<svg onload=__pwned=2>"
SCRIPT = '"><script>__pwned=3</script>'
MDLINK = "see [x](javascript:__pwned=4)"
JSLINK = "<a href=javascript:__pwned=5>x</a>"
DETAILS = "<details open ontoggle=__pwned=6>"
FOCUS = "<input autofocus onfocus=__pwned=7>"

#: Each link: (query, the payloads its message must show as text). Values a parameter refuses are quoted by the
#: page's alert, together in one message (of at most 300 characters: the later values of a long link are cut);
#: a text the engine refuses (the sensor's fields: in the comparison's link below) is quoted by the engine's message.
LINKS = {
    "selectors": ({"camera": IMG, "monitor": SVG, "optics": SCRIPT, "gaussian_centers": MDLINK, "tab": IMG},
                  [IMG, SVG, SCRIPT, MDLINK]),
    "more selectors": ({"scene": "upload:" + SVG, "mosaic": DETAILS, "demosaic_method": FOCUS, "custom_tile": MDLINK,
                        "gaussian_widths": JSLINK}, ["upload:" + SVG, DETAILS, FOCUS, MDLINK, JSLINK]),
    "a chart, numbers": ({"scene": "uniform:" + SVG, "viewing": FOCUS, "light": IMG, "alpha": SVG, "distance": IMG,
                          "exposure": IMG, "f_stop": IMG, "noise_sigma": IMG, "bits": IMG, "seed": IMG,
                          "wavelength": IMG, "render_method": IMG, "illuminant": IMG, "metric": IMG},
                         ["uniform:" + SVG, FOCUS, IMG]),
}
#: Pinned designs: the first is computed (10 m away: a small image, computed quickly), the second refused.
PINNED = [{"name": IMG, "params": {"custom_tile": SVG, "distance": 10.0}},
          {"name": SCRIPT, "params": {"camera": "gaussian-3", "gaussian_centers": MDLINK}}]
SWEEP = {"parameter": DETAILS, "values": [1, 2]}
#: The tabs: (title, an element it shows, words in it).
TABS = [("Scene", ".camsim-scene-meta table", "Wavelengths (nm)"), ("Camera", ".camsim-camera-info p", "sensors"),
        ("Image quality", ".camsim-quality p", "PSNR"), ("Compare designs", ".camsim-sweep-message p", "Pin designs"),
        ("Experiments", ".camsim-exp-message p", "Figure 1.14"), ("Optics & sensor", ".camsim-physical-table table",
                                                                  "f-number"),
        ("Results", ".camsim-stats p", "mean dE")]

#: In the page: the CSP violations the browser reports (they bubble out of shadow roots).
WATCH_JS = """window.__csp = [];
document.addEventListener('securitypolicyviolation',
  e => window.__csp.push(e.violatedDirective + ' ' + (e.blockedURI || '') + ' ' + (e.sample || '')), true);"""

#: Elements (document and shadow roots) that carry a payload as markup: an event-handler attribute, a link or
#: source holding it, a script or frame holding it. A payload shown as text is in text nodes only.
INJECTED_JS = """() => {
  const found = [];
  const walk = root => {
    for (const el of root.querySelectorAll('*')) {
      for (const name of el.getAttributeNames()) {
        const value = el.getAttribute(name) || '';
        if (name.startsWith('on')) found.push(`${el.tagName} ${name}=${value}`);
        if (['href', 'src', 'srcdoc', 'action', 'formaction', 'data', 'xlink:href'].includes(name)
            && /pwned|javascript:/i.test(value)) found.push(`${el.tagName} ${name}=${value}`);
      }
      if (['SCRIPT', 'IFRAME'].includes(el.tagName) && /pwned/.test(el.textContent + (el.srcdoc || '')))
        found.push(`${el.tagName} ${el.textContent.slice(0, 80)}`);
      if (el.shadowRoot) walk(el.shadowRoot);
    }
  };
  walk(document);
  return found;
}"""


class Tab:
    """A browser tab on the explorer that records CSP violations and console messages from its first script."""

    def __init__(self, browser, url, wait=True):
        """``wait=False``: return once the server has answered (the page goes on loading meanwhile)."""
        self.page = new_page(browser)
        self.page.set_default_timeout(TIMEOUT * 1000)
        self.console = []
        self.page.on("console", lambda m: self.console.append((m.type, m.text)))
        self.page.on("pageerror", lambda e: self.console.append(("pageerror", str(e))))
        self.page.add_init_script(WATCH_JS)
        self.response = self.page.goto(url, wait_until="load" if wait else "commit")
        if wait:
            self.page.locator(".camsim-status pre").first.wait_for(state="attached")

    def text(self, css):
        """The visible text of the elements ``css`` selects (Playwright's CSS looks into shadow roots)."""
        return inner_texts(self.page, css)

    def wait_text(self, css, needle, timeout=TIMEOUT):
        """Wait until the text of ``css`` holds ``needle``; return that text."""
        deadline = time.monotonic() + timeout
        while True:
            text = self.text(css)
            if needle in text:
                return text
            if time.monotonic() > deadline:
                raise AssertionError(f"{css} never showed {needle!r}; it shows {text[:500]!r}")
            self.page.wait_for_timeout(POLL * 1000)

    def status(self):
        try:
            return json.loads(self.page.evaluate(STATUS_JS) or "")
        except ValueError:
            return {}

    def wait_status(self, predicate, timeout=TIMEOUT):
        deadline = time.monotonic() + timeout
        while True:
            s = self.status()
            if s and predicate(s):
                return s
            if time.monotonic() > deadline:
                raise AssertionError(f"the status never satisfied the condition; last: {s}")
            self.page.wait_for_timeout(POLL * 1000)

    def open_tab(self, title):
        self.page.locator(".bk-tab").filter(has_text=title).first.click()

    def assert_safe(self):
        """Nothing hostile became markup, no script ran, and no policy had to block anything."""
        assert self.page.evaluate(INJECTED_JS) == []
        assert self.page.evaluate("window.__pwned") is None
        assert self.page.evaluate("window.__csp") == []
        assert not [m for m in self.console if "Content Security Policy" in m[1]]

    def shot(self, name, css=None):
        path = str(ARTIFACTS / f"xss-{name}.png")
        if css:
            self.page.locator(css).first.screenshot(path=path)
        else:
            self.page.screenshot(path=path, full_page=True)

    def close(self):
        self.page.close()


def _link(server, query):
    return server + "?" + urlencode(query)


def test_every_link_parameter_is_covered():
    """The links below put a payload into every parameter the explorer reads from its address."""
    covered = {k for query, _ in LINKS.values() for k, v in query.items() if "pwned" in v}
    assert covered | {"sensor", "pinned", "sweep"} == set(URL_PARAMETERS) | set(COMPARE_PARAMETERS) | set(PAGE_PARAMETERS)


@pytest.fixture(scope="module")
def link_tabs(browser, server):
    """A tab on each of ``LINKS``, opened together (the browser loads one while the server makes the next)."""
    tabs = {}
    try:
        for name, (query, _) in LINKS.items():
            tabs[name] = Tab(browser, _link(server, query), wait=False)
        yield tabs
    finally:
        for tab in tabs.values():
            tab.close()


@pytest.mark.parametrize("name", list(LINKS))
def test_a_hostile_link_is_quoted_as_text(link_tabs, name):
    tab = link_tabs[name]
    shown = LINKS[name][1]
    text = tab.wait_text(".camsim-alert p", shown[0])
    for payload in shown:
        assert payload in text
    tab.assert_safe()
    tab.shot(name.replace(" ", "-").replace(",", ""), ".camsim-alert")


def test_hostile_pinned_designs_and_sweep_are_shown_as_text(browser, server):
    """Names and parameters of pinned designs, and the sweep's parameter, from a link; the Compare tab opened.
    The link's sensor fields are refused by the engine, whose message quotes them."""
    tab = Tab(browser, _link(server, {"sensor": SVG, "pinned": json.dumps(PINNED), "sweep": json.dumps(SWEEP)}))
    try:
        assert SVG in tab.wait_text(".camsim-alert p", "Refused: sensor")
        tab.shot("sensor", ".camsim-alert")
        tab.open_tab("Compare designs")
        # the second design is refused (its Gaussian centres), quoting its name and the value
        message = tab.wait_text(".camsim-compare-message p", "refused")
        assert SCRIPT in message and MDLINK in message
        assert DETAILS in tab.wait_text(".camsim-sweep-message p", "Refused")
        table = tab.wait_text(".camsim-compare-table table", IMG)  # the first design's name heads a column
        # its custom tile is beside the camera's own mosaic: not used, so not listed as a difference (the names
        # are the user text the table shows, escaped)
        assert SVG not in table and "custom_tile" not in table
        # the status pane and the unpin list follow the table (a later message): waited for, not read once
        status = wait_compare(tab, lambda s: "pinned" in s, TIMEOUT)
        assert status["pinned"] == [IMG, SCRIPT]
        options = wait_until(lambda: tab.page.locator(".w-pinned select option").all_inner_texts(), TIMEOUT,
                             "the unpin list names both designs", until=lambda o: len(o) >= 2)
        assert IMG in options and SCRIPT in options
        tab.assert_safe()
        tab.shot("compare")
    finally:
        tab.close()


def _npz(name):
    rng = np.random.default_rng(3)
    buf = io.BytesIO()
    np.savez(buf, data=rng.uniform(0.1, 1.0, (12, 16, 31)), wavelengths=np.arange(400, 710, 10.0))
    return {"name": name, "mimeType": "application/octet-stream", "buffer": buf.getvalue()}


def _mat(name, scene_name):
    """An ISETCam scene whose ``name`` field holds ``scene_name``."""
    wave = np.arange(400, 710, 10.0)
    buf = io.BytesIO()
    scipy.io.savemat(buf, {"scene": {"name": scene_name, "spectrum": {"wave": wave},
                                     "data": {"photons": np.full((10, 14, wave.size), 1e15)}, "distance": 1.0,
                                     "wAngular": 10.0}})
    return {"name": name, "mimeType": "application/octet-stream", "buffer": buf.getvalue()}


def test_hostile_upload_names_are_shown_as_text(browser, server):
    """A file named with markup, a scene whose name inside the file is markup, and a refused file's name."""
    tab = Tab(browser, server)
    try:
        tab.wait_status(lambda s: s.get("mean_de") is not None)
        tab.open_tab("Scene")
        upload = tab.page.locator(".w-upload input[type=file]").first
        # an .npz scene is named after its file
        upload.set_input_files(files=[_npz(IMG + ".npz")])
        tab.wait_status(lambda s: s["params"]["scene"] == "upload:" + IMG)
        assert IMG in tab.wait_text(".camsim-scene-meta table", IMG)
        tab.assert_safe()
        # an ISETCam .mat names its scene inside the file
        upload.set_input_files(files=[_mat(DETAILS + ".mat", SCRIPT)])
        tab.wait_status(lambda s: s["params"]["scene"] == "upload:" + SCRIPT)
        assert SCRIPT in tab.wait_text(".camsim-scene-meta table", SCRIPT)
        wait_until(lambda: "upload:" + SCRIPT in tab.page.locator(".w-scene select option").all_inner_texts(),
                   what="the uploaded scene's name in the scene list")
        tab.shot("scene-meta", ".camsim-scene-meta")
        tab.assert_safe()
        # a file that is not a scene: the refusal quotes its name
        upload.set_input_files(files=[{"name": MDLINK + SVG + ".npz", "mimeType": "application/octet-stream",
                                       "buffer": b"not a zip"}])
        text = tab.wait_text(".camsim-alert p", "Upload refused")
        assert MDLINK + SVG + ".npz" in text
        tab.shot("upload-refused", ".camsim-alert")
        tab.assert_safe()
    finally:
        tab.close()


def test_the_page_carries_a_content_security_policy_that_blocks_injected_script(browser, server):
    """The policy on the page response; a normal walk under it (every tab, a few changes) that it never has to
    block; then markup put into the page by other means (here the test itself) runs no script: an event
    handler, an inline script, a ``javascript:`` link."""
    tab = Tab(browser, server)
    try:
        policy = tab.response.headers.get("content-security-policy", "")
        directives = {d.split()[0]: d.split()[1:] for d in policy.split(";") if d.strip()}
        scripts = directives["script-src"]
        assert "'self'" in scripts and "'unsafe-inline'" not in scripts and "'strict-dynamic'" not in scripts
        assert not [s for s in scripts if s.startswith(("http", "*", "data:"))]  # no foreign or data: scripts
        assert directives["script-src-attr"] == ["'none'"] and directives["object-src"] == ["'none'"]
        nonces = [s for s in scripts if s.startswith("'nonce-")]
        assert len(nonces) == 1
        # every inline script of the page carries the response's nonce; those with a source come from the server
        nonce = nonces[0][len("'nonce-"):-1]
        for attrs in re.findall(r"<script([^>]*)>", tab.response.text()):
            assert f'nonce="{nonce}"' in attrs or re.search(r'\ssrc="static/', attrs), attrs
        with urlopen(server + "?seed=1", timeout=TIMEOUT) as other:  # a nonce per response
            assert "'nonce-" in other.headers["Content-Security-Policy"] and nonce not in other.headers[
                "Content-Security-Policy"]
        # a normal walk: a few changes, every tab renders, and nothing the policy had to block
        box = tab.page.locator(".w-noise input").first
        box.fill("4")
        box.press("Enter")
        tab.wait_status(lambda s: s["params"]["noise_sigma"] == 4 and not s["computing"])
        for title, css, words in TABS:
            tab.open_tab(title)
            tab.wait_text(css, words)
        tab.page.locator(".w-present button").first.click()  # a CustomJS callback: the policy lets it run
        tab.page.wait_for_function("document.body.classList.contains('camsim-present')")
        tab.page.locator(".w-present button").first.click()
        tab.page.locator(".w-de-scale button").filter(has_text="fixed").first.click()
        tab.wait_text(".camsim-de-label span", "fixed colours")
        tab.assert_safe()
        assert not [m for m in tab.console if m[0] in ("error", "pageerror")]
        # markup that got into the page anyway: blocked, each reported as a violation
        tab.page.evaluate("""() => {
          const box = document.createElement('div');
          box.innerHTML = '<img src=x onerror="window.__pwned=1"><a id=xss-link href="javascript:window.__pwned=2">x</a>';
          document.body.append(box);
          const s = document.createElement('script');
          s.textContent = 'window.__pwned = 3';
          document.body.append(s);
          document.getElementById('xss-link').click();
        }""")
        tab.page.wait_for_function("window.__csp.length >= 3")
        blocked = " ".join(tab.page.evaluate("window.__csp"))
        assert "script-src-attr" in blocked and "script-src-elem" in blocked
        assert tab.page.evaluate("window.__pwned") is None
    finally:
        tab.close()
